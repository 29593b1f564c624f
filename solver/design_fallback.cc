#include "solver/design_fallback.hh"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>

#include "solver/design_optimizer.hh"

namespace rodmesh {
namespace {

std::string millimetres(double metres) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g mm", metres * 1e3);
  return buf;
}

// "pose 'NAME': why" for the first pose that did not converge.
std::string firstFailure(const SimulationResult& sim) {
  for (const PoseResult& p : sim.poses)
    if (!p.report.converged()) return "pose '" + p.name + "': " + p.report.message;
  return "";
}

}  // namespace

double designedEquilibriumTolerance(double optimizerRms, double structureSize) {
  return std::max(0.1 * optimizerRms, 1e-6 * structureSize);
}

bool sameControls(const ControlValues& a, const ControlValues& b) {
  return a.radii.rows() == b.radii.rows() && a.radii.cols() == b.radii.cols() &&
         a.displacement.rows() == b.displacement.rows() && a.displacement.cols() == b.displacement.cols() &&
         a.radii == b.radii && a.displacement == b.displacement;
}

void DesignFallbacks::add(const ControlValues& controls, double objective, double rms, const std::string& label,
                          bool pinned) {
  if (!std::isfinite(objective) || !std::isfinite(rms) || !controls.radii.allFinite() ||
      !controls.displacement.allFinite())
    return;
  for (FallbackDesign& d : designs_)
    if (sameControls(d.controls, controls)) {
      if (pinned && !d.pinned) {
        d.pinned = true;
        d.label = label;
      }
      return;
    }
  const auto at = std::upper_bound(designs_.begin(), designs_.end(), objective,
                                   [](double f, const FallbackDesign& d) { return f < d.objective; });
  designs_.insert(at, FallbackDesign{controls, objective, rms, label, pinned});
  const auto unpinned = std::count_if(designs_.begin(), designs_.end(), [](const FallbackDesign& d) { return !d.pinned; });
  if (unpinned <= capacity_) return;
  // Drop the unpinned design closest (by ratio of objectives) to the next
  // better one (pinned or not). At least two are unpinned (capacity >= 1),
  // so one of them has a better neighbour.
  auto logf = [](double f) { return std::log(std::max(f, 1e-300)); };
  std::size_t drop = designs_.size() - 1;
  double closest = std::numeric_limits<double>::infinity();
  for (std::size_t i = 1; i < designs_.size(); ++i) {
    if (designs_[i].pinned) continue;
    const double gap = logf(designs_[i].objective) - logf(designs_[i - 1].objective);
    if (gap < closest) {
      closest = gap;
      drop = i;
    }
  }
  designs_.erase(designs_.begin() + static_cast<std::ptrdiff_t>(drop));
}

