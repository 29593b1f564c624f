// The Ipopt side of SAND: a TNLP adapter over SandNlp and the schedule
// driver. This is the only translation unit that includes Ipopt.
#include "nlp/sand.hh"

#include "nlp/sand_nlp.hh"
#include "solver/design_driver.hh"
#include "solver/design_monitor.hh"
#include "solver/format.hh"
#include "solver/newton.hh"
#include "solver/parallel.hh"

#include "IpIpoptApplication.hpp"
#include "IpTNLP.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <memory>
#include <set>
#include <sstream>
#include <thread>

namespace rodmesh {
namespace {

using Ipopt::Index;
using Ipopt::Number;

// What stopped a phase from inside the iteration callback.
// NearlyConverged: the phase's own test (SandPhaseSolver::solvePhase).
// Diverging: the iterates left equilibrium by far more than any load
// (SandOptions::divergedLoads), the phase is stopped and retried.
enum class StopReason { None, TimeLimit, Interrupted, NearlyConverged, Diverging };

class SandTnlp : public Ipopt::TNLP {
 public:
  struct Hooks {
    std::function<void(int iter, const double* x, double infDu, double alphaPr, double regularization)> progress;
    std::function<StopReason()> stop;
    // The run's hard limits (interrupt, time limit) alone, checked at every
    // evaluation: Ipopt calls no intermediate_callback while it checks
    // derivatives (derivative_test) or inside one long line search.
    std::function<StopReason()> limits;
  };

  SandTnlp(SandNlp& nlp, Hooks hooks) : nlp_(nlp), hooks_(std::move(hooks)) {
    // Fault injection for the tests of `optimize`'s watchdog
    // (tests/cli/interrupt_cli_test.cc): RODMESH_TEST_SLOW_HESSIAN=S makes
    // every Hessian evaluation after the first take S seconds longer, as a
    // factorization that cannot finish in time would.
    if (const char* s = std::getenv("RODMESH_TEST_SLOW_HESSIAN")) slowHessian_ = std::max(0.0, std::atof(s));
  }

  bool get_nlp_info(Index& n, Index& m, Index& nnzJac, Index& nnzHess, IndexStyleEnum& style) override {
    n = nlp_.numVariables();
    m = nlp_.numConstraints();
    nnzJac = nlp_.jacobianNonZeros();
    nnzHess = nlp_.hessianNonZeros();
    style = C_STYLE;
    return true;
  }

  bool get_bounds_info(Index n, Number* xl, Number* xu, Index m, Number* gl, Number* gu) override {
    nlp_.bounds(xl, xu);
    for (Index i = 0; i < n; ++i) {
      if (std::isinf(xl[i])) xl[i] = -1e20;
      if (std::isinf(xu[i])) xu[i] = 1e20;
    }
    std::fill(gl, gl + m, 0.0);
    std::fill(gu, gu + m, 0.0);
    return true;
  }

  // Multipliers for a warm start (Ipopt's warm_start_init_point): the
  // previous phase's, already rescaled to this phase's objective scale;
  // empty: zero.
  void setWarmMultipliers(std::vector<double> lambda, double mu) {
    warmLambda_ = std::move(lambda);
    warmMu_ = mu;
  }

  bool get_starting_point(Index n, bool initX, Number* x, bool initZ, Number* zL, Number* zU, Index m,
                          bool initLambda, Number* lambda) override {
    const Eigen::VectorXd x0 = nlp_.startingPoint();
    if (initX) std::copy(x0.data(), x0.data() + n, x);
    if (initLambda) {
      if (warmLambda_.size() == static_cast<std::size_t>(m))
        std::copy(warmLambda_.begin(), warmLambda_.end(), lambda);
      else
        std::fill(lambda, lambda + m, 0.0);
    }
    if (initZ) {
      // Bound multipliers on the central path of the starting barrier
      // parameter: z = mu / slack (the design variables changed with the
      // phase, so the previous phase's bound multipliers do not apply).
      std::vector<double> lo(n), hi(n);
      nlp_.bounds(lo.data(), hi.data());
      for (Index i = 0; i < n; ++i) {
        zL[i] = std::isfinite(lo[i]) ? warmMu_ / std::max(x0[i] - lo[i], 1e-12) : 0.0;
        zU[i] = std::isfinite(hi[i]) ? warmMu_ / std::max(hi[i] - x0[i], 1e-12) : 0.0;
      }
    }
    return true;
  }

  // Once a limit is reached every evaluation fails at once (Ipopt's contract
  // for an evaluation error: nothing thrown), so that whatever Ipopt is doing,
  // the derivative checker included, ends within one evaluation; the stop
  // reason tells the schedule why.
  bool limitReached() {
    if (stopReason_ == StopReason::Interrupted || stopReason_ == StopReason::TimeLimit) return true;
    if (!hooks_.limits) return false;
    try {
      const StopReason r = hooks_.limits();
      if (r == StopReason::None) return false;
      stopReason_ = r;
    } catch (...) {
      return false;
    }
    return true;
  }

