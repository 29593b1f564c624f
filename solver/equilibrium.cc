#include "solver/equilibrium.hh"

#include <cmath>

namespace rodmesh {

SceneModel::SceneModel(const Scene& scene) : scene_(scene), network_(scene), effects_(resolveEffects(scene, network_)) {
  for (int p = 0; p < static_cast<int>(scene.poses.size()); ++p)
    poses_.push_back(std::make_unique<PoseSystem>(scene_, network_, effects_, p));
}

double rmsError(const std::vector<Vec3>& x, const std::vector<Vec3>& target) {
  double s = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) s += (x[i] - target[i]).squaredNorm();
  return x.empty() ? 0.0 : std::sqrt(s / static_cast<double>(x.size()));
}

SimulationResult simulateAll(SceneModel& model, const Design& design, const NewtonOptions& options,
                             const PoseProgress& progress) {
  SimulationResult out;
  out.dofsPerPose = model.numPoses() > 0 ? model.pose(0).numDofs() : 0;
  for (int p = 0; p < model.numPoses(); ++p) {
    PoseSystem& sys = model.pose(p);
    PoseResult r;
    r.name = model.scene().poses[p].name;
    r.dofs = sys.restDofs(design);
    r.report = solveEquilibrium(sys, design, r.dofs, options);
    r.positions = sys.positions(r.dofs);
    r.twist = sys.materialTwists(r.dofs);
    const auto& target = model.scene().poses[p].target;
    if (!target.empty()) r.rmsError = rmsError(r.positions, target);
    out.allConverged = out.allConverged && r.report.converged;
    if (progress) progress(p, r);
    out.poses.push_back(std::move(r));
  }
  return out;
}

}  // namespace rodmesh
