#include "solver/bound_activity.hh"

#include <cmath>
#include <cstdio>
#include <exception>

#include "solver/design_optimizer.hh"

namespace rodmesh {

RadiusBoundActivity radiusBoundActivity(const SceneModel& model, const DesignSpace& space,
                                        const TargetObjective& objective, const ControlValues& controls,
                                        const std::vector<PoseState>& states, const NewtonOptions& newton) {
  RadiusBoundActivity a;
  const Scene& scene = model.scene();
  if (!scene.design.radii || static_cast<int>(states.size()) != model.numPoses()) return a;
  for (const PoseState& s : states)
    if (s.loadFactor != 1.0 || !s.u.allFinite()) return a;
  try {
    DesignPhase phase;
    phase.radii = true;
    phase.level = space.numLevels() - 1;
    const Eigen::VectorXd z = space.pack(phase, controls);
    ReducedObjective reduced(model, space, objective, phase, controls, newton, 1, states);
    double f = 0.0;
    Eigen::VectorXd g;
    if (!reduced.evaluate(z, f, &g) || !std::isfinite(f) || !g.allFinite()) return a;
    a.lowerBound = space.radiusLower();
    a.upperBound = space.radiusUpper();
    a.total = static_cast<int>(z.size());
    const double near = kAtBoundFraction * (a.upperBound - a.lowerBound);
    double lowerSum = 0.0, upperSum = 0.0;
    a.held.assign(z.size(), 0);
    for (Eigen::Index i = 0; i < z.size(); ++i) {
      if (z[i] - a.lowerBound <= near && g[i] > 0.0) {
        ++a.atLower;
        lowerSum += g[i];
        a.held[i] = -1;
      } else if (a.upperBound - z[i] <= near && g[i] < 0.0) {
        ++a.atUpper;
        upperSum += g[i];
        a.held[i] = 1;
      }
    }
    if (f > 0.0) {
      a.lowerElasticity = a.lowerBound * lowerSum / f;
      a.upperElasticity = a.upperBound * upperSum / f;
    }
    a.computed = true;
  } catch (const std::exception&) {
    a = RadiusBoundActivity{};
  }
  return a;
}

std::string describeBoundActivity(const RadiusBoundActivity& a) {
  if (!a.computed || a.atLower + a.atUpper == 0) return "";
  char buf[160];
  std::string s = std::to_string(a.atLower + a.atUpper) + " of " + std::to_string(a.total) +
                  " control radii are held at a radius bound (";
  std::string where, gain;
  if (a.atLower > 0) {
    std::snprintf(buf, sizeof buf, "%d at %.4g mm", a.atLower, a.lowerBound * 1e3);
    where = buf;
    std::snprintf(buf, sizeof buf, "by %.2g%% per 1%% lower minimum radius", a.lowerElasticity);
    gain = buf;
  }
  if (a.atUpper > 0) {
    std::snprintf(buf, sizeof buf, "%d at %.4g mm", a.atUpper, a.upperBound * 1e3);
    where += (where.empty() ? "" : ", ") + std::string(buf);
    std::snprintf(buf, sizeof buf, "by %.2g%% per 1%% higher maximum", -a.upperElasticity);
    gain += (gain.empty() ? "" : " and ") + std::string(buf);
  }
  return s + where + "): to first order the objective falls " + gain;
}

}  // namespace rodmesh