  bool eval_f(Index, const Number* x, bool, Number& f) override { return !limitReached() && nlp_.objective(x, f); }
  bool eval_grad_f(Index, const Number* x, bool, Number* g) override {
    return !limitReached() && nlp_.gradient(x, g);
  }
  bool eval_g(Index, const Number* x, bool, Index, Number* g) override {
    return !limitReached() && nlp_.constraints(x, g);
  }

  bool eval_jac_g(Index n, const Number* x, bool, Index, Index nele, Index* iRow, Index* jCol,
                  Number* values) override {
    if (!values) {
      std::copy(nlp_.jacobianRows().begin(), nlp_.jacobianRows().end(), iRow);
      std::copy(nlp_.jacobianCols().begin(), nlp_.jacobianCols().end(), jCol);
      return true;
    }
    if (limitReached()) return false;
    // Ipopt evaluates the Jacobian at each new iterate: remember it for progress.
    current_.assign(x, x + n);
    return nlp_.jacobian(x, values);
  }

  bool eval_h(Index, const Number* x, bool, Number sigma, Index, const Number* lambda, bool, Index, Index* iRow,
              Index* jCol, Number* values) override {
    if (!values) {
      std::copy(nlp_.hessianRows().begin(), nlp_.hessianRows().end(), iRow);
      std::copy(nlp_.hessianCols().begin(), nlp_.hessianCols().end(), jCol);
      return true;
    }
    if (limitReached()) return false;
    if (slowHessian_ > 0 && hessianCalls_++ > 0)
      std::this_thread::sleep_for(std::chrono::duration<double>(slowHessian_));
    return nlp_.hessian(x, sigma, lambda, values);
  }

  void finalize_solution(Ipopt::SolverReturn status, Index n, const Number* x, const Number*, const Number*, Index m,
                         const Number*, const Number* lambda, Number, const Ipopt::IpoptData*,
                         Ipopt::IpoptCalculatedQuantities*) override {
    status_ = status;
    if (x) final_.assign(x, x + n);
    if (lambda) finalLambda_.assign(lambda, lambda + m);
  }

  bool intermediate_callback(Ipopt::AlgorithmMode, Index iter, Number, Number, Number infDu, Number, Number,
                             Number regularization, Number, Number alphaPr, Index, const Ipopt::IpoptData*,
                             Ipopt::IpoptCalculatedQuantities*) override {
    iterations_ = iter;
    try {
      if (hooks_.progress && !current_.empty())
        hooks_.progress(iter, current_.data(), infDu, alphaPr, regularization);
      if (hooks_.stop) {
        stopReason_ = hooks_.stop();
        if (stopReason_ != StopReason::None) return false;
      }
    } catch (...) {
      return false;
    }
    return true;
  }

  Ipopt::SolverReturn status() const { return status_; }
  const std::vector<double>& finalPoint() const { return final_; }
  const std::vector<double>& finalMultipliers() const { return finalLambda_; }
  int iterations() const { return iterations_; }
  StopReason stopReason() const { return stopReason_; }

