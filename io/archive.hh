// The HDF5 result archive, "rodmesh-archive/1" (docs/formats.md §3).
//
// Layout (all float64, SI units):
//   /            attrs  format, version, command, status            (strings)
//   /scene       string dataset, the input scene JSON verbatim
//   /model       attrs  effects (comma-separated), dofs_per_pose, n_vertices,
//                       n_edges, n_rods, n_connections; extensions: planar,
//                       effects_reason
//   /rest/positions            V x 3
//   /design/radii              V x 2   [r_t, r_n]
//   /design/initial_radii      V x 2   (optimize only)
//   /design/control_points/{radii C x 2, rest_displacement C x 3, rod int C,
//                           arc_fraction C, vertex int C}     (optimize only)
//   /poses/NAME/positions      V x 3
//   /poses/NAME/twist          E       (when twist is simulated)
//   /poses/NAME/target         V x 3   (when given)
//   /poses/NAME attrs          residual_norm, rms_error (when a target is given);
//                              extensions: status, iterations, time_s
//   /poses/NAME/initial_positions V x 3, attr equilibrium_gap  (optimize only)
//   /frames/NAME/positions     T x V x 3, /frames/NAME/time T (dynamics)
//   /history/{iteration (int64), time_s, objective, rms_error, level (int64),
//             constraint_violation, gradient_norm, phase (string)}  (optimize only)
//   /            attrs  (optimize only) method, iterations (int64), time_s, message
//
// writeArchive writes into an unnamed file (O_TMPFILE) in the directory of
// the target, links it as PATH.tmp.PID once complete and renames that into
// place: a process killed at any moment, even by SIGKILL, leaves no partial
// file, and PATH is either the previous archive or the new one. Where the
// file system has no O_TMPFILE, PATH.tmp.PID itself is written. While it
// writes, SIGINT and SIGTERM remove PATH.tmp.PID (if it exists) and end the
// process with status 130 / 143 (io/interrupt.hh); temporary files of the same
// PATH left by processes that no longer exist are removed before writing.
// Test hook: the environment variable RODMESH_TEST_SLOW_WRITE=SECONDS makes
// writeArchive sleep that long between completing the (unnamed) temporary
// file and naming it, so that tests can interrupt a write; never set it
// otherwise.
#pragma once

#include "model/scene.hh"

#include <Eigen/Core>

#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace rodmesh {

using MatX3 = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using MatX2 = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;

struct ArchivePose {
  std::string name;
  MatX3 positions;
  Eigen::VectorXd twist;  // empty when twist is not simulated
  MatX3 target;           // empty when no target
  double residualNorm = 0.0;
  std::optional<double> rmsError;
  std::string status;  // extension: converged / not_converged / failed
  int iterations = 0;
  double timeSeconds = 0.0;
  int outOfPlaneStable = -1;  // extension: 1/0 for planar solves, -1 unknown (not written)
  // Extensions (Newton solves): 1/0 whether the archived state is a stable
  // equilibrium (-1 unknown, not written), the stiffness eigenvalue of
  // smallest magnitude there (N/m), and the critical points the loading path
  // passed, one row each: load factor, smallest stiffness eigenvalue (N/m),
  // jump (m).
  int stable = -1;
  std::optional<double> smallestEigenvalue;
  // Extension: the same eigenvalue of the unloaded structure (the rest state
  // under the pose's supports), N/m; a stable state with at most
  // kCriticalStiffnessRatio (solver/newton.hh) of it is at a critical point.
  std::optional<double> unloadedSmallestEigenvalue;
  MatX3 criticalPoints;
  // Extension (optimize's archived design): 1/0 whether the pose is
  // imperfection-sensitive (-1 unknown, not written) and the largest vertex
  // distance to the equilibria its loading path reaches with every radius
  // changed by ±kImperfectionRadiusChange (m; not written when such a solve
  // failed, which counts as sensitive).
  int imperfectionSensitive = -1;
  std::optional<double> imperfectionGap;
  // optimize only:
  MatX3 initialPositions;                // equilibrium under the initial design; empty: not written
  std::optional<double> equilibriumGap;  // m: largest |optimizer position - re-solved position|
};

struct ArchiveFrames {
  std::string name;
  Eigen::VectorXd time;        // T
  std::vector<MatX3> positions;  // T entries of V x 3
};

// One entry per optimizer iteration. `iteration`, `timeSeconds`, `objective`
// and `rmsError` are always written with the group; the other vectors are
// written when non-empty. Every written vector has the length of `iteration`.
struct ArchiveHistory {
  std::vector<long long> iteration;         // int64
  std::vector<double> timeSeconds;          // s since the start of the run
  std::vector<double> objective;            // f (contract §4), m^2
  std::vector<double> rmsError;             // m
  std::vector<long long> level;             // schedule level (0, 1, 2: control points in use), int64
  std::vector<double> constraintViolation;  // N: equilibrium violation (SAND; 0 for reduced)
  std::vector<double> gradientNorm;         // extension: norm of the objective's (reduced) gradient
  std::vector<std::string> phase;           // extension: "radii", "rest_shape" or "joint" (both)
  // Extension: RMS (m), re-solved from rest, of the best design confirmed so
  // far at this iteration (solver/design_monitor.hh); NaN before the first.
  std::vector<double> confirmedRms;
  // Extension, Newton method: Hessian-vector products (CG iterations) of the
  // accepted step (-1 for iterates without one, e.g. the initial design) and
  // the trust radius after it (NaN likewise).
  std::vector<long long> cgIterations;
  std::vector<double> trustRadius;
};

