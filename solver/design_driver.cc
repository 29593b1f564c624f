#include "solver/design_driver.hh"

#include "solver/equilibrium.hh"
#include "solver/format.hh"
#include "solver/parallel.hh"


#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

namespace rodmesh {

bool solvePosesFrom(const SceneModel& model, const Design& d, std::vector<PoseState>& states, const NewtonOptions& newton,
                    int threads) {
  const int K = model.numPoses();
  std::vector<char> ok(K, 0);
  forEachPose(K, threads, [&](int k) {
    try {
      const NewtonReport r = solveEquilibrium(model.pose(k), d, states[k], newton);
      ok[k] = r.converged() && states[k].loadFactor == 1.0;
    } catch (...) {
      ok[k] = 0;
    }
  });
  return std::all_of(ok.begin(), ok.end(), [](char c) { return c != 0; });
}

double objectiveOfStates(const SceneModel& model, const TargetObjective& objective, const Design& d,
                         const std::vector<PoseState>& states, double& f) {
  double ss = 0.0;
  f = 0.0;
  for (int k = 0; k < model.numPoses(); ++k) {
    double s = 0.0;
    f += objective.pose(model.pose(k), states[k], d, nullptr, nullptr, &s);
    ss += s;
  }
  return ss;
}

namespace {
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

std::string millimetres(double metres) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g mm", metres * 1e3);
  return buf;
}
}  // namespace

namespace {

// The result's equilibria: their largest force residual, and whether there
// is one finite equilibrium per pose to use; with `bounds`, how much the
// radius bounds hold the design back (one adjoint solve per pose; not where
// the targets are met: the gradient is round-off there and nothing holds the
// design back), said in the message.
void describeResult(const SceneModel& model, const DesignSpace& space, const TargetObjective& objective,
                    const DesignOptimizerOptions& opt, DesignOptimizerResult& res, bool bounds) {
  res.usable = static_cast<int>(res.states.size()) == model.numPoses();
  res.residualNorm = 0.0;
  for (int k = 0; res.usable && k < model.numPoses(); ++k) {
    Eigen::VectorXd g;
    model.pose(k).evaluate(res.states[k], res.design, &g, nullptr);
    const double r = model.pose(k).forceResidual(g).norm();
    res.usable = std::isfinite(r) && res.states[k].u.allFinite() && res.states[k].loadFactor == 1.0;
    res.residualNorm = std::max(res.residualNorm, r);
  }
  if (bounds && res.usable && res.outcome != Outcome::InvalidProblem &&
      res.objective > kTargetsMetRatio * res.initialObjective) {
    res.boundActivity = radiusBoundActivity(model, space, objective, res.controls, res.states, opt.newton);
    const std::string held = describeBoundActivity(res.boundActivity);
    if (!held.empty()) res.message += "; " + held;
  }
}

}  // namespace

// The run's state; PhaseContext forwards to it.
class DesignDriver {
 public:
  DesignDriver(const SceneModel& model, const DesignSpace& space, const DesignOptimizerOptions& opt,
               const DesignProgress& progress)
      : model_(model),
        space_(space),
        scene_(model.scene()),
        opt_(opt),
        progress_(progress),
        objective_(scene_, model.effects()),
        t0_(Clock::now()) {}

  DesignOptimizerResult run(PhaseSolver& solver);

  bool interrupted() const { return opt_.stopRequested && opt_.stopRequested(); }
  bool timeUp() const { return opt_.timeLimit > 0 && since(t0_) >= opt_.timeLimit; }
  double elapsed() const { return since(t0_); }
  double remainingTime() const {
    return opt_.timeLimit > 0 ? std::max(0.0, opt_.timeLimit - since(t0_)) : std::numeric_limits<double>::infinity();
  }
  const DesignOptimizerOptions& options() const { return opt_; }
  // Lets the monitor finish the checks offered so far, so that the design
  // it holds depends only on the optimizer's iterates, not on how far its
  // thread got; a run cut short by its limits does not wait.
  void waitForMonitor() {
    monitor_->drain([this] { return interrupted() || timeUp(); });
  }
  double initialObjective() const { return res_.initialObjective; }

  bool iterate(const PhaseTask& task, DesignIterate& it, const ControlValues* design, bool equilibrium,
               bool settled) {
    const std::string label = "the design of " + task.label + ", iteration " + std::to_string(it.iteration);
    if (design) {
      if (equilibrium) fallbacks_.add(*design, it.objective, it.rms, label);
      if (monitor_ && confirmsIteration(it.iteration)) monitor_->offer(*design, it.iteration, label);
    }
    if (monitor_) monitor_->bestSummary(it.confirmedRms, it.confirmedIteration);
    res_.history.push_back(it);
    if (progress_) progress_(it);
    return settled && it.objective <= kTargetsMetRatio * res_.initialObjective;
  }

