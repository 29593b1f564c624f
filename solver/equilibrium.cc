#include "solver/equilibrium.hh"

#include "model/stiffness.hh"
#include "solver/modified_ldlt.hh"
#include "solver/parallel.hh"

#include <Eigen/Geometry>
#include <Eigen/SparseCholesky>

#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>
#include <cstdio>

namespace rodmesh {

double rmsError(const std::vector<Vec3>& x, const std::vector<Vec3>& target) {
  double s = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) s += (x[i] - target[i]).squaredNorm();
  return x.empty() ? 0.0 : std::sqrt(s / static_cast<double>(x.size()));
}

double rmsError(const SimulationResult& sim) {
  double ss = 0.0;
  std::size_t n = 0;
  for (const PoseResult& p : sim.poses) {
    if (!p.rmsError) return std::numeric_limits<double>::quiet_NaN();
    ss += *p.rmsError * *p.rmsError * static_cast<double>(p.positions.size());
    n += p.positions.size();
  }
  return n > 0 ? std::sqrt(ss / static_cast<double>(n)) : 0.0;
}

std::string unsupportedLoad(const Scene& scene, const RodNetwork& network, const EffectSet& effects, int pose,
                            const Design& design) {
  const Pose& p = scene.poses[pose];
  if (!p.fixed.empty() || !p.clamped.empty()) return "";
  Vec3 total = Vec3::Zero();
  double magnitude = 0.0;
  for (const PointForce& f : p.forces) {
    total += f.force;
    magnitude += f.force.norm();
  }
  if (effects.has(Effect::Gravity)) {
    double mass = 0.0;
    for (const Edge& e : network.edges()) {
      const double L = (design.restPositions[e.b] - design.restPositions[e.a]).norm();
      mass += stiffness::edgeMass(scene.material.density, L, design.radii[e.a][0], design.radii[e.a][1],
                                  design.radii[e.b][0], design.radii[e.b][1]);
    }
    total += mass * *scene.gravity;
    magnitude += mass * scene.gravity->norm();
  }
  if (total.norm() <= 1e-9 * magnitude) return "";
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "pose '%s' has no fixed or clamped vertex and its loads do not balance (net force %.3e N): there is no "
                "static equilibrium; hold at least one vertex",
                p.name.c_str(), total.norm());
  return buf;
}

bool PoseResult::atCriticalPoint() const {
  return stable.value_or(false) && smallestEigenvalue && unloadedSmallestEigenvalue &&
         *unloadedSmallestEigenvalue > 0 && *smallestEigenvalue <= kCriticalStiffnessRatio * *unloadedSmallestEigenvalue;
}

bool PoseResult::imperfectionSensitive() const {
  return imperfectionGap && largestDisplacement && !(*imperfectionGap <= kImperfectionGapRatio * *largestDisplacement);
}

Design radiusImperfection(const Design& design, double change, int sign) {
  Design d = design;
  // splitmix64 of the radius index: signs without a correlation along rods.
  for (std::size_t v = 0; v < d.radii.size(); ++v)
    for (int k = 0; k < 2; ++k) {
      std::uint64_t z = 2 * static_cast<std::uint64_t>(v) + static_cast<std::uint64_t>(k) + 0x9e3779b97f4a7c15ULL;
      z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
      z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
      z ^= z >> 31;
      const double s = (z & 1) ? 1.0 : -1.0;
      d.radii[v][k] *= 1.0 + sign * change * s;
    }
  return d;
}

void addImperfectionSensitivity(const SceneModel& model, const Design& design, const NewtonOptions& options,
                                SimulationResult& sim, int threads) {
  const Design plus = radiusImperfection(design, kImperfectionRadiusChange, 1);
  const Design minus = radiusImperfection(design, kImperfectionRadiusChange, -1);
  // A pose that hardly moves (nothing applied) is judged against 1e-6 of
  // the structure's size, not against its round-off.
  Eigen::AlignedBox3d box;
  for (const Vec3& x : design.restPositions) box.extend(x);
  const double floor = design.restPositions.empty() ? 0.0 : 1e-6 * box.diagonal().norm();
  // Each (pose, sign) on its own: the two loading paths of one pose are as
  // independent as those of two poses (a PoseSystem is safe to share).
  const int poses = std::min(model.numPoses(), static_cast<int>(sim.poses.size()));
  std::vector<double> gaps(2 * poses, 0.0);
  forEachPose(2 * poses, threads, [&](int task) {
    const int p = task / 2;
    const PoseResult& r = sim.poses[p];
    if (!r.report.converged()) return;
    const PoseSystem& sys = model.pose(p);
    const Design& d = task % 2 == 0 ? plus : minus;
    PoseState state = sys.restState(d);
    bool solved = false;
    try {
      solved = solveEquilibrium(sys, d, state, options).converged() && state.loadFactor == 1.0;
    } catch (const std::exception&) {
      solved = false;
    }
    if (!solved) {
      gaps[task] = std::numeric_limits<double>::infinity();
      return;
    }
    const std::vector<Vec3> x = sys.positions(state, d);
    for (std::size_t v = 0; v < x.size() && v < r.positions.size(); ++v)
      gaps[task] = std::max(gaps[task], (x[v] - r.positions[v]).norm());
  });
  for (int p = 0; p < poses; ++p) {
    PoseResult& r = sim.poses[p];
    if (!r.report.converged()) continue;
    double largest = 0.0;
    for (std::size_t v = 0; v < r.positions.size() && v < design.restPositions.size(); ++v)
      largest = std::max(largest, (r.positions[v] - design.restPositions[v]).norm());
    r.imperfectionGap = std::max(gaps[2 * p], gaps[2 * p + 1]);
    r.largestDisplacement = std::max(largest, floor);
  }
}

