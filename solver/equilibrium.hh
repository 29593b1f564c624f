// Static equilibrium of every pose of a scene (poses are independent).
#pragma once

#include "model/effects.hh"
#include "model/network.hh"
#include "model/pose_system.hh"
#include "model/scene_model.hh"
#include "solver/newton.hh"
#include "solver/stability.hh"  // outOfPlaneStable

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace rodmesh {

struct PoseResult {
  std::string name;
  std::vector<Vec3> positions;
  Eigen::VectorXd twist;  // per edge, material frame from the transported rest frame; zeros without twist
  Eigen::VectorXd dofs;
  PoseState state;  // the returned state (dofs, charts, load factor, internal variables)
  NewtonReport report;
  std::optional<double> rmsError;  // m, when the pose has a target
  // Planar solves only: whether the in-plane equilibrium is also stable
  // against out-of-plane motion and twist in the full 3D model.
  std::optional<bool> outOfPlaneStable;
  // Stability of the returned state (solver/newton.hh stability(): inertia of
  // the Hessian at its load factor and the eigenvalue of smallest magnitude,
  // N/m); unset when the state could not be judged (a numerical failure, an
  // unsupported load).
  std::optional<bool> stable;
  std::optional<double> smallestEigenvalue;
  // The same eigenvalue of the unloaded structure (the design's rest state
  // under the pose's supports), N/m: the scale that smallestEigenvalue is
  // judged against (atCriticalPoint).
  std::optional<double> unloadedSmallestEigenvalue;
  // A stable state with at most kCriticalStiffnessRatio of the unloaded
  // structure's smallest stiffness: at (or next to) a limit or bifurcation
  // point, where a little more load or a small imperfection of the printed
  // object makes it snap or buckle to another equilibrium.
  bool atCriticalPoint() const;
  // Imperfection sensitivity (addImperfectionSensitivity): the largest vertex
  // distance between this equilibrium and the ones the loading path reaches
  // with every radius changed by ±kImperfectionRadiusChange (m; infinity
  // when such a solve fails), and the largest vertex displacement from the
  // rest shape it is judged against (m; at least 1e-6 of the structure's
  // size, the diagonal of the rest shape's bounding box).
  std::optional<double> imperfectionGap;
  std::optional<double> largestDisplacement;
  // The gap exceeds kImperfectionGapRatio of the largest displacement: a
  // printed object, whose radii are never exact, may well reach another
  // equilibrium (the pose sits next to a bifurcation or limit point passed
  // on its loading path, or at one).
  bool imperfectionSensitive() const;
};

// The radius change of the imperfection test and the gap, relative to the
// largest displacement, above which a pose is called sensitive. A smooth
// response to relative radius changes e moves a vertex by about 4 e (bending
// stiffness goes as r^4) of its displacement; the ratio allows 25 times that
// before a response is called a jump.
constexpr double kImperfectionRadiusChange = 1e-3;
constexpr double kImperfectionGapRatio = 0.1;

// `design` with every radius scaled by 1 + sign * change * s, s = ±1 a fixed
// pseudo-random pattern over the vertices and the two radii (the same for
// every call): the imperfection of addImperfectionSensitivity.
Design radiusImperfection(const Design& design, double change, int sign);

struct SimulationResult {
  std::vector<PoseResult> poses;
  bool allConverged = true;
  int dofsPerPose = 0;  // unknowns of the first pose
};

using PoseProgress = std::function<void(int pose, const PoseResult&)>;

// Solves every pose from its rest configuration under the given design.
// `unloadedStiffness`: also the unloaded structure's smallest eigenvalue per
// pose (PoseResult::unloadedSmallestEigenvalue, one more factorization per
// pose), for results that are reported; the optimizers' many checks skip it.
// `threads`: poses solved in parallel (solver/parallel.hh; the result does
// not depend on it); `progress` is called on the calling thread, in pose
// order, after every pose was solved when threads > 1.
SimulationResult simulateAll(const SceneModel& model, const Design& design, const NewtonOptions& options,
                             const PoseProgress& progress = {}, bool unloadedStiffness = false, int threads = 1);

// Sets PoseResult::unloadedSmallestEigenvalue of every pose of `sim` (solved
// under `design`) that has a stability judgement and lacks it.
void addUnloadedStiffness(const SceneModel& model, const Design& design, SimulationResult& sim);

// Sets PoseResult::imperfectionGap and largestDisplacement of every pose of
// `sim` (solved under `design`) that converged: each pose solved along its
// loading path under radiusImperfection(design, kImperfectionRadiusChange,
// ±1). Two loading paths per pose; for reported designs (`optimize`'s
// archive), which optimizers tend to push against the edge of the region
// whose loading paths reach the designed branch.
// `threads`: poses in parallel, as simulateAll.
void addImperfectionSensitivity(const SceneModel& model, const Design& design, const NewtonOptions& options,
                                SimulationResult& sim, int threads = 1);

// Empty if the pose's loads can be in equilibrium; otherwise why not (no
// held vertex and a non-zero net force).
std::string unsupportedLoad(const Scene& scene, const RodNetwork& network, const EffectSet& effects, int pose,
                            const Design& design);

// RMS distance to the target over the given positions (m).
double rmsError(const std::vector<Vec3>& x, const std::vector<Vec3>& target);
// Contract §3 RMS error over every pose and vertex of a simulation (from each
// pose's rmsError), in m; NaN unless every pose has a target.
double rmsError(const SimulationResult& sim);

}  // namespace rodmesh