 private:
  DesignOptimizerResult finish(Outcome o, const std::string& message) {
    res_.outcome = o;
    res_.message = message;
    res_.startControls = start_;
    // A pending back-off may change the design: the bounds are judged on
    // the one it leaves (completeImperfectionBackOff).
    describeResult(model_, space_, objective_, opt_, res_,
                   !res_.imperfectionBackOffPending && !interrupted() && !timeUp());
    res_.timeSeconds = since(t0_);
    res_.solverSeconds = std::max(0.0, res_.timeSeconds - res_.evaluationSeconds);
    res_.peakMemoryBytes = peakResidentMemory();
    return res_;
  }
  // Polishes the phase's candidates and keeps the better ones; returns the
  // index of the candidate kept last (-1: none).
  int keepCandidates(const PhaseTask& task, const PhaseResult& pr, int iterations);
  // For a phase solver whose iterates are not equilibria (SAND): empty, or
  // why the phase's optimum is out of reach. An equality constraint holds
  // at unstable equilibria too, so such a phase can end at a design whose
  // equilibria (its own states) do better than the best design by more
  // than round-off while its polish (Newton from those states, or the
  // loading path from rest) lands elsewhere and the candidate was not kept;
  // said when a pose's stiffness at those states has a negative eigenvalue.
  std::string unreachedOptimum(const PhaseTask& task, const PhaseResult& pr, int kept) const;
  // For a phase solver whose iterates are not equilibria (SAND): empty, or
  // why the phase's optimum is not its result. Its first candidate is its
  // final point; when a later one (the best nearly feasible iterate) was
  // kept and the final point does worse on its own equilibria by more than
  // round-off, the iterates went on to another branch and came back to a
  // worse point, and the design kept is no optimum of the phase.
  std::string optimumWorseThanPassed(const PhaseTask& task, const PhaseResult& pr, int kept) const;
  // Re-solves the best design along the loading path from rest. True when
  // that equilibrium is not the one the optimizer holds (farther than
  // designedEquilibriumTolerance): `path` then holds the loading path's
  // equilibria and `note` says what happened.
  // When the rest shape is free, a seeded rest shape may bring the path
  // onto the optimizer's branch (seedTowardsDesigned): `seeded` is then set
  // and that design is already the best one.
  bool offLoadingPath(const PhaseTask& task, std::vector<PoseState>& path, std::string& note, bool& seeded);
  // For a design off its loading path with the rest shape free: tries rest
  // shapes displaced by fractions of the gap between the optimizer's and the
  // path's equilibria (an imperfection towards the designed branch, which
  // is how a structure is made to buckle one way). The first whose loading
  // path reaches the designed branch (within the tolerance) becomes the best
  // design, with those equilibria; `note` says so. False when none does.
  bool seedTowardsDesigned(const std::vector<PoseState>& path, std::string& note);
  // The run goes on from the loading path's equilibria of the best design.
  void continueFromPath(std::vector<PoseState> path);
  // Of the best design and the fallbacks, the one whose loading-path
  // equilibria (from rest) have the lowest objective becomes the result,
  // with those equilibria as the optimizer's. Returns its label.
  std::string adoptBestOnPath();
  double structureSize() const;
  // When a pose of the best design is imperfection-sensitive: the designs
  // t of the way from the initial design to it, t = 0.999, 0.99, 0.9, 0.5,
  // each solved along its loading path and tested; the first that is not
  // sensitive and does better than the initial design becomes the result,
  // with its loading path's equilibria. Returns what the message says (empty:
  // nothing sensitive, or nothing done).
  std::string backOffFromImperfection();
  // With the rest shape free: the rest shapes in which one pose's target is
  // the unloaded shape (the least-squares fit of the control displacements
  // to that target), each solved along its loading path from rest; the best
  // becomes the run's start when it halves the initial design's RMS
  // (kTargetStartGain). Returns what the message says of it (empty: the
  // initial design stays).
  std::string startFromTargets();
  // Newton from `states` under `d` (timed as model evaluations), then f and
  // the RMS there; false when a pose fails or f is not finite.
  bool solveAndScore(const Design& d, std::vector<PoseState>& states, double& f, double& rms);
  // Every pose's rest state under `d` (Newton from there follows the
  // loading path).
  std::vector<PoseState> restStates(const Design& d) const;
  // Tells the front end what the run does next (DesignOptimizerOptions::activity).
  void doing(const std::string& what) const {
    if (opt_.activity) opt_.activity(what);
  }
  // `controls` with its equilibria becomes the best design.
  void adopt(const ControlValues& controls, const Design& d, double f, double rms, std::vector<PoseState> polished,
             std::vector<PoseState> own);

  const SceneModel& model_;
  const DesignSpace& space_;
  const Scene& scene_;
  const DesignOptimizerOptions& opt_;
  const DesignProgress& progress_;
  const TargetObjective objective_;
  const Clock::time_point t0_;
  DesignOptimizerResult res_;
  std::unique_ptr<DesignMonitor> monitor_;
  DesignFallbacks fallbacks_;
  std::vector<PoseState> states_;      // equilibria of the best design (Newton-polished): the next phase's start
  std::vector<PoseState> optimizer_;   // the optimizer's own states of the best design (result.states)
  // The best design whose equilibria are those of its loading path from rest
  // (the initial design, then phase ends found on the path): what a run
  // that went on from a loading path's equilibria falls back to when it ends
  // worse than that.
  struct OnPathDesign {
    ControlValues controls;
    Design design;
    double objective = 0.0, rms = 0.0;
    std::vector<PoseState> states;
    std::string label;
  };
  // The best design whose equilibria were found on its loading path: a
  // phase end checked on its path, a seeded design, the initial design, or
  // the monitor's best confirmed design (waited for, see waitForMonitor).
  OnPathDesign bestKnownOnPath() {
    OnPathDesign best = bestOnPath_;
    if (monitor_) {
      doing("waiting for the monitor's checks of designs from rest");
      waitForMonitor();
    }
    // (DesignMonitor::best returns a copy: keep it while it is read.)
    const std::optional<ConfirmedDesign> confirmed = monitor_ ? monitor_->best() : std::nullopt;
    if (confirmed && confirmed->objective < best.objective)
      best = {confirmed->controls, confirmed->design,         confirmed->objective, confirmed->rms,
              confirmed->states,   confirmed->label + " (confirmed from rest during the run)"};
    return best;
  }
  OnPathDesign bestOnPath_;
  ControlValues start_;          // the design the schedule started from (the initial one, or startFromTargets')
  OnPathDesign lastPath_;        // the design offLoadingPath solved last, with its loading path
  bool wentOnFromPath_ = false;  // continueFromPath was called
};

bool PhaseContext::iterate(DesignIterate& it, const ControlValues* design, bool equilibrium, bool settled) {
  return driver_.iterate(task_, it, design, equilibrium, settled);
}
bool PhaseContext::interrupted() const { return driver_.interrupted(); }
bool PhaseContext::timeUp() const { return driver_.timeUp(); }
double PhaseContext::elapsed() const { return driver_.elapsed(); }
double PhaseContext::remainingTime() const { return driver_.remainingTime(); }
double PhaseContext::initialObjective() const { return driver_.initialObjective(); }
const DesignOptimizerOptions& PhaseContext::options() const { return driver_.options(); }

// backOffFromImperfection: bisections between the first robust design of
// the back-off and the last sensitive one (each tests one design: three
// loading paths per pose, and the imperfect ones).
constexpr int kBackOffBisections = 3;
constexpr const char* kCheckingImperfection =
    "checking the final design for imperfection sensitivity (every pose from rest with its radii 0.1% off)";

