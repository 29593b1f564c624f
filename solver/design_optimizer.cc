#include "solver/design_optimizer.hh"

#include "solver/design_driver.hh"
#include "solver/design_fallback.hh"
#include "solver/parallel.hh"
#include "solver/reduced_hessian.hh"

#include <Eigen/SparseCholesky>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <memory>
#include <thread>

#include <sys/resource.h>

namespace rodmesh {
namespace {
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

}  // namespace

TargetObjective::TargetObjective(const Scene& scene, const EffectSet& effects) : scene_(scene), fx_(effects) {
  for (const Pose& p : scene.poses) weights_.push_back(p.weight);
}

double TargetObjective::pose(const PoseSystem& sys, const PoseState& state, const Design& d, Eigen::VectorXd* dfdu,
                             Eigen::VectorXd* dfdp, double* sumSquared) const {
  const int k = sys.poseIndex();
  const std::vector<Vec3>& target = scene_.poses[k].target;
  const double w = weights_[k];
  const std::vector<Vec3> x = sys.positions(state, d);
  const auto& B = fx_.planeBasis;
  double f = 0.0, ss = 0.0;
  for (std::size_t v = 0; v < x.size(); ++v) {
    const Vec3 r = x[v] - target[v];
    ss += r.squaredNorm();
    f += 0.5 * w * r.squaredNorm();
    const int dof = sys.vertexDof()[v];
    if (dof >= 0) {
      if (!dfdu) continue;
      if (sys.dofsPerVertex() == 3) dfdu->segment<3>(dof) += w * r;
      else dfdu->segment<2>(dof) += w * (B.transpose() * r);
    } else if (dfdp) {
      // A held vertex follows its rest position (projected onto the plane of
      // a planar scene), with the system's coefficient.
      Vec3 gr = w * sys.heldDesignCoefficient(static_cast<int>(v), state.loadFactor) * r;
      if (sys.dofsPerVertex() == 2) gr = B * (B.transpose() * gr);
      dfdp->segment<3>(Design::restIndex(static_cast<int>(v), 0)) += gr;
    }
  }
  if (sumSquared) *sumSquared = ss;
  return f;
}

double TargetObjective::rms(double sumSquared) const {
  const double n = static_cast<double>(scene_.poses.size() * scene_.vertices.size());
  return n > 0 ? std::sqrt(sumSquared / n) : 0.0;
}

BfgsOptions reducedBfgsDefaults() {
  BfgsOptions b;
  b.initialMaxStep = 0.1;
  b.minStep = 1e-9;
  b.maxStepLimit = 10.0;
  return b;
}

TrustRegionOptions newtonTrustRegionDefaults() {
  TrustRegionOptions t;
  t.initialRadius = 1.0;
  t.maxRadius = 100.0;
  t.minRadius = 1e-9;
  t.maxCgIterations = 300;
  t.forcing = 0.1;
  return t;
}

std::string DesignOptimizerOptions::isValid() const {
  if (maxIterations < 0) return "maximum iterations must be non-negative";
  if (!(timeLimit >= 0) || !std::isfinite(timeLimit)) return "time limit must be a non-negative number of seconds";
  if (!(tolerance > 0 && tolerance < 1)) return "tolerance must lie in (0, 1)";
  if (threads < 1) return "threads must be at least 1";
  if (maxAlternations < 0 || maxLevelIterations < 1 || maxPhaseIterations < 1 || phaseWindow < 1)
    return "bad schedule limits (rounds, iterations per phase or window)";
  if (!(phaseRelativeDecrease >= 0 && phaseRelativeDecrease < 1) ||
      !(roundRelativeDecrease >= 0 && roundRelativeDecrease < 1))
    return "relative decreases of a phase and of a round must lie in [0, 1)";
  if (stallWindow < 1 || !(stallRelativeDecrease >= 0 && stallRelativeDecrease < 1))
    return "the stall window must be at least 1 and its relative decrease in [0, 1)";
  if (std::string why = bfgs.isValid(); !why.empty()) return "BFGS: " + why;
  if (std::string why = trustRegion.isValid(); !why.empty()) return "Newton-CG: " + why;
  return newton.isValid();
}

// ------------------------------------------------------------------------

ReducedObjective::ReducedObjective(const SceneModel& model, const DesignSpace& space, const TargetObjective& objective,
                                   const DesignPhase& phase, const ControlValues& base, const NewtonOptions& newton,
                                   int threads, std::vector<PoseState> warm)
    : model_(model),
      space_(space),
      objective_(objective),
      phase_(phase),
      base_(base),
      newton_(newton),
      threads_(threads),
      J_(space.jacobian(phase)),
      warm_(std::move(warm)) {}

bool ReducedObjective::solvePoses(const Design& d, std::vector<PoseState>& states) {
  const int n = model_.numPoses();
  states = warm_;
  std::vector<Eigen::VectorXd> prediction = std::move(prediction_);
  prediction_.clear();
  std::vector<char> ok(n, 0), restarted(n, 0);
  forEachPose(n, threads_, [&](int p) {
    try {
      const PoseSystem& sys = model_.pose(p);
      if (fromRest_) {
        states[p] = sys.restState(d);
      } else if (static_cast<int>(prediction.size()) == n && prediction[p].size() == states[p].u.size() &&
                 states[p].loadFactor == 1.0) {
        // Start from the prediction when it is closer to equilibrium (smaller
        // force residual under the new design) than the warm start.
        Eigen::VectorXd gw, gp;
        sys.evaluate(states[p], d, &gw, nullptr);
        PoseState predicted = states[p];
        predicted.u += prediction[p];
        sys.evaluate(predicted, d, &gp, nullptr);
        if (gp.allFinite() && sys.forceResidual(gp).norm() < sys.forceResidual(gw).norm())
          states[p] = std::move(predicted);
      }
      const NewtonReport r = solveEquilibrium(sys, d, states[p], newton_);
      ok[p] = r.converged() && states[p].loadFactor == 1.0;
      restarted[p] = !fromRest_ && r.loadSteps > 1;
    } catch (...) {
      ok[p] = 0;
    }
  });
  bool all = true;
  for (int p = 0; p < n; ++p) {
    all = all && ok[p];
    restarts_ += restarted[p];
  }
  if (!all) failedSolves_++;
  return all;
}

void ReducedObjective::setDesignDerivatives(DesignDerivatives mode, const Eigen::VectorXd& scale) {
  derivatives_ = mode;
  fdScale_ = scale;
  if (mode != DesignDerivatives::Exact && fdScale_.size() != J_.cols())
    throw std::invalid_argument("finite-difference design derivatives need one scale per design variable");
}

bool ReducedObjective::probeObjective(const Eigen::VectorXd& z, const std::vector<PoseState>& start, double& f) {
  const Design d = space_.toDesign(space_.unpack(phase_, z, base_));
  const int n = model_.numPoses();
  std::vector<double> fk(n, 0.0);
  std::vector<char> ok(n, 0);
  forEachPose(n, threads_, [&](int p) {
    try {
      const PoseSystem& sys = model_.pose(p);
      PoseState st = start[p];
      const NewtonReport r = solveEquilibrium(sys, d, st, newton_);
      ok[p] = r.converged() && st.loadFactor == 1.0;
      if (ok[p]) fk[p] = objective_.pose(sys, st, d, nullptr, nullptr);
    } catch (...) {
      ok[p] = 0;
    }
  });
  f = 0.0;
  for (int p = 0; p < n; ++p) {
    if (!ok[p]) return false;
    f += fk[p];
  }
  return std::isfinite(f);
}

bool ReducedObjective::evaluate(const Eigen::VectorXd& z, double& f, Eigen::VectorXd* g) {
  const auto t0 = Clock::now();
  const bool ok = evaluateImpl(z, f, g);
  seconds_ += since(t0);
  return ok;
}

bool ReducedObjective::evaluateImpl(const Eigen::VectorXd& z, double& f, Eigen::VectorXd* g) {
  if (!z.allFinite()) return false;
  const Design d = space_.toDesign(space_.unpack(phase_, z, base_));
  std::vector<PoseState> states;
  const bool cached = lastZ_.size() == z.size() && lastZ_ == z;
  if (cached) {
    states = lastStates_;
  } else if ((stop_ && stop_()) || !solvePoses(d, states)) {
    return false;
  }
  const int n = model_.numPoses();
  std::vector<double> fk(n, 0.0), ssk(n, 0.0);
  std::vector<Eigen::VectorXd> dfdp(n), dfdz(n);
  std::vector<char> ok(n, 1);
  const bool adjoint = g && derivatives_ != DesignDerivatives::FiniteDifferenceResolve;
  forEachPose(n, threads_, [&](int p) {
    try {
      const PoseSystem& sys = model_.pose(p);
      const PoseState& state = states[p];
      if (!adjoint) {
        fk[p] = objective_.pose(sys, state, d, nullptr, nullptr, &ssk[p]);
        return;
      }
      Eigen::VectorXd dfdu = Eigen::VectorXd::Zero(sys.numDofs());
      dfdp[p] = Eigen::VectorXd::Zero(d.numParameters());
      fk[p] = objective_.pose(sys, state, d, &dfdu, &dfdp[p], &ssk[p]);
      if (sys.numDofs() == 0) return;
      // Adjoint: H lambda = df/du with the equilibrium's Hessian.
      Eigen::VectorXd grad;
      Eigen::SparseMatrix<double> H;
      sys.evaluate(state, d, &grad, &H);
      Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt(H);
      if (ldlt.info() != Eigen::Success) {
        ok[p] = 0;
        return;
      }
      const Eigen::VectorXd lambda = ldlt.solve(dfdu);
      if (!lambda.allFinite()) {
        ok[p] = 0;
        return;
      }
      if (derivatives_ == DesignDerivatives::Exact) {
        dfdp[p] -= sys.designForceProduct(state, d, lambda);
        return;
      }
      // The paper's recipe: dF/dz_i by central differences of the force at
      // the fixed equilibrium u (same charts and load factor), contracted
      // with lambda.
      dfdz[p] = Eigen::VectorXd::Zero(z.size());
      Eigen::VectorXd zp = z, Fp, Fm;
      for (int i = 0; i < z.size(); ++i) {
        const double h = fdForceStep * fdScale_[i];
        zp[i] = z[i] + h;
        sys.evaluate(state, space_.toDesign(space_.unpack(phase_, zp, base_)), &Fp, nullptr);
        zp[i] = z[i] - h;
        sys.evaluate(state, space_.toDesign(space_.unpack(phase_, zp, base_)), &Fm, nullptr);
        zp[i] = z[i];
        dfdz[p][i] = -lambda.dot(Fp - Fm) / (2 * h);
      }
    } catch (...) {
      ok[p] = 0;
    }
  });
  double ss = 0.0;
  f = 0.0;
  for (int p = 0; p < n; ++p) {
    if (!ok[p]) return false;
    f += fk[p];
    ss += ssk[p];
  }
  if (!std::isfinite(f)) return false;
  if (adjoint) {
    Eigen::VectorXd total = Eigen::VectorXd::Zero(d.numParameters());
    for (int p = 0; p < n; ++p)
      if (dfdp[p].size()) total += dfdp[p];
    *g = J_.transpose() * total;
    for (int p = 0; p < n; ++p)
      if (dfdz[p].size()) *g += dfdz[p];
    if (!g->allFinite()) return false;
  } else if (g) {
    // Central differences of the reduced objective, every probe re-solving
    // every pose from the equilibrium at z.
    g->resize(z.size());
    Eigen::VectorXd zp = z;
    for (int i = 0; i < z.size(); ++i) {
      const double h = fdResolveStep * fdScale_[i];
      double fp, fm;
      if (stop_ && stop_()) return false;
      zp[i] = z[i] + h;
      if (!probeObjective(zp, states, fp)) return false;
      zp[i] = z[i] - h;
      if (!probeObjective(zp, states, fm)) return false;
      zp[i] = z[i];
      (*g)[i] = (fp - fm) / (2 * h);
    }
    if (!g->allFinite()) return false;
  }
  lastZ_ = z;
  lastStates_ = std::move(states);
  lastF_ = f;
  lastSumSq_ = ss;
  return true;
}

void ReducedObjective::accept(const Eigen::VectorXd& z) {
  if (lastZ_.size() == z.size() && lastZ_ == z) warm_ = lastStates_;
}

// ------------------------------------------------------------------------

const char* designDerivativesName(DesignDerivatives d) {
  switch (d) {
    case DesignDerivatives::FiniteDifference: return "fd";
    case DesignDerivatives::FiniteDifferenceResolve: return "fd-resolve";
    default: return "exact";
  }
}

const char* phaseName(const DesignPhase& ph) {
  if (ph.radii && ph.restShape) return "joint";
  return ph.radii ? "radii" : "rest_shape";
}

std::string describeStep(const DesignStep& step) {
  return std::string(phaseName(step.phase)) +
         (step.round > 0 ? " round " + std::to_string(step.round) : " level " + std::to_string(step.phase.level));
}

Eigen::VectorXd designVariableScale(const DesignSpace& space, const DesignPhase& ph, const Scene& scene) {
  Eigen::VectorXd lo, hi;
  space.bounds(ph, lo, hi);
  double rodLength = 0.0;
  for (const Rod& r : scene.rods)
    for (std::size_t i = 1; i < r.vertices.size(); ++i)
      rodLength += (scene.vertices[r.vertices[i]] - scene.vertices[r.vertices[i - 1]]).norm();
  rodLength /= std::max<std::size_t>(1, scene.rods.size());
  Eigen::VectorXd s(lo.size());
  for (int i = 0; i < s.size(); ++i)
    s[i] = std::isfinite(lo[i]) && std::isfinite(hi[i]) ? std::max(hi[i] - lo[i], 1e-12) : 0.1 * rodLength;
  return s;
}

std::vector<DesignStep> designSchedule(const Scene& scene, const DesignSpace& space,
                                       const DesignOptimizerOptions& opt) {
  const int finest = space.numLevels() - 1;
  const bool radii = scene.design.radii, rest = scene.design.restShape;
  std::vector<DesignStep> steps;
  if (opt.schedule == Schedule::Joint) {
    steps.push_back({{radii, rest, finest}, 0});
  } else if (opt.schedule == Schedule::Multilevel) {
    for (int l = 0; l <= finest; ++l) steps.push_back({{radii, rest, l}, 0});
  } else {
    if (radii)
      for (int l = 0; l <= finest; ++l) steps.push_back({{true, false, l}, 0});
    if (rest) {
      if (radii && opt.schedule == Schedule::Levels) {
        steps.push_back({{true, true, finest}, 0});
      } else if (radii) {
        for (int r = 1; r <= opt.maxAlternations; ++r) {
          steps.push_back({{false, true, finest}, r});
          steps.push_back({{true, false, finest}, r});
        }
      } else {
        steps.push_back({{false, true, finest}, 0});
      }
    }
  }
  return steps;
}

void StallDetector::add(double settledObjective, bool nearEquilibrium) {
  const double previous = best_.empty() ? std::numeric_limits<double>::infinity() : best_.back();
  best_.push_back(std::min(previous, std::isnan(settledObjective) ? previous : settledObjective));
  near_.push_back(nearEquilibrium ? 1 : 0);
}

double StallDetector::best() const { return best_.empty() ? std::numeric_limits<double>::infinity() : best_.back(); }

bool StallDetector::stalled() const {
  const int n = static_cast<int>(best_.size());
  if (window_ < 1 || n <= window_) return false;
  const double before = best_[n - 1 - window_], now = best_[n - 1];
  if (!std::isfinite(before)) return false;
  for (int i = n - window_; i < n; ++i)
    if (!near_[i]) return false;
  return now > (1.0 - relative_) * before || (initial_ > 0 && !meaningfulGain(before, now, initial_, window_));
}

bool meaningfulGain(double before, double after, double initial, int iterations) {
  return std::sqrt(std::max(before, 0.0)) - std::sqrt(std::max(after, 0.0)) >=
         kMeaningfulRmsPerIteration * std::max(iterations, 1) * std::sqrt(std::max(initial, 0.0));
}

bool adoptConfirmed(const DesignMonitor& monitor, Outcome outcome, DesignOptimizerResult& res,
                    std::vector<PoseState>& states, DesignFallbacks& fallbacks) {
  const std::optional<ConfirmedDesign> best = monitor.best();
  if (!best) return false;
  fallbacks.add(best->controls, best->objective, best->rms, best->label + " (confirmed from rest during the run)",
                /*pinned=*/true);
  if (outcome == Outcome::Converged || !(best->objective < res.objective)) return false;
  res.controls = best->controls;
  res.design = best->design;
  res.objective = best->objective;
  res.rms = best->rms;
  states = best->states;
  return true;
}

long peakResidentMemory() {
  struct rusage ru {};
  if (getrusage(RUSAGE_SELF, &ru) != 0) return 0;
  return static_cast<long>(ru.ru_maxrss) * 1024L;  // Linux: kilobytes
}

namespace {

// How a phase of the reduced or Newton method ended, from its minimizer's status.
void setPhaseEnd(const Status& status, int iterations, bool targetsMet, const PhaseTask& task, PhaseContext& ctx,
                 PhaseResult& out) {
  Outcome o = status.outcome;
  // A phase cut by the run's limits inside an evaluation (its line search or
  // its trial step then fails) ends for that reason.
  if (o != Outcome::Converged && ctx.limitReached()) o = ctx.interrupted() ? Outcome::Interrupted : Outcome::TimeLimit;
  out.message = status.message;
  if (targetsMet) out.end = PhaseEnd::TargetsMet;
  else if (o == Outcome::TimeLimit) out.end = PhaseEnd::TimeLimit;
  else if (o == Outcome::Interrupted) out.end = PhaseEnd::Interrupted;
  else if (o == Outcome::MaxIterations)
    out.end = iterations >= task.remainingIterations ? PhaseEnd::IterationLimit : PhaseEnd::PhaseCap;
  else if (o == Outcome::Stalled) out.end = PhaseEnd::Stalled;
  else if (o == Outcome::Converged) out.end = PhaseEnd::Converged;
  else {
    out.end = PhaseEnd::Failed;
    out.failure = o;
  }
}

// The iteration cap of a phase: radius levels maxLevelIterations, phases of
// the alternation (the last one included) maxPhaseIterations; the last phase
// of a schedule without alternation (joint, radii only, rest shape only) is
// the whole rest of the run and only has the run's limits.
int phaseIterationCap(const PhaseTask& task, const DesignOptimizerOptions& opt) {
  const int cap = task.step.round > 0 ? opt.maxPhaseIterations
                  : task.lastPhase    ? task.remainingIterations
                                      : opt.maxLevelIterations;
  return std::min(task.remainingIterations, cap);
}

// What the nested phases (BFGS and Newton-CG, whose iterates are
// equilibria solved by a ReducedObjective) share: their limits, the
// progress entry of an accepted iterate, and the candidate a phase ends with.
class NestedPhase {
 public:
  NestedPhase(const PhaseTask& task, PhaseContext& ctx, const DesignSpace& space, const TargetObjective& objective,
              ReducedObjective& ro, const Eigen::VectorXd& scale)
      : task_(task), ctx_(ctx), space_(space), objective_(objective), ro_(ro), s_(scale), accepted_{task.objective} {}