// The design's control points (contract §4), C of them.
struct ArchiveControlPoints {
  MatX2 radii;                      // C x 2 [r_t, r_n]; empty: not written
  MatX3 restDisplacement;           // C x 3 [dx, dy, dz]; empty: not written
  std::vector<int> rod;             // C: owning rod, -1 for a shared end control point
  std::vector<double> arcFraction;  // C: arc-length fraction along `rod` in [0, 1]; 0 for a shared end
  std::vector<int> vertex;          // extension, C: scene vertex of a shared end, -1 for an interior one
  // Extension, attributes of /design/control_points when radii were free:
  // how the radius bounds hold the design (solver/bound_activity.hh).
  struct RadiusBounds {
    double min = 0.0, max = 0.0;                    // radius_min, radius_max [m]: the bounds in use
    long long atMin = 0, atMax = 0;                 // radii_at_min, radii_at_max: values of `radii` held there
    double minElasticity = 0.0, maxElasticity = 0.0;  // elasticity_min (>= 0), elasticity_max (<= 0):
                                                      // d ln f / d ln bound, first order
  };
  std::optional<RadiusBounds> radiusBounds;
};

// Root attributes written by optimize.
struct ArchiveOptimizeSummary {
  std::string method;        // "sand", "reduced" or "newton"
  long long iterations = 0;  // optimizer iterations over the whole schedule (int64)
  double timeSeconds = 0.0;  // wall time of the optimization [s]
  std::string message;       // why the optimizer stopped, for humans
  double evaluationSeconds = 0.0;  // of timeSeconds: in model evaluations (energies, derivatives, Newton)
  double solverSeconds = 0.0;      // of timeSeconds: in the optimizer itself (SAND: Ipopt + MUMPS)
  long long peakMemoryBytes = 0;   // peak resident memory of the process
  // Extension: objective evaluations of the run (reduced and newton: each
  // solves every pose's equilibrium; sand: Ipopt's function evaluations);
  // -1: not written.
  long long evaluations = -1;
};

struct Archive {
  std::string format = "rodmesh-archive/1";
  std::string version;
  std::string command;
  std::string status;  // converged, not_converged, failed
  std::string sceneJson;

  // /model attributes
  std::string effects;        // comma-separated
  std::string effectsReason;  // extension: why each effect is on or off
  long long dofsPerPose = 0;
  long long nVertices = 0, nEdges = 0, nRods = 0, nConnections = 0;
  int planar = 0;

  MatX3 restPositions;
  MatX2 radii;
  std::optional<MatX2> initialRadii;
  std::optional<ArchiveControlPoints> controlPoints;  // optimize only
  std::vector<ArchivePose> poses;
  std::vector<ArchiveFrames> frames;
  std::optional<ArchiveHistory> history;           // optimize only
  std::optional<ArchiveOptimizeSummary> optimize;  // optimize only: root attributes
  // Extra string attributes on /, e.g. solver reports.
  std::map<std::string, std::string> extraRootAttributes;
};

// Throws std::runtime_error if the file cannot be written or the archive is
// inconsistent (history vectors or control point arrays of different lengths,
// initial positions of the wrong size); never leaves a partial file at `path`.
void writeArchive(const Archive& a, const std::string& path);

// The bytes of the HDF5 file writeArchive would write (built in memory).
std::string writeArchiveImage(const Archive& a);

// ---- Reading (io/archive_reader.cc). Archives are untrusted input: nothing
// is used before it is checked, and every problem is an InputError
// (io/scene_reader.hh) with one message "FILE: /path/of/dataset: what, got
// VALUE" ("/model attribute n_vertices" for attributes). HDF5's own error
// printing is switched off.
//
// readArchive checks the structure: the format attribute; the presence of
// what every archive has (root attributes format, version, command, status;
// /scene; /model and its counts; /rest/positions; /design/radii; /poses with
// at least one pose, each with positions and residual_norm); links that are
// hard links to groups or datasets as expected; types (numbers, strings,
// integers that are whole numbers in range); shapes, V x 3 and V x 2 with V
// the rows of /rest/positions, T x V x 3 frames with T times, history and
// control point series of one length, twist of n_edges entries; sizes, which
// are checked against the size of the file before anything is allocated.
// Numbers may still be non-finite (validateArchive checks values).
Archive readArchive(const std::string& path);

// readArchive with the HDF5 library in a child process: a file that makes the
// library crash or loop (it has such bugs on corrupted input) is an
// InputError naming the object being read, never a crash or a hang of this
// process. The child sends the archive back rebuilt (writeArchiveImage),
// which is then read here. Each HDF5 call gets 4 s plus 0.1 s per MB it may
// produce. Falls back to readArchive if no process can be started.
Archive readArchiveIsolated(const std::string& path);

// The same from an HDF5 file image in memory (`size` bytes at `data`);
// `name` stands for the file in messages.
Archive readArchiveImage(const void* data, std::size_t size, const std::string& name);

// Values and agreement with the scene, for an archive read from `path`:
// status is converged, not_converged or failed; every number finite (a
// residual_norm may be inf or nan only for a pose whose status is not
// converged), radii positive, frame times non-decreasing; the scene's vertex,
// rod and edge counts match /rest/positions and /model; frames belong to
// poses; control points name existing rods and vertices, arc fractions in
// [0, 1]. Throws InputError.
void validateArchive(const Archive& a, const Scene& scene, const std::string& path);

// What `inspect` and `export` read: readArchiveIsolated, the scene parsed
// from /scene (messages say FILE:/scene), validateArchive.
struct LoadedArchive {
  Archive archive;
  Scene scene;
};
LoadedArchive loadArchive(const std::string& path);

}  // namespace rodmesh