namespace {

// What the back-off needs of the run it backs off in: its start, its
// limits, and how a design becomes the result.
struct BackOffRun {
  const SceneModel& model;
  const DesignSpace& space;
  const TargetObjective& objective;
  const DesignOptimizerOptions& opt;
  const ControlValues& start;
  DesignOptimizerResult& res;
  std::function<bool()> interrupted, timeUp;
  std::function<void(const ControlValues&, const Design&, double f, double rms, const std::vector<PoseState>&)> adopt;
};

// See DesignDriver::backOffFromImperfection.
std::string backOffFromImperfection(const BackOffRun& run) {
  const SceneModel& model = run.model;
  const DesignSpace& space = run.space;
  const DesignOptimizerOptions& opt = run.opt;
  DesignOptimizerResult& res = run.res;
  const auto& interrupted = run.interrupted;
  const auto& timeUp = run.timeUp;
  // `d` solved from rest into `sim` and tested: true when a pose is
  // sensitive (`pose`, `gap`: the first such). A design with a pose that
  // does not solve from rest is not tested (sim.allConverged false; such
  // designs are the archive's business).
  auto sensitive = [&](const Design& d, SimulationResult& sim, std::string& pose, double& gap) {
    const auto te = Clock::now();
    // (unloaded stiffness: atCriticalPoint below)
    sim = simulateAll(model, d, opt.newton, {}, /*unloadedStiffness=*/true, opt.threads);
    bool any = false;
    if (sim.allConverged) {
      addImperfectionSensitivity(model, d, opt.newton, sim, opt.threads);
      for (const PoseResult& p : sim.poses)
        if (p.imperfectionSensitive() && !any) {
          any = true;
          pose = p.name;
          gap = p.imperfectionGap.value_or(0.0);
        }
    }
    res.evaluationSeconds += since(te);
    return any;
  };
  SimulationResult sim;
  std::string pose;
  double gap = 0.0;
  const bool base = sensitive(res.design, sim, pose, gap);
  if (interrupted()) return "";  // solves cut short prove nothing
  if (sim.allConverged) res.imperfectionCheck = sim;
  if (!base || !sim.allConverged) return "";
  const ControlValues& initial = run.start;
  const std::string from = sameControls(run.start, space.initialControls(model.scene()))
                               ? "the initial design"
                               : "the design the run started from";
  const std::string gapText = std::isfinite(gap) ? "reaches an equilibrium " + millimetres(gap) + " away"
                                           : "reaches no equilibrium";
  const std::string what = "pose '" + pose + "' of the final design is imperfection-sensitive (with its radii 0.1% " +
                           "off, its loading path " + gapText + ")";
  // The design t of the way from `initial` to the final design, solved from
  // rest and tested; true when it is not sensitive (every pose converged),
  // with its objective and RMS.
  struct Tested {
    ControlValues controls;
    Design design;
    SimulationResult sim;
    double f = 0.0, rms = 0.0;
  };
  auto robust = [&](double t, Tested& out) {
    out.controls = initial;
    out.controls.radii = initial.radii + t * (res.controls.radii - initial.radii);
    out.controls.displacement = initial.displacement + t * (res.controls.displacement - initial.displacement);
    out.design = space.toDesign(out.controls);
    std::string p;
    double g = 0.0;
    if (sensitive(out.design, out.sim, p, g) || !out.sim.allConverged || interrupted()) return false;
    std::vector<PoseState> states;
    for (const PoseResult& r : out.sim.poses) states.push_back(r.state);
    out.rms = run.objective.rms(objectiveOfStates(model, run.objective, out.design, states, out.f));
    return true;
  };
  double lastSensitive = 1.0;  // the final design
  for (const double t : {0.999, 0.99, 0.9, 0.5}) {
    if (interrupted() || timeUp()) break;
    Tested ok;
    if (!robust(t, ok)) {
      lastSensitive = t;
      continue;
    }
    if (!(ok.f < res.initialObjective)) break;  // farther back is no better
    // The edge lies between t and the last sensitive design: a few
    // bisections find a robust design nearer to it, which near the edge is
    // the better one (the steps of t are coarse where the final design is
    // far from the start).
    // A design nearer the edge must not be at a critical point where the
    // coarse step's is not (its stiffness near zero: robust to this test's
    // imperfection, not to a larger one).
    auto critical = [](const SimulationResult& sim) {
      for (const PoseResult& r : sim.poses)
        if (r.atCriticalPoint()) return true;
      return false;
    };
    const bool okCritical = critical(ok.sim);
    double tOk = t;
    for (int i = 0; i < kBackOffBisections && !interrupted() && !timeUp(); ++i) {
      const double mid = 0.5 * (tOk + lastSensitive);
      Tested m;
      if (!robust(mid, m) || (critical(m.sim) && !okCritical)) {
        lastSensitive = mid;
        continue;
      }
      if (!(m.f < ok.f)) break;  // nearer the edge but no better: keep t
      ok = std::move(m);
      tOk = mid;
    }
    const double before = res.rms;
    std::vector<PoseState> states;
    for (const PoseResult& r : ok.sim.poses) states.push_back(r.state);
    run.adopt(ok.controls, ok.design, ok.f, ok.rms, states);
    res.imperfectionCheck = std::move(ok.sim);
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.4g", tOk);
    return what + ": the result is the design " + buf + " of the way from " + from + " to it, the nearest " +
           "tested that is not (RMS " + millimetres(ok.rms) + " as loaded from rest, against " + millimetres(before) +
           ")";
  }
  return what + "; no design between it and " + from + " that was tested is better and not sensitive";
}

}  // namespace

std::string DesignDriver::backOffFromImperfection() {
  BackOffRun run{model_,
                 space_,
                 objective_,
                 opt_,
                 start_,
                 res_,
                 [this] { return interrupted(); },
                 [this] { return timeUp(); },
                 [this](const ControlValues& c, const Design& d, double f, double rms,
                        const std::vector<PoseState>& states) { adopt(c, d, f, rms, states, states); }};
  return rodmesh::backOffFromImperfection(run);
}

double DesignDriver::structureSize() const {
  if (scene_.vertices.empty()) return 0.0;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const Vec3& x : scene_.vertices) {
    lo = std::min({lo, x.x(), x.y(), x.z()});
    hi = std::max({hi, x.x(), x.y(), x.z()});
  }
  return hi - lo;
}

bool DesignDriver::solveAndScore(const Design& d, std::vector<PoseState>& states, double& f, double& rms) {
  const auto te = Clock::now();
  const bool ok = solvePosesFrom(model_, d, states, opt_.newton, opt_.threads);
  res_.evaluationSeconds += since(te);
  if (!ok) return false;
  rms = objective_.rms(objectiveOfStates(model_, objective_, d, states, f));
  return std::isfinite(f);
}

std::vector<PoseState> DesignDriver::restStates(const Design& d) const {
  std::vector<PoseState> s(model_.numPoses());
  for (int k = 0; k < model_.numPoses(); ++k) s[k] = model_.pose(k).restState(d);
  return s;
}

void DesignDriver::adopt(const ControlValues& controls, const Design& d, double f, double rms,
                         std::vector<PoseState> polished, std::vector<PoseState> own) {
  res_.controls = controls;
  res_.design = d;
  res_.objective = f;
  res_.rms = rms;
  states_ = std::move(polished);
  optimizer_ = std::move(own);
}