  // Every phase stops on the gradient test, on the relative decrease over a
  // window, on its cap (phaseIterationCap) and on the run's time limit.
  template <class MinimizerOptions>
  void setLimits(MinimizerOptions& o, const DesignOptimizerOptions& opt) const {
    o.maxIterations = phaseIterationCap(task_, opt);
    o.timeLimit = opt.timeLimit > 0 ? std::max(1e-3, ctx_.remainingTime()) : 0.0;
    o.gradientTolerance = opt.tolerance;
    o.relativeDecrease = opt.phaseRelativeDecrease;
    o.stallWindow = opt.phaseWindow;
  }

  // The minimizer accepted y (scaled variables): the objective keeps its
  // equilibria as the next warm start.
  void accept(const Eigen::VectorXd& y) {
    acceptedZ_ = y.cwiseProduct(s_);
    ro_.accept(acceptedZ_);
  }
  // The progress entry of the minimizer's iteration `iteration` (of this
  // phase), RMS from the objective's last evaluation (the accepted point's).
  DesignIterate iterate(int iteration, double f, double projectedGradientNorm, double step, int evaluations) const {
    DesignIterate di;
    di.iteration = task_.iterationBase + iteration;
    di.level = task_.step.phase.level;
    di.phase = phaseName(task_.step.phase);
    di.objective = f;
    di.rms = objective_.rms(ro_.lastSumSquared());
    di.gradientNorm = projectedGradientNorm;
    di.step = step;
    di.elapsed = ctx_.elapsed();
    di.evaluations = evaluations;
    return di;
  }
  // Hands the entry and the accepted design to the driver.
  void offer(DesignIterate di) {
    ControlValues c;
    if (acceptedZ_.size() > 0) c = space_.unpack(task_.step.phase, acceptedZ_, task_.controls);
    const double f = di.objective;
    targetsMet_ = ctx_.iterate(di, acceptedZ_.size() > 0 ? &c : nullptr, true, true);
    // No meaningful progress, the rule of SAND's StallDetector: over the
    // last stallWindow accepted iterates (every one an equilibrium) the RMS
    // fell by less than kMeaningfulRmsPerIteration x stallWindow of the
    // initial design's RMS. The relative-decrease rule of the minimizers
    // does not see this: a run near an exact design keeps halving an error
    // that no longer matters to a designer.
    accepted_.push_back(f);
    const int w = ctx_.options().stallWindow;
    const std::size_t n = accepted_.size();
    if (w > 0 && n > static_cast<std::size_t>(w) &&
        !meaningfulGain(accepted_[n - 1 - w], f, ctx_.initialObjective(), w)) {
      char buf[200];
      std::snprintf(buf, sizeof buf,
                    "no meaningful progress: the last %d iterations lowered the RMS by less than %.2g%% of the "
                    "initial design's",
                    w, 100 * kMeaningfulRmsPerIteration * w);
      stalled_ = buf;
    }
  }
  bool targetsMet() const { return targetsMet_; }
  // The phase stopped because it made no meaningful progress: why (empty: it did not).
  const std::string& stalled() const { return stalled_; }
  bool stopRequested() const { return targetsMet_ || !stalled_.empty() || ctx_.interrupted(); }
  // The phase's end, from the minimizer's status and this phase's own stops.
  void setEnd(const Status& status, int iterations, PhaseResult& out) const {
    setPhaseEnd(status, iterations, targetsMet_, task_, ctx_, out);
    if (!targetsMet_ && !stalled_.empty() && status.outcome == Outcome::Interrupted && !ctx_.interrupted()) {
      out.end = PhaseEnd::Stalled;
      out.message = stalled_;
    }
  }