namespace {
void setUnloadedStiffness(const PoseSystem& sys, const Design& design, PoseResult& r) {
  if (!r.smallestEigenvalue || r.unloadedSmallestEigenvalue) return;
  const Stability unloaded = stability(sys, design, sys.restState(design));
  if (unloaded.ok) r.unloadedSmallestEigenvalue = unloaded.smallestEigenvalue;
}
}  // namespace

void addUnloadedStiffness(const SceneModel& model, const Design& design, SimulationResult& sim) {
  for (int p = 0; p < model.numPoses() && p < static_cast<int>(sim.poses.size()); ++p)
    setUnloadedStiffness(model.pose(p), design, sim.poses[p]);
}

SimulationResult simulateAll(const SceneModel& model, const Design& design, const NewtonOptions& options,
                             const PoseProgress& progress, bool unloadedStiffness, int threads) {
  SimulationResult out;
  out.dofsPerPose = model.numPoses() > 0 ? model.pose(0).numDofs() : 0;
  const int poses = model.numPoses();
  std::vector<PoseResult> results(poses);
  std::vector<std::exception_ptr> errors(poses);  // rethrown on the calling thread
  auto solvePose = [&](int p) {
    const PoseSystem& sys = model.pose(p);
    PoseResult& r = results[p];
    r.name = model.scene().poses[p].name;
    PoseState state = sys.restState(design);
    const std::string unsupported = unsupportedLoad(model.scene(), model.network(), model.effects(), p, design);
    if (!unsupported.empty()) {
      r.report.outcome = Outcome::InvalidProblem;
      r.report.message = unsupported;
      r.report.loadScale = r.report.residualNorm = loadScale(sys, design);
      r.report.relativeResidual = 1.0;
    } else {
      r.report = solveEquilibrium(sys, design, state, options);
    }
    r.dofs = state.u;
    r.state = state;
    // Positions and material twists of the returned state at its own load
    // factor (the full load when converged; a pose that stopped short is
    // archived as the equilibrium it reached, its held vertices where they
    // were then, not at their final positions with the free ones left
    // behind, where an edge can even point back along its rest tangent and
    // its twist is undefined).
    const PoseState reported{state.u, state.charts, state.loadFactor, state.internal};
    r.positions = sys.positions(reported, design);
    r.twist = sys.materialTwists(reported, design);
    const auto& target = model.scene().poses[p].target;
    if (!target.empty()) r.rmsError = rmsError(r.positions, target);
    if (r.report.outcome != Outcome::NumericalFailure && r.report.outcome != Outcome::InvalidProblem) {
      const Stability st =
          stability(sys, design, PoseState{state.u, state.charts, r.report.loadFactor, state.internal});
      if (st.ok) {
        r.stable = st.negative == 0;
        r.smallestEigenvalue = st.smallestEigenvalue;
        if (unloadedStiffness) setUnloadedStiffness(sys, design, r);
      }
    }
    if (model.effects().planar && r.report.converged())
      r.outOfPlaneStable = outOfPlaneStable(model.scene(), model.network(), model.effects(), p, design, r.positions);
  };
  auto report = [&](int p) {
    if (errors[p]) std::rethrow_exception(errors[p]);
    PoseResult& r = results[p];
    out.allConverged = out.allConverged && r.report.converged();
    if (progress) progress(p, r);
    out.poses.push_back(std::move(r));
  };
  if (threads <= 1 || poses <= 1) {
    for (int p = 0; p < poses; ++p) {
      solvePose(p);
      report(p);
    }
    return out;
  }
  forEachPose(poses, threads, [&](int p) {
    try {
      solvePose(p);
    } catch (...) {
      errors[p] = std::current_exception();
    }
  });
  for (int p = 0; p < poses; ++p) report(p);
  return out;
}

}  // namespace rodmesh