int DesignDriver::keepCandidates(const PhaseTask& task, const PhaseResult& pr, int iterations) {
  int kept = -1;
  for (std::size_t c = 0; c < pr.candidates.size(); ++c) {
    const PhaseCandidate& cand = pr.candidates[c];
    if (static_cast<int>(cand.states.size()) != model_.numPoses()) continue;
    const Design d = space_.toDesign(cand.controls);
    std::vector<PoseState> polished = cand.states;
    double f = 0.0, rms = 0.0;
    if (!solveAndScore(d, polished, f, rms) || !(kept >= 0 ? f < res_.objective : f <= res_.objective)) continue;
    adopt(cand.controls, d, f, rms, std::move(polished), cand.states);
    kept = static_cast<int>(c);
    fallbacks_.add(cand.controls, f, res_.rms,
                   "the design kept at the end of " + task.label + " (iteration " + std::to_string(iterations) + ")");
  }
  return kept;
}

// Relative margin above the polish's round-off: a kept candidate's own and
// polished objectives differ in their last digits only (unreachedOptimum,
// optimumWorseThanPassed).
constexpr double kOptimumMargin = 1e-3;

std::string DesignDriver::unreachedOptimum(const PhaseTask& task, const PhaseResult& pr, int kept) const {
  for (std::size_t c = 0; c < pr.candidates.size(); ++c) {
    const PhaseCandidate& cand = pr.candidates[c];
    if (static_cast<int>(c) == kept || static_cast<int>(cand.states.size()) != model_.numPoses()) continue;
    const Design d = space_.toDesign(cand.controls);
    double f = 0.0;
    const double rms = objective_.rms(objectiveOfStates(model_, objective_, d, cand.states, f));
    if (!(f < (1.0 - kOptimumMargin) * res_.objective)) continue;
    // Only an optimum shown unstable: a polish can also fail for want of
    // Newton iterations, which says nothing about the design.
    for (int k = 0; k < model_.numPoses(); ++k) {
      const Stability st = stability(model_.pose(k), d, cand.states[k]);
      if (st.ok && st.negative > 0)
        return "the optimum of " + task.label + " (RMS " + millimetres(rms) +
               " on its own equilibria) is no stable equilibrium of its design: pose '" + scene_.poses[k].name +
               "' is an unstable equilibrium there (" + std::to_string(st.negative) + " negative stiffness eigenvalue" +
               (st.negative > 1 ? "s" : "") + ")";
    }
  }
  return "";
}

std::string DesignDriver::optimumWorseThanPassed(const PhaseTask& task, const PhaseResult& pr, int kept) const {
  if (kept <= 0 || pr.candidates.empty() || static_cast<int>(pr.candidates[0].states.size()) != model_.numPoses())
    return "";
  const PhaseCandidate& end = pr.candidates[0];
  const Design d = space_.toDesign(end.controls);
  double f = 0.0;
  const double rms = objective_.rms(objectiveOfStates(model_, objective_, d, end.states, f));
  if (!(f > (1.0 + kOptimumMargin) * res_.objective)) return "";
  return "the optimum of " + task.label + " (RMS " + millimetres(rms) +
         " on its own equilibria) does worse than a design its iterates passed (RMS " + millimetres(res_.rms) +
         "), which is no optimum of the phase either";
}

bool DesignDriver::offLoadingPath(const PhaseTask& task, std::vector<PoseState>& path, std::string& note,
                                  bool& seeded) {
  // Along the loading path from rest (solver/newton.hh), as `rodmesh
  // simulate` and the archive solve the design.
  path = restStates(res_.design);
  double f = 0.0, rms = 0.0;
  // A design that does not re-solve from rest is the archive's business
  // (fallback designs); the optimizer's equilibria are all there is to go on.
  if (!solveAndScore(res_.design, path, f, rms)) return false;
  lastPath_ = {res_.controls, res_.design, f, rms, path, ""};
  const double tolerance = designedEquilibriumTolerance(res_.rms, structureSize());
  double gap = 0.0;
  int worst = 0;
  for (int k = 0; k < model_.numPoses(); ++k) {
    const PoseSystem& sys = model_.pose(k);
    const std::vector<Vec3> own = sys.positions(states_[k], res_.design);
    const std::vector<Vec3> along = sys.positions(path[k], res_.design);
    for (std::size_t v = 0; v < own.size() && v < along.size(); ++v) {
      const double g = (own[v] - along[v]).norm();
      if (g > gap) {
        gap = g;
        worst = k;
      }
    }
  }
  if (!(gap > tolerance)) {
    if (f < bestOnPath_.objective) bestOnPath_ = {res_.controls, res_.design, f, rms, path, "the end of " + task.label};
    return false;
  }
  note = "the design kept at the end of " + task.label + " has pose '" + scene_.poses[worst].name +
         "' as loaded from rest " + millimetres(gap) + " from the optimizer's equilibrium (tolerance " +
         millimetres(tolerance) + "; RMS " + millimetres(res_.rms) + " on the optimizer's equilibria, " +
         millimetres(rms) + " on the loading path's)";
  std::string how;
  if (seedTowardsDesigned(path, how)) {
    note += ": " + how;
    seeded = true;
  }
  return true;
}

namespace {
// Largest vertex distance between two equilibria of pose k of one design.
double poseGap(const SceneModel& model, int k, const Design& d, const PoseState& a, const PoseState& b) {
  const std::vector<Vec3> x = model.pose(k).positions(a, d), y = model.pose(k).positions(b, d);
  double gap = 0.0;
  for (std::size_t v = 0; v < x.size() && v < y.size(); ++v) gap = std::max(gap, (x[v] - y[v]).norm());
  return gap;
}
}  // namespace