  // The phase's candidate: the minimizer's best point x (scaled) with its
  // equilibria (the objective caches the last evaluation; the best point is
  // usually the last accepted one). After the run's limits an evaluation
  // that must solve fails: then the last accepted point, whose equilibria
  // the objective holds.
  void addCandidate(const Eigen::VectorXd& x, double f, PhaseResult& out) {
    const std::vector<PoseState> acceptedStates = ro_.warmStates();
    if (std::isfinite(f)) {
      const Eigen::VectorXd z = x.cwiseProduct(s_);
      double fz;
      if (ro_.evaluate(z, fz, nullptr)) {
        ro_.accept(z);
        out.candidates.push_back({space_.unpack(task_.step.phase, z, task_.controls), ro_.warmStates()});
        return;
      }
    }
    if (acceptedZ_.size() > 0)
      out.candidates.push_back({space_.unpack(task_.step.phase, acceptedZ_, task_.controls), acceptedStates});
  }

 private:
  const PhaseTask& task_;
  PhaseContext& ctx_;
  const DesignSpace& space_;
  const TargetObjective& objective_;
  ReducedObjective& ro_;
  const Eigen::VectorXd& s_;
  Eigen::VectorXd acceptedZ_;  // the last accepted point, unscaled (progress follows accepted points)
  bool targetsMet_ = false;
  std::vector<double> accepted_;  // objective at the phase's start and at every accepted iterate
  std::string stalled_;
};

// The reduced method's phase: BFGS with a projected line search
// (solver/bfgs.hh) on the phase's scaled variables, every evaluation solving
// the equilibria (ReducedObjective).
class ReducedPhaseSolver : public PhaseSolver {
 public:
  ReducedPhaseSolver(const SceneModel& model, const DesignSpace& space, const DesignOptimizerOptions& opt)
      : model_(model), space_(space), opt_(opt), objective_(model.scene(), model.effects()) {}