 private:
  SandNlp& nlp_;
  Hooks hooks_;
  std::vector<double> current_, final_, finalLambda_, warmLambda_;
  double warmMu_ = 0.0;
  double slowHessian_ = 0.0;
  int hessianCalls_ = 0;
  Ipopt::SolverReturn status_ = Ipopt::UNASSIGNED;
  int iterations_ = 0;
  StopReason stopReason_ = StopReason::None;
};

const char* solverReturnName(Ipopt::SolverReturn s) {
  switch (s) {
    case Ipopt::SUCCESS: return "optimal solution found";
    case Ipopt::MAXITER_EXCEEDED: return "maximum iterations exceeded";
    case Ipopt::CPUTIME_EXCEEDED: return "CPU time limit exceeded";
    case Ipopt::STOP_AT_TINY_STEP: return "search direction became too small";
    case Ipopt::STOP_AT_ACCEPTABLE_POINT: return "solved to an acceptable level";
    case Ipopt::LOCAL_INFEASIBILITY: return "converged to a point of local infeasibility";
    case Ipopt::USER_REQUESTED_STOP: return "stopped on request";
    case Ipopt::FEASIBLE_POINT_FOUND: return "feasible point found";
    case Ipopt::DIVERGING_ITERATES: return "iterates diverging";
    case Ipopt::RESTORATION_FAILURE: return "restoration phase failed";
    case Ipopt::ERROR_IN_STEP_COMPUTATION: return "error in step computation";
    case Ipopt::INVALID_NUMBER_DETECTED: return "invalid number in a function or derivative";
    case Ipopt::TOO_FEW_DEGREES_OF_FREEDOM: return "too few degrees of freedom";
    case Ipopt::INVALID_OPTION: return "invalid option";
    case Ipopt::OUT_OF_MEMORY: return "out of memory";
    case Ipopt::INTERNAL_ERROR: return "internal error";
    case Ipopt::UNASSIGNED: return "did not run";
  }
  return "unknown status";
}

const char* applicationStatusName(Ipopt::ApplicationReturnStatus s) {
  switch (s) {
    case Ipopt::Invalid_Option: return "invalid option";
    case Ipopt::Not_Enough_Degrees_Of_Freedom: return "too few degrees of freedom";
    case Ipopt::Invalid_Problem_Definition: return "invalid problem definition";
    case Ipopt::Unrecoverable_Exception: return "unrecoverable exception";
    case Ipopt::NonIpopt_Exception_Thrown: return "exception in a callback";
    case Ipopt::Insufficient_Memory: return "insufficient memory";
    case Ipopt::Internal_Error: return "internal error";
    default: return "did not run";
  }
}

// Settings Ipopt registers but this build cannot run: the HSL, Pardiso and
// WSMP linear solvers and HSL's MC19 scaling are not part of Debian's Ipopt
// (MUMPS is its only linear solver); Ipopt would accept them here and fail
// with "invalid option" only when the run starts.
std::string unavailableSetting(const std::string& key, const std::string& value) {
  if (key == "linear_solver" && value != "mumps")
    return "Ipopt option 'linear_solver': '" + value + "' is not available in this build (allowed: mumps)";
  if (key == "linear_system_scaling" && value == "mc19")
    return "Ipopt option 'linear_system_scaling': 'mc19' needs the HSL library, which this build does not have "
           "(allowed: none, slack-based)";
  return "";
}

// Sets a user option with the type Ipopt registered for it.
std::string setOption(Ipopt::IpoptApplication& app, const std::string& key, const std::string& value) {
  Ipopt::SmartPtr<const Ipopt::RegisteredOption> opt = app.RegOptions()->GetOption(key);
  if (!Ipopt::IsValid(opt)) return "Ipopt has no option '" + key + "'";
  if (std::string why = unavailableSetting(key, value); !why.empty()) return why;
  const char* s = value.c_str();
  char* end = nullptr;
  switch (opt->Type()) {
    case Ipopt::OT_Number: {
      const double v = std::strtod(s, &end);
      if (value.empty() || *end != '\0' || !std::isfinite(v))
        return "Ipopt option '" + key + "' takes a number, got '" + value + "'";
      if (!opt->IsValidNumberSetting(v)) return "Ipopt option '" + key + "': value " + value + " is out of range";
      app.Options()->SetNumericValue(key, v);
      return "";
    }
    case Ipopt::OT_Integer: {
      const long v = std::strtol(s, &end, 10);
      if (value.empty() || *end != '\0' || v < -2147483647L || v > 2147483647L)
        return "Ipopt option '" + key + "' takes an integer, got '" + value + "'";
      if (!opt->IsValidIntegerSetting(static_cast<Index>(v)))
        return "Ipopt option '" + key + "': value " + value + " is out of range";
      app.Options()->SetIntegerValue(key, static_cast<Index>(v));
      return "";
    }
    case Ipopt::OT_String: {
      if (!opt->IsValidStringSetting(value))
        return "Ipopt option '" + key + "': '" + value + "' is not one of its settings";
      app.Options()->SetStringValue(key, value);
      return "";
    }
    default:
      return "Ipopt option '" + key + "' has an unknown type";
  }
}

}  // namespace

std::string checkIpoptOption(const std::string& key, const std::string& value) {
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  return setOption(*app, key, value);
}

namespace {

// SAND's phase: one Ipopt solve over every pose's unknowns and the phase's
// design values (nlp/sand_nlp.hh).
class SandPhaseSolver : public PhaseSolver {
 public:
  SandPhaseSolver(const SceneModel& model, const DesignSpace& space, const SandOptions& so)
      : model_(model), space_(space), so_(so), opt_(so.optimizer), objective_(model.scene(), model.effects()) {
    warmupOptions_ = opt_;
    warmupOptions_.maxLevelIterations = std::max(1, so.warmupIterations);
    warmupOptions_.phaseWindow = std::max(1, so.warmupWindow);
    warmupOptions_.phaseRelativeDecrease = so.warmupRelativeDecrease;
    warmup_ = makeReducedPhaseSolver(model, space, warmupOptions_);
    if (so.newtonRetry) retry_ = makeNewtonPhaseSolver(model, space, opt_);
  }