bool DesignDriver::seedTowardsDesigned(const std::vector<PoseState>& path, std::string& note) {
  if (!scene_.design.restShape) return false;
  const int K = model_.numPoses();
  // The gap field, summed over the poses: per vertex, designed minus path;
  // and the poses in decreasing order of their gap.
  const int nv = space_.numVertices();
  Eigen::MatrixXd gapField = Eigen::MatrixXd::Zero(nv, 3);
  std::vector<std::pair<double, int>> order;
  for (int k = 0; k < K; ++k) {
    const PoseSystem& sys = model_.pose(k);
    const std::vector<Vec3> own = sys.positions(states_[k], res_.design);
    const std::vector<Vec3> along = sys.positions(path[k], res_.design);
    for (int v = 0; v < nv; ++v) gapField.row(v) += (own[v] - along[v]).transpose();
    order.emplace_back(-poseGap(model_, k, res_.design, states_[k], path[k]), k);
  }
  const double tolerance = designedEquilibriumTolerance(res_.rms, structureSize());
  std::sort(order.begin(), order.end());
  // Control displacements whose interpolation fits it (least squares).
  Eigen::MatrixXd delta;
  if (!space_.fitControls(gapField, delta)) return false;
  doing("seeding the rest shape towards the optimizer's equilibria (each seed: every pose from rest)");
  for (const double fraction : {0.03, 0.1, 0.3}) {
    ControlValues c = res_.controls;
    c.displacement += fraction * delta;
    const Design d = space_.toDesign(c);
    // Pose by pose, the farthest first (a seed that fails there costs no
    // other pose's loading path): the designed branch continued to the
    // seeded design, and its loading path from rest.
    std::vector<PoseState> own = states_, along = restStates(d);
    bool reached = true;
    for (const auto& [negativeGap, k] : order) {
      if (interrupted() || timeUp()) return false;
      const auto te = Clock::now();
      const PoseSystem& sys = model_.pose(k);
      bool solved = false;
      try {
        solved = solveEquilibrium(sys, d, own[k], opt_.newton).converged() &&
                 solveEquilibrium(sys, d, along[k], opt_.newton).converged() && own[k].loadFactor == 1.0 &&
                 along[k].loadFactor == 1.0;
      } catch (const std::exception&) {
        solved = false;
      }
      res_.evaluationSeconds += since(te);
      // Within the tolerance of the run's RMS before the seed (the seeded
      // design's own RMS is not known until every pose is solved). A pose
      // that was on its path before and is not any more: larger seeds
      // would only push it farther; the seed is given up.
      if (!solved || !(poseGap(model_, k, d, own[k], along[k]) <= tolerance)) {
        if (-negativeGap <= tolerance) return false;
        reached = false;
        break;
      }
    }
    if (!reached) continue;
    double fPath = 0.0;
    const double rmsPath = objective_.rms(objectiveOfStates(model_, objective_, d, along, fPath));
    if (!std::isfinite(fPath)) continue;
    adopt(c, d, fPath, rmsPath, along, along);
    wentOnFromPath_ = true;
    if (fPath < bestOnPath_.objective) bestOnPath_ = {c, d, fPath, rmsPath, along, "a seeded rest shape"};
    lastPath_ = {c, d, fPath, rmsPath, along, ""};
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.2g", fraction);
    note = std::string("a rest shape displaced by ") + buf +
           " of that gap towards the optimizer's equilibria brings the loading path onto the designed branch "
           "(RMS " + millimetres(rmsPath) + " as loaded from rest), and the run went on from that design";
    return true;
  }
  return false;
}

// startFromTargets: the objective ratio a target's rest shape must beat
// (a quarter of the objective: half the RMS).
constexpr double kTargetStartGain = 0.25;

std::string DesignDriver::startFromTargets() {
  if (opt_.startControls) {
    const ControlValues& c = *opt_.startControls;
    if (c.radii.rows() != res_.controls.radii.rows() || c.radii.cols() != res_.controls.radii.cols() ||
        c.displacement.rows() != res_.controls.displacement.rows() ||
        c.displacement.cols() != res_.controls.displacement.cols())
      return "";
    const Design d = space_.toDesign(c);
    std::vector<PoseState> path = restStates(d);
    double f = 0.0, rms = 0.0;
    if (!solveAndScore(d, path, f, rms)) return "";
    const OnPathDesign given{c, d, f, rms, path, "the design the run was given"};
    adopt(given.controls, given.design, f, rms, path, path);
    if (f < bestOnPath_.objective) bestOnPath_ = given;
    start_ = c;
    res_.start = given.label;
    return "the run started from " + given.label + " (RMS " + millimetres(rms) + " as loaded from rest)";
  }
  const bool forced = opt_.startTargetPose >= 0;  // a second start: that pose's target, however little it gains
  if (!scene_.design.restShape || !(opt_.startFromTargets || forced)) return "";
  const int K = model_.numPoses();
  const int nv = space_.numVertices();
  // A target's rest shape replaces the scene's only when it at least halves
  // the RMS: the scene's rest shape is the designer's, and a start only
  // somewhat better from rest need not lie in a better basin
  // (docs/optimization.md, "The start").
  OnPathDesign best = bestOnPath_;
  if (!forced) best.objective *= kTargetStartGain;
  int chosen = -1;
  double candidateObjective = std::numeric_limits<double>::infinity();
  for (int k = 0; k < K; ++k) {
    const Pose& pose = scene_.poses[static_cast<std::size_t>(k)];
    if ((forced && k != opt_.startTargetPose) || !(pose.weight > 0) || static_cast<int>(pose.target.size()) != nv)
      continue;
    if (interrupted() || timeUp()) break;
    // The rest displacement that makes this target the unloaded shape, as
    // nearly as the control points can (for a planar scene toDesign keeps
    // its in-plane part).
    Eigen::MatrixXd field(nv, 3);
    for (int v = 0; v < nv; ++v) field.row(v) = (pose.target[v] - scene_.vertices[v]).transpose();
    Eigen::MatrixXd delta;
    if (!space_.fitControls(field, delta)) continue;
    ControlValues c = res_.controls;
    c.displacement = delta;
    const Design d = space_.toDesign(c);
    std::vector<PoseState> path = restStates(d);
    double f = 0.0, rms = 0.0;
    if (!solveAndScore(d, path, f, rms)) continue;
    const std::string label = "the rest shape of pose '" + pose.name + "''s target";
    if (f < bestOnPath_.objective && f < candidateObjective) {
      candidateObjective = f;
      res_.startCandidate = label;
      res_.startCandidatePose = k;
    }
    if (!(f < best.objective)) continue;
    best = {c, d, f, rms, path, label};
    chosen = k;
  }
  if (chosen < 0) return "";
  adopt(best.controls, best.design, best.objective, best.rms, best.states, best.states);
  bestOnPath_ = best;
  start_ = best.controls;
  res_.start = best.label;
  return "the run started from " + best.label + " (RMS " + millimetres(best.rms) +
         " as loaded from rest, against " + millimetres(res_.initialRms) + " for the initial design)";
}

void DesignDriver::continueFromPath(std::vector<PoseState> path) {
  double f = 0.0;
  const double rms = objective_.rms(objectiveOfStates(model_, objective_, res_.design, path, f));
  adopt(res_.controls, res_.design, f, rms, path, path);
  wentOnFromPath_ = true;
}