  bool iteratesAreEquilibria() const override { return true; }
  bool solvesOnPath() const override { return true; }

  PhaseResult solvePhase(const PhaseTask& task, PhaseContext& ctx) override {
    const DesignPhase& phase = task.step.phase;
    const Scene& scene = model_.scene();
    PhaseResult out;
    ReducedObjective ro(model_, space_, objective_, phase, task.controls, opt_.newton, opt_.threads, task.states);
    const Eigen::VectorXd s = designVariableScale(space_, phase, scene);
    if (opt_.designDerivatives != DesignDerivatives::Exact) ro.setDesignDerivatives(opt_.designDerivatives, s);
    ro.setStop([&ctx] { return ctx.limitReached(); });
    ro.setFromRest(task.onPath);
    Eigen::VectorXd lo, hi;
    space_.bounds(phase, lo, hi);
    const Eigen::VectorXd y0 = space_.pack(phase, task.controls).cwiseQuotient(s);
    BfgsOptions bo = opt_.bfgs;
    NestedPhase np(task, ctx, space_, objective_, ro, s);
    np.setLimits(bo, opt_);
    BfgsCallbacks cb;
    cb.accepted = [&](const Eigen::VectorXd& y) { np.accept(y); };
    cb.stopRequested = [&] { return np.stopRequested(); };
    cb.progress = [&](const BfgsIterate& it) {
      if (it.iteration == 0) return;  // the phase's start is the previous phase's end
      np.offer(np.iterate(it.iteration, it.f, it.projectedGradientNorm, it.step, it.evaluations));
    };
    auto fobj = [&](const Eigen::VectorXd& y, double& f, Eigen::VectorXd* g) {
      const bool ok = ro.evaluate(y.cwiseProduct(s), f, g);
      if (ok && g) *g = g->cwiseProduct(s);
      return ok;
    };
    const BfgsResult br = minimizeBfgs(fobj, y0, lo.cwiseQuotient(s), hi.cwiseQuotient(s), bo, cb);
    out.iterations = br.iterations;
    out.evaluations = br.evaluations;
    out.failedEvaluations = br.failedEvaluations;
    out.equilibriumRestarts = ro.restarts();
    np.addCandidate(br.x, br.f, out);
    out.evaluationSeconds = ro.evaluationSeconds();
    np.setEnd(br.status, br.iterations, out);
    return out;
  }