ArchivedDesign chooseArchivedDesign(const SceneModel& model, const DesignSpace& space, const DesignOptimizerResult& result,
                                    const NewtonOptions& newton, int threads) {
  const Scene& scene = model.scene();
  ArchivedDesign out;
  out.controls = result.controls;
  out.design = result.design;
  out.label = "the final design";
  out.optimizerRms = result.rms;
  out.simulation = simulateAll(model, out.design, newton, {}, false, threads);
  out.allConverged = out.simulation.allConverged;
  out.rms = rmsError(out.simulation);
  if (out.allConverged && static_cast<int>(result.states.size()) == model.numPoses()) {
    // Are the loading-path equilibria the optimizer's?
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const Vec3& x : scene.vertices) {
      lo = std::min({lo, x.x(), x.y(), x.z()});
      hi = std::max({hi, x.x(), x.y(), x.z()});
    }
    out.gapTolerance = designedEquilibriumTolerance(result.rms, scene.vertices.empty() ? 0.0 : hi - lo);
    std::string worst;
    for (int p = 0; p < model.numPoses(); ++p) {
      const PoseSystem& sys = model.pose(p);
      if (result.states[p].u.size() != sys.numDofs()) continue;
      const std::vector<Vec3> own = sys.positions(result.states[p], out.design);
      const std::vector<Vec3>& path = out.simulation.poses[p].positions;
      for (std::size_t v = 0; v < own.size() && v < path.size(); ++v) {
        const double g = (own[v] - path[v]).norm();
        if (g > out.gap) {
          out.gap = g;
          worst = out.simulation.poses[p].name;
        }
      }
    }
    if (!(out.gap > out.gapTolerance)) return out;
    out.offPath = true;
    out.note = "the final design's equilibrium of pose '" + worst + "' reached along the loading path lies " +
               millimetres(out.gap) + " from the one the optimizer designed (tolerance " +
               millimetres(out.gapTolerance) + "): the optimizer worked on another branch of equilibria (RMS " +
               millimetres(result.rms) + " on its equilibria, " + millimetres(out.rms) + " as loaded from rest)";
    // An earlier design that does better as loaded from rest replaces it.
    std::vector<FallbackDesign> candidates;
    for (const FallbackDesign& f : result.fallbacks)
      if (!sameControls(f.controls, result.controls)) candidates.push_back(f);
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const FallbackDesign& a, const FallbackDesign& b) { return a.objective < b.objective; });
    for (const FallbackDesign& f : candidates) {
      // Only designs the optimizer scored better on its own equilibria than
      // the final one does from rest (best first): each try costs a loading
      // path per pose, and one the optimizer scored worse on its own branch
      // is rarely better from rest.
      if (!(f.rms < out.rms)) continue;
      const Design d = space.toDesign(f.controls);
      SimulationResult sim;
      try {
        sim = simulateAll(model, d, newton, {}, false, threads);
      } catch (const std::exception&) {
        continue;
      }
      if (!sim.allConverged) continue;
      const double rms = rmsError(sim);
      if (!(rms < out.rms)) continue;
      out.note += "; archived " + f.label + " instead (RMS " + millimetres(rms) + " as loaded from rest)";
      out.controls = f.controls;
      out.design = d;
      out.simulation = std::move(sim);
      out.fallback = true;
      out.label = f.label;
      out.optimizerRms = f.rms;
      out.rms = rms;
      return out;
    }
    out.note += "; no earlier design does better as loaded from rest: the final design is archived with its "
                "loading-path equilibria";
    return out;
  }
  if (out.allConverged) return out;

  const std::string finalFailure = firstFailure(out.simulation);
  std::vector<FallbackDesign> candidates;
  for (const FallbackDesign& f : result.fallbacks)
    if (!sameControls(f.controls, result.controls)) candidates.push_back(f);
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const FallbackDesign& a, const FallbackDesign& b) { return a.objective < b.objective; });
  const ControlValues initial = space.initialControls(scene);
  const bool tryInitial = !sameControls(initial, result.controls);
  if (tryInitial) candidates.push_back({initial, result.initialObjective, result.initialRms, "the initial design"});

  int failed = 0, worse = 0;
  for (std::size_t c = 0; c < candidates.size(); ++c) {
    const FallbackDesign& f = candidates[c];
    const bool isInitial = tryInitial && c + 1 == candidates.size();
    const Design d = space.toDesign(f.controls);
    SimulationResult sim;
    try {
      sim = simulateAll(model, d, newton, {}, false, threads);
    } catch (const std::exception&) {
      sim.allConverged = false;  // a design the model rejects is one more that does not re-solve
    }
    if (!sim.allConverged) {
      ++failed;
      continue;
    }
    const double rms = rmsError(sim);
    if (!isInitial && !(rms <= result.initialRms * (1 + 1e-9))) {
      ++worse;
      continue;
    }
    out.controls = f.controls;
    out.design = d;
    out.simulation = std::move(sim);
    out.allConverged = true;
    out.fallback = true;
    out.label = f.label;
    out.optimizerRms = f.rms;
    out.rms = rms;
    std::string skipped;
    if (failed > 0)
      skipped += "; " + std::to_string(failed) + " better design" + (failed > 1 ? "s" : "") +
                 " could not be re-solved from rest either";
    if (worse > 0)
      skipped += "; " + std::to_string(worse) + " better design" + (worse > 1 ? "s" : "") +
                 " re-solved from rest worse than the initial design";
    out.note = "the final design (" + millimetres(result.rms) +
               " on the optimizer's equilibria) could not be re-solved from rest (" + finalFailure + "); archived " +
               f.label + " (RMS " + millimetres(rms) + " re-solved from rest, " + millimetres(f.rms) +
               " on the optimizer's equilibria), the best earlier design that re-solves from rest" + skipped;
    return out;
  }
  if (!tryInitial)
    out.note = "the final design is the initial one and could not be re-solved from rest (" + finalFailure +
               "); archived with positions that are not equilibria (RMS " + millimetres(out.rms) + ")";
  else
    out.note = "no design of this run could be re-solved from rest, not even the initial one (" +
               std::to_string(candidates.size()) + " earlier design" + (candidates.size() == 1 ? "" : "s") +
               " tried): the final design (" + millimetres(result.rms) + " on the optimizer's equilibria) failed in " +
               finalFailure + "; archived the final design with positions that are not equilibria (RMS " +
               millimetres(out.rms) + ")";
  return out;
}

}  // namespace rodmesh