std::string DesignDriver::adoptBestOnPath() {
  doing("choosing the design that does best as loaded from rest (the monitor's checks, then the fallback designs)");
  const std::vector<FallbackDesign> candidates = fallbacks_.designs();
  std::string label = "the last phase's design";
  double best = std::numeric_limits<double>::infinity();
  // The current best design first (its loading path is usually the one
  // offLoadingPath just solved), then the fallbacks.
  std::vector<PoseState> path;
  double f = 0.0, rms = 0.0;
  if (sameControls(lastPath_.controls, res_.controls) && !lastPath_.states.empty()) {
    const OnPathDesign known = lastPath_;
    adopt(known.controls, known.design, known.objective, known.rms, known.states, known.states);
    best = known.objective;
  } else {
    path = restStates(res_.design);
    if (solveAndScore(res_.design, path, f, rms)) {
      adopt(res_.controls, res_.design, f, rms, path, path);
      best = f;
    }
  }
  // The best design found on its loading path (the initial design at
  // least): known without a solve.
  if (bestOnPath_.objective < best) {
    best = bestOnPath_.objective;
    label = bestOnPath_.label;
    adopt(bestOnPath_.controls, bestOnPath_.design, best, bestOnPath_.rms, bestOnPath_.states, bestOnPath_.states);
  }
  // Then the monitor's best confirmed design (its objective from rest is
  // known; one solve for its states) and the fallbacks, best first, as long
  // as the optimizer's own objective for them is below the best found from
  // rest so far: each costs a loading path per pose (seconds on scenes with
  // prescribed rotations), and a design the optimizer scored worse on its
  // own branch is rarely better from rest.
  std::vector<std::pair<ControlValues, std::string>> tries;
  if (monitor_) {
    waitForMonitor();
    if (const std::optional<ConfirmedDesign> c = monitor_->best(); c && c->objective < best)
      tries.emplace_back(c->controls, c->label + " (confirmed from rest during the run)");
  }
  for (const FallbackDesign& c : candidates) {
    if (!(c.objective < best)) break;
    tries.emplace_back(c.controls, c.label);
  }
  for (const auto& [controls, name] : tries) {
    if (interrupted() || timeUp()) break;
    const Design d = space_.toDesign(controls);
    path = restStates(d);
    if (!solveAndScore(d, path, f, rms) || !(f < best)) continue;
    best = f;
    label = name;
    adopt(controls, d, f, rms, path, path);
  }
  return label;
}