 private:
  const SceneModel& model_;
  const DesignSpace& space_;
  const DesignOptimizerOptions& opt_;
  const TargetObjective objective_;
};

// The Newton method's phase: trust-region Newton-CG (solver/trust_region.hh)
// on the phase's scaled variables y = z / designVariableScale, values from
// ReducedObjective (equilibria warm-started from the last accepted design),
// gradient and exact Hessian products from ReducedHessian at every accepted
// design.
class NewtonPhaseSolver : public PhaseSolver {
 public:
  NewtonPhaseSolver(const SceneModel& model, const DesignSpace& space, const DesignOptimizerOptions& opt)
      : model_(model), space_(space), opt_(opt), objective_(model.scene(), model.effects()) {}

  bool iteratesAreEquilibria() const override { return true; }
  bool solvesOnPath() const override { return true; }

  PhaseResult solvePhase(const PhaseTask& task, PhaseContext& ctx) override {
    const DesignPhase& phase = task.step.phase;
    PhaseResult out;
    ReducedObjective ro(model_, space_, objective_, phase, task.controls, opt_.newton, opt_.threads, task.states);
    ro.setStop([&ctx] { return ctx.limitReached(); });
    ro.setFromRest(task.onPath);
    ReducedHessian rh(model_, space_, objective_, phase, opt_.threads);
    const Eigen::VectorXd s = designVariableScale(space_, phase, model_.scene());
    Eigen::VectorXd lo, hi;
    space_.bounds(phase, lo, hi);
    const Eigen::VectorXd y0 = space_.pack(phase, task.controls).cwiseQuotient(s);
    TrustRegionOptions to = opt_.trustRegion;
    NestedPhase np(task, ctx, space_, objective_, ro, s);
    np.setLimits(to, opt_);
    // The radius the last phase of this kind ended with, when this phase
    // starts where that one ended: the alternation comes back to the same
    // variables, whose scale of good steps it knows. A phase from another
    // design (a retry from a design confirmed earlier, a fallback) starts
    // afresh: the last radius may be one that shrank against a fold of a
    // loading path the new start is far from.
    const int kind = (phase.radii ? 1 : 0) + (phase.restShape ? 2 : 0);
    if (radius_[kind] > 0 && sameControls(end_[kind], task.controls))
      to.initialRadius = std::clamp(radius_[kind], 1e3 * to.minRadius, to.maxRadius);
    double hessianSeconds = 0.0;
    TrustRegionProblem problem;
    Eigen::VectorXd preparedZ;  // where rh was last prepared (the last accepted design)
    problem.value = [&](const Eigen::VectorXd& y, double& f) {
      const Eigen::VectorXd z = y.cwiseProduct(s);
      // Trial designs start their equilibria from the first-order prediction
      // (not on the loading path: those start from rest).
      if (!task.onPath && preparedZ.size() == z.size()) ro.predict(rh.equilibriumChange(z - preparedZ));
      return ro.evaluate(z, f, nullptr);
    };
    problem.prepare = [&](const Eigen::VectorXd& y, Eigen::VectorXd& g) {
      const Eigen::VectorXd z = y.cwiseProduct(s);
      double f;
      if (!ro.statesAt(z) && !ro.evaluate(z, f, nullptr)) return false;
      const auto t0 = Clock::now();
      const bool ok = rh.prepare(z, task.controls, *ro.statesAt(z));
      preparedZ = ok ? z : Eigen::VectorXd();
      hessianSeconds += since(t0);
      if (ok) g = rh.gradient().cwiseProduct(s);
      return ok;
    };
    auto timed = [&](bool gaussNewton) {
      return [&, gaussNewton](const Eigen::VectorXd& v) -> Eigen::VectorXd {
        const auto t0 = Clock::now();
        const Eigen::VectorXd w = v.cwiseProduct(s);
        Eigen::VectorXd Hv = (gaussNewton ? rh.gaussNewtonProduct(w) : rh.product(w)).cwiseProduct(s);
        hessianSeconds += since(t0);
        return Hv;
      };
    };
    problem.hessian = timed(false);
    problem.gaussNewton = timed(true);
    TrustRegionCallbacks cb;
    cb.accepted = [&](const Eigen::VectorXd& y) { np.accept(y); };
    cb.stopRequested = [&] { return np.stopRequested(); };
    cb.progress = [&](const TrustRegionIterate& it) {
      if (it.iteration == 0) return;  // the phase's start is the previous phase's end
      DesignIterate di = np.iterate(it.iteration, it.f, it.projectedGradientNorm, it.step, it.evaluations);
      di.cgIterations = it.cgIterations;
      di.trustRadius = it.radius;
      np.offer(di);
    };
    const TrustRegionResult tr = minimizeTrustRegion(problem, y0, lo.cwiseQuotient(s), hi.cwiseQuotient(s), to, cb);
    if (tr.iterations > 0) {
      radius_[kind] = tr.radius;
      end_[kind] = space_.unpack(phase, tr.x.cwiseProduct(s), task.controls);
    }
    out.iterations = tr.iterations;
    out.evaluations = tr.evaluations;
    out.failedEvaluations = tr.failedEvaluations;
    out.equilibriumRestarts = ro.restarts();
    np.addCandidate(tr.x, tr.f, out);
    out.evaluationSeconds = ro.evaluationSeconds() + hessianSeconds;
    np.setEnd(tr.status, tr.iterations, out);
    return out;
  }