  bool iteratesAreEquilibria() const override { return false; }
  // By the Newton-CG retry's solver (Ipopt's iterates are no equilibria).
  bool solvesOnPath() const override { return retry_ != nullptr; }
  std::string divergedRetry() const override {
    return retry_ ? "run again by the reduced Newton-CG method (every iterate an equilibrium)"
                  : "run again by Ipopt held near equilibrium";
  }
  std::string prepare(const std::vector<PoseState>& states, double f0) override;
  PhaseResult solvePhase(const PhaseTask& task, PhaseContext& ctx) override;
  void phaseEnded(int kept) override {
    // Multipliers for the next phase: Ipopt's final ones, if that is the
    // point kept (candidate 0 when the phase has a final point).
    warmLambda_.clear();
    if (kept >= 0 && kept == finalCandidate_) {
      warmLambda_ = std::move(finalLambda_);
      warmObjectiveScale_ = phaseObjectiveScale_;
    }
    finalLambda_.clear();
  }

 private:
  const SceneModel& model_;
  const DesignSpace& space_;
  const SandOptions& so_;
  const DesignOptimizerOptions& opt_;
  const TargetObjective objective_;
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app_;
  std::set<std::string> userSet_;  // Ipopt options the user set: left alone by the per-phase settings
  SandScaling scaling_;
  double minLoad_ = 0.0, maxLoad_ = 0.0;
  std::vector<double> warmLambda_, finalLambda_;  // the kept phase's constraint multipliers, the last phase's
  double warmObjectiveScale_ = 1.0, phaseObjectiveScale_ = 1.0;
  int finalCandidate_ = -1;
  DesignOptimizerOptions warmupOptions_;    // the first phase's BFGS start
  std::unique_ptr<PhaseSolver> warmup_;
  std::unique_ptr<PhaseSolver> retry_;      // the diverged phases' retry (SandOptions::newtonRetry)
  // Ipopt's part of a phase, from `task`'s design.
  PhaseResult solveWithIpopt(const PhaseTask& task, PhaseContext& ctx);
};

std::string SandPhaseSolver::prepare(const std::vector<PoseState>& states, double f0) {
  const Design d0 = space_.toDesign(space_.initialControls(model_.scene()));
  // Scaling: objective relative to the initial design's, constraints
  // relative to each pose's load (newtons).
  scaling_.objective = f0;
  minLoad_ = std::numeric_limits<double>::infinity();
  maxLoad_ = 0.0;
  const std::vector<double> loads = sandLoadScales(model_, d0, states);  // nlp/sand_nlp.hh
  for (int k = 0; k < model_.numPoses(); ++k) {
    const double L = loads[k];
    scaling_.load.push_back(std::isfinite(L) && L > 0 ? L : 1.0);
    minLoad_ = std::min(minLoad_, scaling_.load.back());
    maxLoad_ = std::max(maxLoad_, scaling_.load.back());
  }

  app_ = IpoptApplicationFactory();
  Ipopt::OptionsList& o = *app_->Options();
  o.SetStringValue("sb", "yes");
  o.SetIntegerValue("print_level", 0);
  o.SetStringValue("linear_solver", "mumps");
  // AMD ordering for the KKT systems. Debian's MUMPS is built without
  // METIS (5 falls back to MUMPS's automatic choice, SCOTCH on larger
  // systems), and SCOTCH's orderings differ between calls in one process,
  // so results would depend on what ran before; AMD is deterministic and
  // the cheapest per factorization on the sheets and the hat measured
  // (docs/optimization.md).
  o.SetIntegerValue("mumps_pivot_order", 0);
  // MUMPS's workspace at 1.2 times its estimate instead of Ipopt's 11
  // times: the workspace is mapped and zero-filled again at every
  // factorization. Where delayed pivots need more, MUMPS says so (INFO(1)
  // -8 or -9) and Ipopt doubles the percentage and factorizes again.
  o.SetIntegerValue("mumps_mem_percent", 20);
  o.SetStringValue("hessian_approximation", "exact");
  o.SetStringValue("mu_strategy", "adaptive");  // not monotone: docs/optimization.md
  o.SetNumericValue("tol", opt_.tolerance);
  o.SetNumericValue("dual_inf_tol", opt_.tolerance);
  o.SetNumericValue("constr_viol_tol", std::max(1e-12, 10.0 * opt_.newton.tolerance));
  o.SetNumericValue("acceptable_tol", std::min(1e-2, 1e3 * opt_.tolerance));
  o.SetNumericValue("acceptable_constr_viol_tol", 1e-6);
  // Initial constraint multipliers: Ipopt's least-squares estimate, however
  // large. By default (constr_mult_init_max 1e3) Ipopt discards an estimate
  // with any entry above 1e3 and starts from zero multipliers; the first
  // Hessian of the Lagrangian then lacks the equilibrium's own curvature
  // (sum_k lambda_k d2F_k, the geometric stiffness the objective acts
  // through), and the first step, from the BFGS start's equilibrium, left
  // equilibrium by 36 N under loads of tenths of newtons on the hat with
  // radii and rest shape free (benchmarks/defaults hat_both). With the
  // estimate kept that run stays within 1.4 N, exact in 56 s instead of
  // 117 s through a diverged phase and its Newton-CG retry
  // (docs/optimization.md, "SAND phases that diverge").
  o.SetNumericValue("constr_mult_init_max", 1e20);
  // User options before Initialize (journals such as output_file are opened
  // there) and again after it, so that they override ./ipopt.opt.
  for (const auto& [key, value] : so_.ipopt)
    if (std::string why = setOption(*app_, key, value); !why.empty()) return why;
  const Ipopt::ApplicationReturnStatus init = so_.readOptionsFile ? app_->Initialize() : app_->Initialize("");
  if (init != Ipopt::Solve_Succeeded)
    return std::string("Ipopt could not be initialised (") + applicationStatusName(init) +
           (ipoptOptionsFilePresent() ? "; check ./ipopt.opt)" : ")");
  for (const auto& [key, value] : so_.ipopt)
    if (std::string why = setOption(*app_, key, value); !why.empty()) return why;

  // Options set by the user (--ipopt, or ./ipopt.opt: a value other than
  // ours) are left alone by the per-phase settings.
  for (const auto& kv : so_.ipopt) userSet_.insert(kv.first);
  std::string strategy;
  double value = 0.0;
  if (o.GetStringValue("mu_strategy", strategy, "") && strategy != "adaptive") userSet_.insert("mu_strategy");
  if (o.GetNumericValue("tol", value, "") && value != opt_.tolerance) userSet_.insert("tol");
  if (o.GetNumericValue("dual_inf_tol", value, "") && value != opt_.tolerance) userSet_.insert("dual_inf_tol");
  if (o.GetNumericValue("mu_init", value, "")) userSet_.insert("mu_init");
  if (o.GetNumericValue("theta_max_fact", value, "")) userSet_.insert("theta_max_fact");
  Ipopt::Index trigger = 0;
  if (o.GetIntegerValue("watchdog_shortened_iter_trigger", trigger, ""))
    userSet_.insert("watchdog_shortened_iter_trigger");
  return "";
}

PhaseResult SandPhaseSolver::solvePhase(const PhaseTask& task, PhaseContext& ctx) {
  if ((task.diverged || task.onPath) && retry_) {
    finalCandidate_ = -1;  // no Ipopt multipliers for the next phase
    return retry_->solvePhase(task, ctx);
  }
  if (task.index > 0 || task.attempt > 0 || so_.warmupIterations <= 0) return solveWithIpopt(task, ctx);
  // The first phase: BFGS first (SandOptions::warmupIterations), as a phase
  // the schedule continues, so that its own cap applies.
  PhaseTask start = task;
  start.lastPhase = false;
  start.handsOver = true;
  start.remainingIterations = std::min(task.remainingIterations, so_.warmupIterations);
  PhaseResult warm = warmup_->solvePhase(start, ctx);
  if (warm.end == PhaseEnd::TimeLimit || warm.end == PhaseEnd::Interrupted || warm.end == PhaseEnd::TargetsMet ||
      warm.iterations >= task.remainingIterations) {
    if (warm.end == PhaseEnd::PhaseCap || warm.end == PhaseEnd::IterationLimit) warm.end = PhaseEnd::IterationLimit;
    finalCandidate_ = -1;
    return warm;
  }
  // Ipopt continues the phase from the best design the BFGS start found
  // (its equilibria, re-solved by Newton: ReducedObjective's states are
  // equilibria already, so this is one residual check per pose).
  PhaseTask rest = task;
  rest.iterationBase = task.iterationBase + warm.iterations;
  rest.remainingIterations = task.remainingIterations - warm.iterations;
  if (!warm.candidates.empty()) {
    std::vector<PoseState> states = warm.candidates.front().states;
    const Design d = space_.toDesign(warm.candidates.front().controls);
    if (solvePosesFrom(model_, d, states, opt_.newton, opt_.threads)) {
      double f = 0.0;
      objectiveOfStates(model_, objective_, d, states, f);
      if (std::isfinite(f) && f <= task.objective) {
        rest.controls = warm.candidates.front().controls;
        rest.states = std::move(states);
        rest.objective = f;
      }
    }
  }
  PhaseResult out = solveWithIpopt(rest, ctx);
  out.iterations += warm.iterations;
  out.evaluations += warm.evaluations;
  out.failedEvaluations += warm.failedEvaluations;
  out.equilibriumRestarts += warm.equilibriumRestarts;
  out.evaluationSeconds += warm.evaluationSeconds;
  // The BFGS start's design stays a candidate (after Ipopt's), in case
  // Ipopt ends worse.
  for (PhaseCandidate& c : warm.candidates) out.candidates.push_back(std::move(c));
  return out;
}

PhaseResult SandPhaseSolver::solveWithIpopt(const PhaseTask& task, PhaseContext& ctx) {
  const DesignPhase& phase = task.step.phase;
  const Scene& scene = model_.scene();
  const int K = model_.numPoses();
  Ipopt::OptionsList& o = *app_->Options();
  PhaseResult out;
  // The retry of a diverged phase holds the iterates near equilibrium
  // (theta_max_fact) and turns Ipopt's watchdog off, which would accept a
  // full step after repeated short ones and so leave equilibrium again.
  const bool retry = task.attempt > 0;
  if (!userSet_.count("theta_max_fact")) o.SetNumericValue("theta_max_fact", retry ? so_.retryThetaMaxFact : 1e4);
  if (!userSet_.count("watchdog_shortened_iter_trigger"))
    o.SetIntegerValue("watchdog_shortened_iter_trigger", retry ? 0 : 10);

  // Charts at the current equilibria: edges keep far from their chart's
  // singular direction while Ipopt moves them.
  std::vector<PoseState> states = task.states;
  {
    const Design d = space_.toDesign(task.controls);
    for (int k = 0; k < K; ++k)
      if (std::optional<PoseState> moved = model_.pose(k).reanchored(states[k], d, 0.5)) states[k] = std::move(*moved);
  }
  scaling_.variable = designVariableScale(space_, phase, scene);
  {
    // Radii are scaled by their own current value (within the bounds), so
    // that thin and thick rods (up to the bounds' ratio) take comparable
    // relative steps.
    Eigen::VectorXd lo, hi;
    space_.bounds(phase, lo, hi);
    const Eigen::VectorXd z = space_.pack(phase, task.controls);
    for (int i = 0; i < z.size(); ++i)
      if (std::isfinite(lo[i]) && std::isfinite(hi[i]) && lo[i] > 0) scaling_.variable[i] = std::clamp(z[i], lo[i], hi[i]);
  }
  // Objective relative to the phase's start (its scaled value starts at 1,
  // so the barrier parameter means the same in every phase); later phases
  // start at a converged design, so the barrier starts small instead of
  // pushing every design value away from its bounds first.
  scaling_.objective = std::max(task.objective, 1e-300);
  phaseObjectiveScale_ = scaling_.objective;
  if (task.index > 0 && !userSet_.count("mu_init")) o.SetNumericValue("mu_init", 1e-4);
  // Later phases start at a converged design with a small barrier
  // parameter: Fiacco-McCormick's monotone decrease then takes 30-50% fewer
  // iterations than the adaptive rule, which keeps re-raising mu (the
  // four-pose hat: 32 + 33 against 66 + 66 iterations for radius levels 1
  // and 2, docs/optimization.md). The first phase starts far from any
  // optimum and keeps the adaptive rule (with the monotone one the
  // design-at-its-bounds hard case found no better design in 150
  // iterations).
  if (!userSet_.count("mu_strategy")) o.SetStringValue("mu_strategy", task.index > 0 ? "monotone" : "adaptive");
  // A phase that the schedule continues before any alternation (the radius
  // levels, unless the last phase) only has to hand a good start to the
  // next: relative tolerance so_.handOverTolerance (or --tol if looser). The
  // last phase and the phases of the paper's alternation keep --tol.
  const double phaseTolerance = task.handsOver ? std::max(opt_.tolerance, so_.handOverTolerance) : opt_.tolerance;
  if (!userSet_.count("tol")) o.SetNumericValue("tol", phaseTolerance);
  if (!userSet_.count("dual_inf_tol")) o.SetNumericValue("dual_inf_tol", phaseTolerance);
  SandNlp nlp(model_, space_, objective_, phase, task.controls, states, scaling_, opt_.threads);
  std::pair<double, std::vector<double>> bestIterate{std::numeric_limits<double>::infinity(), {}};
  bool nearlyConverged = false, targetsMet = false, stalled = false, diverging = false;
  int farOff = 0;  // iterates in a row more than divergedLoads off equilibrium
  int offEquilibrium = 0;  // iterates in a row none of them nearly feasible (wanderingIterates)
  int regularized = 0;     // iterates in a row with a large regularization (divergedRegularization)
  std::string divergedHow;  // how the iterates diverged, when not by leaving equilibrium
  // Progress of the settled iterates (within 1e-5 of the load of
  // equilibrium: Newton's polish makes them equilibria); the phase starts at
  // an equilibrium.
  StallDetector stall(opt_.stallWindow, opt_.stallRelativeDecrease, ctx.initialObjective());
  stall.add(task.objective, true);
  SandTnlp::Hooks hooks;
  hooks.progress = [&](int iter, const double* x, double infDu, double alphaPr, double regularization) {
    if (iter == 0 && task.iterationBase > 0) return;  // a phase starts where the previous one ended
    DesignIterate it;
    it.iteration = task.iterationBase + iter;
    it.level = phase.level;
    it.phase = phaseName(phase);
    double f = 0.0;
    nlp.objective(x, f);
    it.objective = f * scaling_.objective;
    it.rms = nlp.rms(x);
    it.constraintViolation = nlp.forceViolation(x);
    it.dualInfeasibility = infDu;
    it.gradientNorm = infDu;
    it.step = alphaPr;
    it.elapsed = ctx.elapsed();
    it.evaluations = nlp.evaluations();
    // The phase ends when the iterate is stationary within the phase's
    // tolerance and within 1e-5 of the smallest load of equilibrium:
    // Newton's polish at the phase end makes it an equilibrium. Ipopt's own
    // test also wants the violation below constr_viol_tol (1e-8 of the load),
    // which it may never reach when the targets are met exactly (the
    // objective flat in many design directions, steps along them leave
    // equilibrium by 1e-7 to 1e-1 of the load: a 343-vertex sheet at --tol
    // 1e-2 ran 160 iterations at such a point, then diverged to 6.6e5 N).
    const bool settled = it.constraintViolation <= 1e-5 * minLoad_;
    const ControlValues design = nlp.controls(x);
    targetsMet = ctx.iterate(it, &design, false, settled) && iter > 0;
    nearlyConverged = iter > 0 && std::isfinite(infDu) && infDu <= phaseTolerance && settled;
    // Also when the targets are met to round-off (Ipopt's dual infeasibility
    // need not fall at such a point: the objective's scale is gone, what is
    // left is the equilibria's own round-off), and when the settled iterates
    // stopped improving (StallDetector).
    stall.add(settled ? it.objective : std::numeric_limits<double>::infinity(),
              it.constraintViolation <= 1e-3 * minLoad_);
    stalled = iter > 0 && stall.stalled();
    nearlyConverged = nearlyConverged || targetsMet || stalled;
    farOff = it.constraintViolation > so_.divergedLoads * maxLoad_ ? farOff + 1 : 0;
    offEquilibrium = iter > 0 && it.constraintViolation > 1e-3 * minLoad_ ? offEquilibrium + 1 : 0;
    regularized = regularization >= so_.divergedRegularization && infDu >= so_.regularizedDualInfeasibility
                      ? regularized + 1
                      : 0;
    diverging = farOff >= so_.divergedIterates || !(infDu <= so_.divergedDualInfeasibility) ||
                offEquilibrium >= so_.wanderingIterates || regularized >= so_.divergedIterates;
    if (diverging && regularized >= so_.divergedIterates && farOff < so_.divergedIterates)
      divergedHow = "needed Hessian regularizations of " + formatNumber("%.2g", regularization) +
                    " and more at dual infeasibilities above " +
                    formatNumber("%.2g", so_.regularizedDualInfeasibility);
    // The best nearly feasible iterate, the other candidate at the phase end
    // (a limit may stop Ipopt anywhere).
    if (it.constraintViolation <= 1e-3 * minLoad_ && it.objective < bestIterate.first) {
      bestIterate.first = it.objective;
      bestIterate.second.assign(x, x + nlp.numVariables());
    }
  };
  hooks.limits = [&] {
    if (ctx.interrupted()) return StopReason::Interrupted;
    if (ctx.timeUp()) return StopReason::TimeLimit;
    return StopReason::None;
  };
  hooks.stop = [&] {
    if (ctx.interrupted()) return StopReason::Interrupted;
    if (ctx.timeUp()) return StopReason::TimeLimit;
    if (nearlyConverged) return StopReason::NearlyConverged;
    if (diverging) return StopReason::Diverging;
    return StopReason::None;
  };
  Ipopt::SmartPtr<SandTnlp> tnlp = new SandTnlp(nlp, hooks);
  // Multipliers for `--ipopt warm_start_init_point=yes` (not the default: on
  // the paper Sheet it took more iterations than Ipopt's least-squares
  // estimate, see docs/optimization.md): the previous phase's constraint
  // multipliers (same constraints and scaling; the objective is rescaled by
  // f_s, so they scale by f_s(previous) / f_s(this phase)) and bound
  // multipliers on the central path of mu_init.
  {
    double mu = 0.1;
    o.GetNumericValue("mu_init", mu, "");
    std::vector<double> lambda = warmLambda_;
    for (double& l : lambda) l *= warmObjectiveScale_ / scaling_.objective;
    tnlp->setWarmMultipliers(std::move(lambda), mu);
  }
  o.SetIntegerValue("max_iter", task.remainingIterations);
  const Ipopt::ApplicationReturnStatus st = app_->OptimizeTNLP(Ipopt::GetRawPtr(tnlp));
  out.iterations = std::max(1, tnlp->iterations());
  out.evaluations = nlp.evaluations();
  out.evaluationSeconds = nlp.evaluationSeconds();

  // The phase's candidates, polished and compared by the driver: Ipopt's
  // final point, then the best nearly feasible iterate (when a limit cut
  // the phase, the final point is wherever the cut fell: on the Dino, 0.83
  // mm after polishing, where the best nearly feasible iterate was still at
  // the initial design's RMS). Ipopt's iterates keep within bounds relaxed
  // by bound_relax_factor (1e-8); only its final point is projected back
  // (honor_original_bounds): both are clamped to the bounds.
  std::vector<double> lowerBound(nlp.numVariables()), upperBound(nlp.numVariables());
  nlp.bounds(lowerBound.data(), upperBound.data());
  auto candidate = [&](std::vector<double> point) {
    for (std::size_t i = 0; i < point.size(); ++i) point[i] = std::clamp(point[i], lowerBound[i], upperBound[i]);
    out.candidates.push_back({nlp.controls(point.data()), nlp.states(point.data())});
  };
  finalCandidate_ = -1;
  // A diverged phase's final point lies by construction hundreds of loads
  // off equilibrium: polishing it by Newton (continuation from there) is
  // slow and never yields the better design; only the best nearly feasible
  // iterate is a candidate then.
  const bool diverged = tnlp->stopReason() == StopReason::Diverging;
  if (!diverged && tnlp->finalPoint().size() == static_cast<std::size_t>(nlp.numVariables())) {
    candidate(tnlp->finalPoint());
    finalCandidate_ = 0;
    if (tnlp->finalMultipliers().size() == static_cast<std::size_t>(nlp.numConstraints()))
      finalLambda_ = tnlp->finalMultipliers();
  }
  if (!bestIterate.second.empty()) candidate(bestIterate.second);

  const Ipopt::SolverReturn sr = tnlp->status();
  const StopReason why = tnlp->stopReason();
  if (why == StopReason::Diverging) {
    out.end = PhaseEnd::Diverged;
    out.message = divergedHow;
  } else if (why == StopReason::Interrupted) {
    out.end = PhaseEnd::Interrupted;
  } else if (why == StopReason::TimeLimit) {
    out.end = PhaseEnd::TimeLimit;
  } else if (sr == Ipopt::MAXITER_EXCEEDED) {
    out.end = PhaseEnd::IterationLimit;
  } else if (targetsMet) {
    out.end = PhaseEnd::TargetsMet;
  } else if (stalled && why == StopReason::NearlyConverged) {
    out.end = PhaseEnd::Stalled;
    std::ostringstream m;
    m << "no meaningful progress: over the last " << opt_.stallWindow
      << " iterations near equilibrium the objective fell by less than " << opt_.stallRelativeDecrease * 100.0
      << "%, or the RMS by less than " << kMeaningfulRmsPerIteration * opt_.stallWindow * 100.0
      << "% of the initial design's";
    out.message = m.str();
  } else if (sr == Ipopt::SUCCESS || sr == Ipopt::STOP_AT_ACCEPTABLE_POINT || why == StopReason::NearlyConverged) {
    out.end = PhaseEnd::Converged;
  } else {
    std::ostringstream m;
    m << "Ipopt, " << phaseName(phase) << " at level " << phase.level << ": "
      << (sr == Ipopt::UNASSIGNED ? applicationStatusName(st) : solverReturnName(sr));
    out.end = PhaseEnd::Failed;
    out.failure = sr == Ipopt::STOP_AT_TINY_STEP ? Outcome::Stalled : Outcome::NumericalFailure;
    out.message = m.str();
  }
  return out;
}

}  // namespace

std::string SandOptions::isValid() const {
  if (!(divergedLoads > 0) || !std::isfinite(divergedLoads)) return "SAND: the divergence threshold (loads) must be positive";
  if (divergedIterates < 1) return "SAND: the divergence window must be at least 1 iterate";
  if (wanderingIterates < 1) return "SAND: the window of iterates off equilibrium must be at least 1 iterate";
  if (!(divergedDualInfeasibility > 0)) return "SAND: the divergence threshold (dual infeasibility) must be positive";
  if (!(divergedRegularization > 0) || !(regularizedDualInfeasibility > 0))
    return "SAND: the divergence thresholds (regularization, dual infeasibility) must be positive";
  if (!(retryThetaMaxFact > 0) || !std::isfinite(retryThetaMaxFact))
    return "SAND: theta_max_fact of a retried phase must be positive";
  if (!(handOverTolerance > 0 && handOverTolerance < 1)) return "SAND: the hand-over tolerance must lie in (0, 1)";
  if (warmupIterations < 0 || warmupWindow < 1 || !(warmupRelativeDecrease >= 0 && warmupRelativeDecrease < 1))
    return "SAND: the BFGS start needs iterations >= 0, a window >= 1 and a relative decrease in [0, 1)";
  for (const auto& [key, value] : ipopt)
    if (std::string why = checkIpoptOption(key, value); !why.empty()) return why;
  return optimizer.isValid();
}

DesignOptimizerResult optimizeSand(const SceneModel& model, const DesignSpace& space, const SandOptions& so,
                                   const DesignProgress& progress) {
  SandPhaseSolver solver(model, space, so);
  return runDesign(model, space, so.optimizer, solver, progress);
}

}  // namespace rodmesh