DesignOptimizerResult DesignDriver::run(PhaseSolver& solver) {
  const int K = model_.numPoses();
  res_.controls = space_.initialControls(scene_);
  const Design d0 = space_.toDesign(res_.controls);
  res_.design = d0;

  // The initial design's equilibria, from rest.
  doing("solving every pose of the initial design from rest");
  states_ = restStates(d0);
  double f0 = 0.0, rms0 = 0.0;
  if (!solveAndScore(d0, states_, f0, rms0)) {
    // Newton solves stop at the run's limits too (NewtonOptions::cancel).
    if (interrupted()) return finish(Outcome::Interrupted, "interrupted");
    if (timeUp()) return finish(Outcome::TimeLimit, "time limit reached");
    return finish(Outcome::NumericalFailure,
                  "no equilibrium under the initial design: the poses cannot be solved as given");
  }
  res_.initialObjective = res_.objective = f0;
  res_.initialRms = res_.rms = rms0;
  for (int k = 0; k < K; ++k) res_.initialPositions.push_back(model_.pose(k).positions(states_[k], d0));
  optimizer_ = states_;
  res_.states = states_;
  bestOnPath_ = {res_.controls, d0, f0, rms0, states_, "the initial design"};
  {
    DesignIterate it;
    it.phase = "initial";
    it.objective = f0;
    it.rms = res_.rms;
    it.elapsed = since(t0_);
    it.evaluations = 1;
    res_.history.push_back(it);
    if (progress_) progress_(it);
  }
  if (!(f0 > 0)) return finish(Outcome::Converged, "the initial design meets every target");
  if (rms0 <= kTargetsMetExtent * structureSize())
    return finish(Outcome::Converged, "the initial design meets every target to round-off (RMS " +
                                          formatNumber("%.3g", rms0) + " m, structure size " +
                                          formatNumber("%.3g", structureSize()) + " m)");
  if (std::string why = solver.prepare(states_, f0); !why.empty()) return finish(Outcome::InvalidProblem, why);
  start_ = res_.controls;
  if (scene_.design.restShape) doing("solving the start's candidates from rest (the rest shapes of the targets)");
  const std::string startNote = startFromTargets();
  if (interrupted()) return finish(Outcome::Interrupted, "interrupted");
  if (timeUp()) return finish(Outcome::TimeLimit, "time limit reached");
  if (opt_.startControls && startNote.empty())
    return finish(Outcome::InvalidProblem, "the design the run was given as its start cannot be solved from rest");
  if (opt_.startTargetPose >= 0 && startNote.empty())
    return finish(Outcome::InvalidProblem,
                  "the rest shape of the start's target cannot be solved from rest or does no better than the initial "
                  "design");
  // The optimizer's designs are re-solved on a second thread, so that a
  // design that re-solves from rest is at hand at every moment.
  if (opt_.confirmDesigns)
    monitor_ = std::make_unique<DesignMonitor>(scene_, space_, opt_.newton, f0, t0_, opt_.onConfirmed);

  std::vector<DesignStep> steps = designSchedule(scene_, space_, opt_);
  Outcome stop = Outcome::Converged;
  std::string message = "schedule completed";
  std::vector<std::string> notes;  // what the phase ends did besides keeping designs
  if (!startNote.empty()) notes.push_back(startNote);
  int iterations = 0;
  double roundStart = res_.objective;
  int roundStartIteration = 0;
  int attempt = 0;        // retries of the current phase (divergence, off the loading path)
  bool retryDiverged = false;  // the retry is that of a diverged phase
  bool seededRetry = false;    // the last phase was run again from a seeded rest shape
  bool onPathRetry = false;    // the last phase was run again on the loading path (PhaseTask::onPath)
  int phaseIndex = 0;
  // The retry of a diverged phase (or of one whose optimum no stable
  // equilibrium realizes) starts from the best design so far; a design
  // confirmed from rest during the run (the monitor's, waited for) or found
  // on its loading path that does better is that design, with its loading
  // path's equilibria. Returns what the note says of the start.
  auto retryStart = [&]() -> std::string {
    const OnPathDesign best = bestKnownOnPath();
    if (interrupted() || timeUp() || best.states.empty() || sameControls(best.controls, res_.controls) ||
        !(best.objective < res_.objective))
      return "";
    const double before = res_.rms;
    adopt(best.controls, best.design, best.objective, best.rms, best.states, best.states);
    wentOnFromPath_ = true;
    return " from " + best.label + " (RMS " + millimetres(best.rms) + " as loaded from rest, against " +
           millimetres(before) + " for the best design the phase kept)";
  };
  // A run that went on from a loading path's equilibria and is about to end
  // worse, as loaded from rest, than a design it held before (`why`): that
  // design is adopted and the run goes on with a phase run on the loading
  // path (PhaseTask::onPath), the last resort also used when the last phase
  // ends off the path twice. False when there is no such design.
  auto onPathFromBest = [&](const std::string& why) {
    if (!wentOnFromPath_ || onPathRetry || !solver.solvesOnPath() || interrupted() || timeUp()) return false;
    const OnPathDesign best = bestKnownOnPath();
    if (sameControls(best.controls, res_.controls) || !(best.objective < res_.objective)) return false;
    notes.push_back(why + ": its design as loaded from rest (RMS " + millimetres(res_.rms) + ") is worse than " +
                    best.label + " (RMS " + millimetres(best.rms) + "); a last phase was run from that design, every "
                    "equilibrium solved from rest along its loading path");
    adopt(best.controls, best.design, best.objective, best.rms, best.states, best.states);
    onPathRetry = true;
    return true;
  };
  for (std::size_t ph = 0; ph < steps.size(); ++ph) {
    const DesignStep& step = steps[ph];
    if (step.round > 0 && step.phase.restShape && attempt == 0) {
      roundStart = res_.objective;
      roundStartIteration = iterations;
    }
    const int remaining = opt_.maxIterations - iterations;
    if (remaining <= 0) {
      stop = Outcome::MaxIterations;
      message = "iteration limit reached";
      break;
    }
    if (timeUp()) {
      stop = Outcome::TimeLimit;
      message = "time limit reached";
      break;
    }
    if (interrupted()) {
      stop = Outcome::Interrupted;
      message = "interrupted";
      break;
    }
    if (space_.numFree(step.phase) == 0) continue;
    PhaseTask task;
    task.step = step;
    task.index = attempt > 0 ? phaseIndex - 1 : phaseIndex++;  // a retry is the same phase
    task.lastPhase = ph + 1 == steps.size();
    task.handsOver = !task.lastPhase && step.round == 0;
    task.iterationBase = iterations;
    task.remainingIterations = remaining;
    task.attempt = attempt;
    task.diverged = attempt > 0 && retryDiverged;
    task.onPath = onPathRetry;
    task.controls = res_.controls;
    task.states = states_;
    task.objective = res_.objective;
    task.label = describeStep(step);
    PhaseContext context(*this, task);
    const PhaseResult pr = solver.solvePhase(task, context);
    iterations += pr.iterations;
    res_.evaluations += pr.evaluations;
    res_.failedEvaluations += pr.failedEvaluations;
    res_.equilibriumRestarts += pr.equilibriumRestarts;
    res_.evaluationSeconds += pr.evaluationSeconds;
    const int kept = keepCandidates(task, pr, iterations);
    solver.phaseEnded(kept);

    // A phase that ended at an optimum no stable equilibrium realizes is run
    // again like a diverged one (by a method whose iterates are stable
    // equilibria); it did not converge.
    const bool phaseStopped = pr.end == PhaseEnd::Converged || pr.end == PhaseEnd::Stalled ||
                              pr.end == PhaseEnd::PhaseCap || pr.end == PhaseEnd::TargetsMet;
    if (phaseStopped && attempt < 1 && !solver.iteratesAreEquilibria() && !interrupted() && !timeUp()) {
      std::string why = unreachedOptimum(task, pr, kept);
      if (why.empty()) why = optimumWorseThanPassed(task, pr, kept);
      if (!why.empty()) {
        ++attempt;
        retryDiverged = true;
        notes.push_back(why + "; the phase was " + solver.divergedRetry() + retryStart());
        --ph;
        continue;
      }
    }

    if (pr.end == PhaseEnd::Diverged) {
      // Run the phase again from the best design so far; the phase solver
      // sees task.diverged and runs it in a way that keeps its iterates at
      // (or near) equilibrium (PhaseSolver::divergedRetry). A second
      // divergence ends the run.
      if (attempt < 1) {
        ++attempt;
        retryDiverged = true;
        notes.push_back("the iterates of " + task.label + " " +
                        (pr.message.empty() ? std::string("left equilibrium far behind") : pr.message) +
                        " (iteration " + std::to_string(iterations) + "); the phase was " + solver.divergedRetry() +
                        retryStart());
        --ph;
        continue;
      }
      stop = Outcome::Stalled;
      message = "the iterates left equilibrium far behind in " + task.label +
                ", also in its retry; the best design so far is the result";
      break;
    }
    if (pr.end == PhaseEnd::TimeLimit || pr.end == PhaseEnd::Interrupted) {
      stop = pr.end == PhaseEnd::Interrupted ? Outcome::Interrupted : Outcome::TimeLimit;
      message = stop == Outcome::Interrupted ? "interrupted" : "time limit reached";
      break;
    }
    if (pr.end == PhaseEnd::IterationLimit) {
      stop = Outcome::MaxIterations;
      message = "iteration limit reached";
      break;
    }
    if (pr.end == PhaseEnd::Failed) {
      stop = pr.failure;
      message = pr.message + (kept >= 0 ? "" : "; the phase's design was not kept");
      // A failed phase with a usable best design so far is not a failed run.
      if (stop == Outcome::NumericalFailure && res_.objective < res_.initialObjective) stop = Outcome::Stalled;
      break;
    }
    // The kept design's equilibria must be the ones reached along the
    // loading path; otherwise the run continues from those (once per phase:
    // the phase is run again from them when it was the schedule's last).
    // When the last phase ends off the path again, the result is the design
    // of the run that does best as loaded from rest (adoptBestOnPath), with
    // its loading path's equilibria, and the run is not converged.
    std::vector<PoseState> path;
    std::string note;
    bool offPath = false;
    bool off = false, seeded = false;
    if (kept >= 0 && !interrupted() && !timeUp()) {
      doing("checking the design kept at the end of " + task.label + ": every pose from rest along its loading path");
      off = offLoadingPath(task, path, note, seeded);
    }
    if (off) {
      // The last phase is run again from the loading path's equilibria
      // once, and once from a seeded rest shape that brought the path onto
      // the designed branch (also after a diverged phase's retry: the
      // optimizer then works on from a design that is on its path).
      const bool seededAgain = seeded && !seededRetry;
      if (!task.lastPhase || attempt < 1 || seededAgain) {
        offPath = true;
        if (seeded) {
          notes.push_back(note);  // the seeded design is the best design, with its path's equilibria
        } else {
          notes.push_back(note + ": the run went on from the loading path's equilibria");
          continueFromPath(std::move(path));
        }
        if (task.lastPhase) {
          if (seeded) seededRetry = true;
          ++attempt;
          --ph;
          continue;
        }
      } else if (!onPathRetry && solver.solvesOnPath() && !interrupted() && !timeUp()) {
        // The last resort: the last phase once more from the design that
        // does best as loaded from rest, every equilibrium solved from rest
        // along its loading path, so that every design it accepts is on its
        // path (and the objective is the loaded object's).
        const std::string adopted = adoptBestOnPath();
        notes.push_back("the last phase ended off the loading path again (" + note + "); it was run once more from " +
                        adopted + " (RMS " + millimetres(res_.rms) +
                        " as loaded from rest), every equilibrium solved from rest along its loading path");
        onPathRetry = true;
        ++attempt;
        --ph;
        continue;
      } else {
        stop = Outcome::Stalled;
        const std::string adopted = adoptBestOnPath();
        message = "the last phase ended off the loading path again (" + note + "); the result is " + adopted +
                  ", the design of the run that does best as loaded from rest (RMS " + millimetres(res_.rms) + ")";
        break;
      }
    }
    if ((pr.end == PhaseEnd::TargetsMet && !offPath) || res_.objective <= kTargetsMetRatio * res_.initialObjective) {
      message = "every target met to round-off";
      break;
    }
    // A run that went on from a loading path's equilibria and whose last
    // phase ended (on its path) worse, as loaded from rest, than a design it
    // held before: the last phase once more from that design, on the path
    // (the last resort above).
    if (task.lastPhase && !offPath && onPathFromBest("the last phase ended on its loading path")) {
      ++attempt;
      --ph;
      continue;
    }
    attempt = 0;
    retryDiverged = false;
    if (task.lastPhase && !pr.message.empty() && pr.end != PhaseEnd::PhaseCap) message = pr.message;
    // A round (rest shape, then radii) ends the run when it lowered the
    // objective by less than roundRelativeDecrease, or the RMS by less than
    // kMeaningfulRmsPerIteration of the initial design's per iteration.
    if (step.round > 0 && step.phase.radii) {
      const double gain = (roundStart - res_.objective) / std::max(roundStart, 1e-300);
      if (gain < opt_.roundRelativeDecrease ||
          !meaningfulGain(roundStart, res_.objective, res_.initialObjective, iterations - roundStartIteration)) {
        char buf[240];
        std::snprintf(buf, sizeof buf,
                      "rest-shape/radii round %d lowered the objective by %.2g%% (less than %.2g%%, or the RMS by less "
                      "than %.2g%% of the initial design's per iteration)",
                      step.round, 100 * gain, 100 * opt_.roundRelativeDecrease, 100 * kMeaningfulRmsPerIteration);
        // The alternation ends; from a better design on its path, a joint
        // phase on the path instead (the last resort above).
        if (onPathFromBest(buf)) {
          steps.resize(ph + 1);
          steps.push_back({{scene_.design.radii, scene_.design.restShape, space_.numLevels() - 1}, 0});
          continue;
        }
        message = buf;
        break;
      }
      if (task.lastPhase) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "alternation limit reached: round %d still lowered the objective by %.2g%%",
                      step.round, 100 * gain);
        stop = Outcome::MaxIterations;
        message = buf;
      }
    }
  }

  if (monitor_) {
    // A run that converged by its own tests, on its optimizer's equilibria
    // throughout, archives its own design: the checks still queued are not
    // waited for (seconds on a run that met its targets quickly), and the
    // monitor's best design is no fallback either, since which designs were
    // checked by then depends on timing.
    const bool needed = stop != Outcome::Converged || wentOnFromPath_;
    if (needed) waitForMonitor();
    monitor_->stop();
    if (needed && adoptConfirmed(*monitor_, stop, res_, optimizer_, fallbacks_))
      message += "; the best design confirmed during the run (iteration " + std::to_string(monitor_->best()->iteration) +
                 ") is better than the last phase's and is the result";
  }
  // Going on from a loading path's equilibria (the optimizer's were not
  // those of the loaded object) can end worse, as loaded from rest, than a
  // design the run held before: that design is then the result, and the run
  // did not converge (its archived equilibria are not the ones it ended at).
  if (wentOnFromPath_) {
    const OnPathDesign best = bestKnownOnPath();
    // The last design itself, kept on its path at its phase's end, differs
    // from the result only by the round-off between its two equilibria.
    if (!sameControls(best.controls, res_.controls) && best.objective < res_.objective) {
      message += "; the last design as loaded from rest (RMS " + millimetres(res_.rms) + ") is worse than " +
                 best.label + " (RMS " + millimetres(best.rms) + "), which is the result";
      adopt(best.controls, best.design, best.objective, best.rms, best.states, best.states);
      if (stop == Outcome::Converged) stop = Outcome::Stalled;
    }
  }
  if (opt_.imperfectionBackOff && opt_.deferImperfectionBackOff) {
    res_.imperfectionBackOffPending = true;
  } else if (opt_.imperfectionBackOff && !interrupted() && !timeUp()) {
    doing(kCheckingImperfection);
    const std::string backOff = backOffFromImperfection();
    if (!backOff.empty()) message += "; " + backOff;
  }
  for (const std::string& n : notes) message += "; " + n;
  res_.iterations = iterations;
  res_.states = optimizer_;
  res_.fallbacks = fallbacks_.designs();
  return finish(stop, message);
}