 private:
  const SceneModel& model_;
  const DesignSpace& space_;
  const DesignOptimizerOptions& opt_;
  const TargetObjective objective_;
  double radius_[4] = {0, 0, 0, 0};  // last radius per phase kind (radii 1, rest shape 2, joint 3)
  // and the design it ended at: unpacked as the phase's candidate is, so
  // that a phase starting from that candidate matches it exactly.
  ControlValues end_[4];
};

}  // namespace

std::unique_ptr<PhaseSolver> makeReducedPhaseSolver(const SceneModel& model, const DesignSpace& space,
                                                    const DesignOptimizerOptions& options) {
  return std::make_unique<ReducedPhaseSolver>(model, space, options);
}

std::unique_ptr<PhaseSolver> makeNewtonPhaseSolver(const SceneModel& model, const DesignSpace& space,
                                                   const DesignOptimizerOptions& options) {
  return std::make_unique<NewtonPhaseSolver>(model, space, options);
}

DesignOptimizerResult optimizeNewton(const SceneModel& model, const DesignSpace& space, const DesignOptimizerOptions& opt,
                                     const DesignProgress& progress) {
  NewtonPhaseSolver solver(model, space, opt);
  return runDesign(model, space, opt, solver, progress);
}

DesignOptimizerResult optimizeReduced(const SceneModel& model, const DesignSpace& space,
                                      const DesignOptimizerOptions& opt, const DesignProgress& progress) {
  ReducedPhaseSolver solver(model, space, opt);
  return runDesign(model, space, opt, solver, progress);
}

}  // namespace rodmesh
