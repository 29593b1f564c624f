// Helpers shared by the command implementations.
#pragma once

#include "io/archive.hh"
#include "io/scene_reader.hh"
#include "model/design_space.hh"
#include "model/effects.hh"
#include "model/network.hh"
#include "solver/design_fallback.hh"
#include "solver/design_optimizer.hh"
#include "solver/equilibrium.hh"

#include <Eigen/Core>

#include <optional>
#include <string>
#include <vector>

namespace rodmesh::cli {

// Everything about an output path that can be known before a run (exit 2,
// nothing written): throws InputError naming `flag`, the path and why if the
// path is empty, names a directory (trailing '/', ".", "..", an existing
// directory) or an existing file that is not a regular file, is one of
// `inputs` (the same file under any name), has a name longer than the file
// system allows (with the writer's ".tmp.PID" suffix), or lies in a
// directory that does not exist, is not writable or cannot hold a new file
// (probed by creating an unnamed one).
void checkOutputPath(const std::string& path, const std::string& flag, const std::vector<std::string>& inputs = {});

// optimize: the memory the design needs, checked before anything of that
// size is allocated (exit 2): with `reduced`, the dense inverse-Hessian
// approximation of BFGS (8 n^2 bytes for n design values up to
// BfgsOptions::denseLimit; limited memory above) must fit in half of the
// machine's physical memory (and of RLIMIT_AS when set). Throws InputError
// naming design.control_points_per_rod.
void checkOptimizeMemory(const Scene& scene, const DesignSpace& space, bool reduced);

// Fills the /model part of an archive.
void describeModel(Archive& a, const RodNetwork& net, const EffectSet& fx, long long dofsPerPose);

// The scene solved in 3D: a copy of `scene` whose "effects" are the
// inferred ones of `inferred` plus twist (simulate and optimize solve an
// inferred-planar scene again so when an in-plane equilibrium is unstable
// out of plane).
Scene spatialScene(const Scene& scene, const EffectSet& inferred);

// Prints the scene warnings and the effects summary to stderr.
void printEffects(const EffectSet& fx, const RodNetwork& net, long long dofsPerPose);

// ---- Building archives: the parts simulate and optimize fill alike.

// How one pose's equilibrium solve went (the /poses/NAME extension
// attributes): the solver's summary (its outcome gives the status:
// converged, not_converged or failed) and the stability of the state.
struct PoseSolveSummary {
  std::optional<SolveSummary> solve;  // unset: no status, residual, iterations or time written
  int outOfPlaneStable = -1;  // 1/0 for planar Newton solves, -1 unknown (not written)
  int stable = -1;            // 1/0: the state is a stable equilibrium; -1 unknown (not written)
  std::optional<double> smallestEigenvalue;  // N/m
  std::optional<double> unloadedSmallestEigenvalue;  // N/m, of the rest state under the pose's supports
  MatX3 criticalPoints;                      // load factor, eigenvalue (N/m), jump (m) per row
  int imperfectionSensitive = -1;            // 1/0 (PoseResult::imperfectionSensitive); -1 not judged
  std::optional<double> imperfectionGap;     // m, when finite
};

// The summary of a pose solved by Newton (simulateAll): non-finite loads or
// states, and problems without a solution, fail.
PoseSolveSummary newtonSolveSummary(const PoseResult& pr);

// "pose 'NAME' is at a critical point (...)": what a stable equilibrium with
// PoseResult::atCriticalPoint() means for the object.
std::string criticalPointNote(const PoseResult& p);
// "pose 'NAME' is imperfection-sensitive (...)": what
// PoseResult::imperfectionSensitive() means for the object.
std::string imperfectionNote(const PoseResult& p);

// Row-per-entry matrices for the archive.
MatX3 toRows(const std::vector<Vec3>& v);
MatX2 toRows(const std::vector<Vec2>& v);

// Sets /rest/positions and /design/radii (V x 3, V x 2).
void setRestAndRadii(Archive& a, const std::vector<Vec3>& rest, const std::vector<Vec2>& radii);

// One /poses/NAME entry. `twist` is the edge twist (nullptr when twist is not
// simulated: nothing is written); `target` may be empty, else it has one entry
// per vertex and the pose gets `target` and `rms_error` (RMS distance of
// `positions` to it, in m).
ArchivePose makeArchivePose(const std::string& name, const std::vector<Vec3>& positions, const Eigen::VectorXd* twist,
                            const std::vector<Vec3>& target, const PoseSolveSummary& solve = {});

// optimize: records the equilibrium under the initial design and the
// equilibrium gap, the largest distance between the optimizer's own positions
// and the re-solved `positions` already in the pose (m).
void setOptimizeResult(ArchivePose& p, const std::vector<Vec3>& initialPositions,
                       const std::vector<Vec3>& optimizerPositions);

// optimize: the archive of a run (all but `version` and method-specific
// extension attributes): the design `chosen` (chooseArchivedDesign,
// solver/design_fallback.hh) with its rest shape, radii and control points,
// every pose as re-solved from rest under it, with the equilibrium under the
// initial design and, for the final design, the gap to the optimizer's own
// equilibrium; the optimizer's history and summary, `chosen.note` appended to
// its message; root attribute `archived_design`. Status: converged when the
// optimizer converged and the final design re-solved; failed after a
// numerical failure; otherwise not_converged. `method`: sand or reduced.
Archive optimizeArchive(const Scene& scene, const SceneModel& model, const DesignSpace& space,
                        const DesignOptimizerResult& r, const ArchivedDesign& chosen, const std::string& method);

// Contract §3 RMS error over every pose and vertex, in m; nullopt unless every
// pose has a target.
std::optional<double> overallRmsError(const Archive& a);

// Formats seconds as "12.3 ms" / "1.23 s".
std::string formatSeconds(double s);

}  // namespace rodmesh::cli