void completeImperfectionBackOff(const SceneModel& model, const DesignSpace& space, const DesignOptimizerOptions& opt,
                                 DesignOptimizerResult& res) {
  if (!res.imperfectionBackOffPending) return;
  res.imperfectionBackOffPending = false;
  const auto t0 = Clock::now();
  auto interrupted = [&opt] { return opt.stopRequested && opt.stopRequested(); };
  auto timeUp = [&opt, t0] { return opt.timeLimit > 0 && since(t0) >= opt.timeLimit; };
  const TargetObjective objective(model.scene(), model.effects());
  if (!interrupted() && !timeUp()) {
    if (opt.activity) opt.activity(kCheckingImperfection);
    BackOffRun run{
        model,
        space,
        objective,
        opt,
        res.startControls,
        res,
        interrupted,
        timeUp,
        [&res](const ControlValues& c, const Design& d, double f, double rms, const std::vector<PoseState>& states) {
          res.controls = c;
          res.design = d;
          res.objective = f;
          res.rms = rms;
          res.states = states;
        }};
    const std::string backOff = backOffFromImperfection(run);
    if (!backOff.empty()) res.message += "; " + backOff;
  }
  describeResult(model, space, objective, opt, res, !interrupted() && !timeUp());
  res.timeSeconds += since(t0);
  res.solverSeconds = std::max(0.0, res.timeSeconds - res.evaluationSeconds);
  res.peakMemoryBytes = std::max(res.peakMemoryBytes, peakResidentMemory());
}

DesignOptimizerResult runDesign(const SceneModel& model, const DesignSpace& space, const DesignOptimizerOptions& options,
                                PhaseSolver& solver, const DesignProgress& progress) {
  DesignDriver driver(model, space, options, progress);
  return driver.run(solver);
}

}  // namespace rodmesh
