// The HDF5 result archive, "rodmesh-archive/1" (../shared/contracts.md §3).
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
//   /poses/NAME/positions      V x 3
//   /poses/NAME/twist          E       (when twist is simulated)
//   /poses/NAME/target         V x 3   (when given)
//   /poses/NAME attrs          residual_norm, rms_error (when a target is given);
//                              extensions: status, iterations, time_s
//   /frames/NAME/positions     T x V x 3, /frames/NAME/time T (dynamics)
//   /history/{iteration,time_s,objective,rms_error}   (optimize only)
//
// writeArchive writes to a temporary file next to the target and renames it
// into place only when complete.
#pragma once

#include <Eigen/Core>

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
};

struct ArchiveFrames {
  std::string name;
  Eigen::VectorXd time;        // T
  std::vector<MatX3> positions;  // T entries of V x 3
};

struct ArchiveHistory {
  std::vector<double> iteration, timeSeconds, objective, rmsError;
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
  std::vector<ArchivePose> poses;
  std::vector<ArchiveFrames> frames;
  std::optional<ArchiveHistory> history;
  // Extra string attributes on /, e.g. solver reports.
  std::map<std::string, std::string> extraRootAttributes;
};

// Throws std::runtime_error if the file cannot be written; never leaves a
// partial file at `path`.
void writeArchive(const Archive& a, const std::string& path);

// Throws std::runtime_error with a clear message if the file is missing or is
// not a rodmesh archive.
Archive readArchive(const std::string& path);

}  // namespace rodmesh
