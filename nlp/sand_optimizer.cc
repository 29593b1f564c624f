// The Ipopt side of SAND: a TNLP adapter over SandNlp and the schedule
// driver. This is the only translation unit that includes Ipopt.
#include "nlp/sand.hh"

#include "nlp/sand_nlp.hh"
#include "solver/design_monitor.hh"
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
#include <set>
#include <sstream>
#include <thread>

namespace rodmesh {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Relative tolerance of a phase that a finer phase continues (see the
// schedule loop in optimizeSand).
constexpr double kLevelTolerance = 1e-3;

using Ipopt::Index;
using Ipopt::Number;

// What stopped a phase from inside the iteration callback.
// NearlyConverged: the phase's own test, see the schedule loop.
// Diverging: the iterates left equilibrium by far more than any load (see
// kDivergedLoads), the phase is stopped and retried.
enum class StopReason { None, TimeLimit, Interrupted, NearlyConverged, Diverging };

// A phase is diverging when kDivergedIterates iterates in a row are off
// equilibrium by more than kDivergedLoads times the largest pose load (N), or
// an iterate's dual infeasibility exceeds kDivergedDualInfeasibility. Far
// from equilibrium the linearised constraints are poor (a step that moves
// part of a sheet out of plane by an edge length changes edge lengths at
// second order), the iterates rarely come back and the KKT factorizations
// grow slower; runs that do recover leave it for single iterations only
// (docs/optimization.md, "SAND phases that diverge", has the measurements).
constexpr double kDivergedLoads = 100.0;
constexpr int kDivergedIterates = 3;
constexpr double kDivergedDualInfeasibility = 1e10;
// The retry of a diverged phase keeps its iterates within this 1-norm of the
// scaled constraints (Ipopt's theta_max_fact, default 1e4): steps that leave
// equilibrium further are cut by the filter line search.
constexpr double kRetryThetaMaxFact = 1e-2;

class SandTnlp : public Ipopt::TNLP {
 public:
  struct Hooks {
    std::function<void(int iter, const double* x, double infDu, double alphaPr)> progress;
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

  bool intermediate_callback(Ipopt::AlgorithmMode, Index iter, Number, Number, Number infDu, Number, Number, Number,
                             Number, Number alphaPr, Index, const Ipopt::IpoptData*,
                             Ipopt::IpoptCalculatedQuantities*) override {
    iterations_ = iter;
    try {
      if (hooks_.progress && !current_.empty()) hooks_.progress(iter, current_.data(), infDu, alphaPr);
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

// Equilibria of a design from the given states (Newton, warm started with the
// states' charts; restarted from rest if that fails). False if a pose fails.
bool solvePoses(SceneModel& model, const Design& d, std::vector<PoseState>& states, const NewtonOptions& newton,
                int threads) {
  const int K = model.numPoses();
  std::vector<char> ok(K, 0);
  forEachPose(K, threads, [&](int k) {
    try {
      const NewtonReport r = solveEquilibrium(model.pose(k), d, states[k], newton);
      ok[k] = r.converged && states[k].loadFactor == 1.0;
    } catch (...) {
      ok[k] = 0;
    }
  });
  return std::all_of(ok.begin(), ok.end(), [](char c) { return c != 0; });
}

double sumSquared(SceneModel& model, const TargetObjective& objective, const Design& d,
                  const std::vector<PoseState>& states, double& f) {
  double ss = 0.0;
  f = 0.0;
  for (int k = 0; k < model.numPoses(); ++k) {
    double s = 0.0;
    model.pose(k).setState(states[k]);
    f += objective.pose(model.pose(k), states[k].u, d, nullptr, nullptr, &s);
    ss += s;
  }
  return ss;
}

}  // namespace

std::string checkIpoptOption(const std::string& key, const std::string& value) {
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  return setOption(*app, key, value);
}

DesignOptimizerResult optimizeSand(SceneModel& model, const DesignSpace& space, const SandOptions& so,
                                   const DesignProgress& progress) {
  const auto t0 = Clock::now();
  const DesignOptimizerOptions& opt = so.optimizer;
  const Scene& scene = model.scene();
  const TargetObjective objective(scene, model.effects());
  const int K = model.numPoses();
  DesignOptimizerResult res;
  res.controls = space.initialControls(scene);
  const Design d0 = space.toDesign(res.controls);
  auto finish = [&](Outcome o, const std::string& message) {
    res.status = {o, message};
    res.timeSeconds = since(t0);
    res.solverSeconds = std::max(0.0, res.timeSeconds - res.evaluationSeconds);
    res.peakMemoryBytes = peakResidentMemory();
    return res;
  };

  // Starting point: the equilibria of the initial design.
  std::vector<PoseState> states(K);
  for (int k = 0; k < K; ++k) states[k] = model.pose(k).restState(d0);
  {
    const auto te = Clock::now();
    const bool ok = solvePoses(model, d0, states, opt.newton, opt.threads);
    res.evaluationSeconds += since(te);
    if (!ok) {
      res.design = d0;
      // Newton solves stop at the run's limits too (NewtonOptions::cancel).
      if (opt.stopRequested && opt.stopRequested()) return finish(Outcome::Interrupted, "interrupted");
      if (opt.timeLimit > 0 && since(t0) >= opt.timeLimit) return finish(Outcome::TimeLimit, "time limit reached");
      return finish(Outcome::NumericalFailure,
                    "no equilibrium under the initial design: the poses cannot be solved as given");
    }
  }
  double f0 = 0.0;
  const double ss0 = sumSquared(model, objective, d0, states, f0);
  res.initialObjective = res.objective = f0;
  res.initialRms = res.rms = objective.rms(ss0);
  for (int k = 0; k < K; ++k) res.initialPositions.push_back(model.pose(k).positions(states[k].u, d0));
  res.design = d0;
  res.states = states;
  {
    DesignIterate it;
    it.phase = "initial";
    it.objective = f0;
    it.rms = res.rms;
    it.elapsed = since(t0);
    it.evaluations = 1;
    res.history.push_back(it);
    if (progress) progress(it);
  }
  if (!(f0 > 0)) return finish(Outcome::Converged, "the initial design meets every target");
  // Ipopt's iterates are designs, but not equilibria: the monitor re-solves
  // them on a second thread, so that a design that re-solves from rest is at
  // hand at every moment (solver/design_monitor.hh).
  std::unique_ptr<DesignMonitor> monitor;
  if (opt.confirmDesigns)
    monitor = std::make_unique<DesignMonitor>(scene, space, opt.newton, states, f0, t0, opt.onConfirmed);

  // Scaling: objective relative to the initial design's, constraints
  // relative to each pose's load (newtons).
  SandScaling scaling;
  scaling.objective = f0;
  double minLoad = std::numeric_limits<double>::infinity(), maxLoad = 0.0;
  const std::vector<double> loads = sandLoadScales(model, d0, states);  // nlp/sand_nlp.hh
  for (int k = 0; k < K; ++k) {
    const double L = loads[k];
    scaling.load.push_back(std::isfinite(L) && L > 0 ? L : 1.0);
    minLoad = std::min(minLoad, scaling.load.back());
    maxLoad = std::max(maxLoad, scaling.load.back());
  }

  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  Ipopt::OptionsList& o = *app->Options();
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
  // MUMPS's workspace at twice its estimate instead of Ipopt's 1000 %: the
  // larger workspace is mapped and zero-filled again at every factorization.
  o.SetIntegerValue("mumps_mem_percent", 100);
  o.SetStringValue("hessian_approximation", "exact");
  o.SetStringValue("mu_strategy", "adaptive");  // not monotone: docs/optimization.md
  o.SetNumericValue("tol", opt.tolerance);
  o.SetNumericValue("dual_inf_tol", opt.tolerance);
  o.SetNumericValue("constr_viol_tol", std::max(1e-12, 10.0 * opt.newton.tolerance));
  o.SetNumericValue("acceptable_tol", std::min(1e-2, 1e3 * opt.tolerance));
  o.SetNumericValue("acceptable_constr_viol_tol", 1e-6);
  // User options before Initialize (journals such as output_file are opened
  // there) and again after it, so that they override ./ipopt.opt.
  for (const auto& [key, value] : so.ipopt)
    if (std::string why = setOption(*app, key, value); !why.empty()) return finish(Outcome::InvalidProblem, why);
  const Ipopt::ApplicationReturnStatus init = so.readOptionsFile ? app->Initialize() : app->Initialize("");
  if (init != Ipopt::Solve_Succeeded)
    return finish(Outcome::InvalidProblem,
                  std::string("Ipopt could not be initialised (") + applicationStatusName(init) +
                      (ipoptOptionsFilePresent() ? "; check ./ipopt.opt)" : ")"));
  for (const auto& [key, value] : so.ipopt)
    if (std::string why = setOption(*app, key, value); !why.empty()) return finish(Outcome::InvalidProblem, why);

  // Options set by the user (--ipopt, or ./ipopt.opt: a value other than
  // ours) are left alone by the per-phase settings below.
  std::set<std::string> userSet;
  for (const auto& kv : so.ipopt) userSet.insert(kv.first);
  {
    std::string strategy;
    double value = 0.0;
    if (o.GetStringValue("mu_strategy", strategy, "") && strategy != "adaptive") userSet.insert("mu_strategy");
    if (o.GetNumericValue("tol", value, "") && value != opt.tolerance) userSet.insert("tol");
    if (o.GetNumericValue("dual_inf_tol", value, "") && value != opt.tolerance) userSet.insert("dual_inf_tol");
    if (o.GetNumericValue("mu_init", value, "")) userSet.insert("mu_init");
    if (o.GetNumericValue("theta_max_fact", value, "")) userSet.insert("theta_max_fact");
    Ipopt::Index trigger = 0;
    if (o.GetIntegerValue("watchdog_shortened_iter_trigger", trigger, ""))
      userSet.insert("watchdog_shortened_iter_trigger");
  }
  const std::vector<DesignStep> steps = designSchedule(scene, space, opt);
  Outcome stop = Outcome::Converged;
  std::string message = "schedule completed";
  int iterations = 0;
  double roundStart = res.objective;
  int roundStartIteration = 0;
  std::vector<PoseState> rawStates = states;  // Ipopt's own equilibria of the kept design
  std::vector<double> warmLambda;             // the kept phase's constraint multipliers
  double warmObjectiveScale = 1.0;            // and its objective scale f_s
  DesignFallbacks fallbacks;                  // the kept phase designs (solver/design_fallback.hh)

  // Attempts of the current phase after a divergence: the retry holds the
  // iterates near equilibrium (theta_max_fact) and turns Ipopt's watchdog
  // off, which would accept a full step after repeated short ones and so
  // leave equilibrium again.
  int retry = 0;
  for (std::size_t ph = 0; ph < steps.size(); ++ph) {
    const DesignPhase& phase = steps[ph].phase;
    if (!userSet.count("theta_max_fact")) o.SetNumericValue("theta_max_fact", retry > 0 ? kRetryThetaMaxFact : 1e4);
    if (!userSet.count("watchdog_shortened_iter_trigger"))
      o.SetIntegerValue("watchdog_shortened_iter_trigger", retry > 0 ? 0 : 10);
    const int round = steps[ph].round;
    if (round > 0 && phase.restShape) {
      roundStart = res.objective;
      roundStartIteration = iterations;
    }
    const int remaining = opt.maxIterations - iterations;
    if (remaining <= 0) {
      stop = Outcome::MaxIterations;
      message = "iteration limit reached";
      break;
    }
    if (opt.timeLimit > 0 && since(t0) >= opt.timeLimit) {
      stop = Outcome::TimeLimit;
      message = "time limit reached";
      break;
    }
    if (space.numFree(phase) == 0) continue;
    // Charts at the current equilibria: edges keep far from their chart's
    // singular direction while Ipopt moves them.
    for (int k = 0; k < K; ++k) {
      PoseSystem& sys = model.pose(k);
      sys.setState(states[k]);
      sys.reanchorCharts(states[k].u, res.design, 0.5);
      states[k].charts = sys.charts();
    }
    scaling.variable = designVariableScale(space, phase, scene);
    {
      // Radii are scaled by their own current value (within the bounds), so
      // that thin and thick rods (up to the bounds' ratio) take comparable
      // relative steps.
      Eigen::VectorXd lo, hi;
      space.bounds(phase, lo, hi);
      const Eigen::VectorXd z = space.pack(phase, res.controls);
      for (int i = 0; i < z.size(); ++i)
        if (std::isfinite(lo[i]) && std::isfinite(hi[i]) && lo[i] > 0)
          scaling.variable[i] = std::clamp(z[i], lo[i], hi[i]);
    }
    // Objective relative to the phase's start (its scaled value starts at 1,
    // so the barrier parameter means the same in every phase); later phases
    // start at a converged design, so the barrier starts small instead of
    // pushing every design value away from its bounds first.
    scaling.objective = std::max(res.objective, 1e-300);
    if (ph > 0 && !userSet.count("mu_init")) o.SetNumericValue("mu_init", 1e-4);
    // Later phases start at a converged design with a small barrier
    // parameter: Fiacco-McCormick's monotone decrease then takes 30-50% fewer
    // iterations than the adaptive rule, which keeps re-raising mu (the
    // four-pose hat: 32 + 33 against 66 + 66 iterations for radius levels 1
    // and 2, docs/optimization.md). The first phase starts far from any
    // optimum and keeps the adaptive rule (with the monotone one the
    // design-at-its-bounds hard case found no better design in 150
    // iterations).
    if (!userSet.count("mu_strategy")) o.SetStringValue("mu_strategy", ph > 0 ? "monotone" : "adaptive");
    // A phase that the schedule continues before any alternation (the
    // radius levels, unless the last phase) only has to hand a good start to
    // the next: relative tolerance 1e-3 (or --tol if looser). The last
    // phase and the phases of the paper's alternation keep --tol.
    const bool handsOver = ph + 1 < steps.size() && round == 0;
    const double phaseTolerance = handsOver ? std::max(opt.tolerance, kLevelTolerance) : opt.tolerance;
    if (!userSet.count("tol")) o.SetNumericValue("tol", phaseTolerance);
    if (!userSet.count("dual_inf_tol")) o.SetNumericValue("dual_inf_tol", phaseTolerance);
    SandNlp nlp(model, space, objective, phase, res.controls, states, scaling, opt.threads);
    const int base = iterations;
    std::pair<double, std::vector<double>> bestIterate{std::numeric_limits<double>::infinity(), {}};
    bool nearlyConverged = false, targetsMet = false, stalled = false, diverging = false;
    int farOff = 0;  // iterates in a row more than kDivergedLoads off equilibrium
    // Progress of the settled iterates (within 1e-5 of the load of
    // equilibrium: Newton's polish makes them equilibria); the phase starts
    // at an equilibrium.
    StallDetector stall(opt.stallWindow, opt.stallRelativeDecrease, res.initialObjective);
    stall.add(res.objective, true);
    SandTnlp::Hooks hooks;
    hooks.progress = [&](int iter, const double* x, double infDu, double alphaPr) {
      if (iter == 0 && base > 0) return;  // a phase starts where the previous one ended
      DesignIterate it;
      it.iteration = base + iter;
      it.level = phase.level;
      it.phase = phaseName(phase);
      double f = 0.0;
      nlp.objective(x, f);
      it.objective = f * scaling.objective;
      it.rms = nlp.rms(x);
      it.constraintViolation = nlp.forceViolation(x);
      it.dualInfeasibility = infDu;
      it.gradientNorm = infDu;
      it.step = alphaPr;
      it.elapsed = since(t0);
      it.evaluations = nlp.evaluations();
      if (monitor) {
        monitor->offer(nlp.controls(x), it.iteration,
                       "the design of " + describeStep(steps[ph]) + ", iteration " + std::to_string(it.iteration));
        monitor->bestSummary(it.confirmedRms, it.confirmedIteration);
      }
      res.history.push_back(it);
      if (progress) progress(it);
      // The phase ends when the iterate is stationary within the phase's
      // tolerance and within 1e-5 of the smallest load of equilibrium:
      // Newton's polish at the phase end makes it an equilibrium. Ipopt's own
      // test also wants the violation below constr_viol_tol (1e-8 of the
      // load), which it may never reach when the targets are met exactly (the
      // objective flat in many design directions, steps along them leave
      // equilibrium by 1e-7 to 1e-1 of the load: a 343-vertex sheet at --tol
      // 1e-2 ran 160 iterations at such a point, then diverged to 6.6e5 N).
      const bool settled = it.constraintViolation <= 1e-5 * minLoad;
      nearlyConverged = iter > 0 && std::isfinite(infDu) && infDu <= phaseTolerance && settled;
      // Also when the targets are met to round-off (Ipopt's dual
      // infeasibility need not fall at such a point: the objective's scale
      // is gone, what is left is the equilibria's own round-off), and when
      // the settled iterates stopped improving (StallDetector).
      stall.add(settled ? it.objective : std::numeric_limits<double>::infinity(),
                it.constraintViolation <= 1e-3 * minLoad);
      targetsMet = iter > 0 && settled && it.objective <= kTargetsMetRatio * res.initialObjective;
      stalled = iter > 0 && stall.stalled();
      nearlyConverged = nearlyConverged || targetsMet || stalled;
      farOff = it.constraintViolation > kDivergedLoads * maxLoad ? farOff + 1 : 0;
      diverging = farOff >= kDivergedIterates || !(infDu <= kDivergedDualInfeasibility);
      // The best nearly feasible iterate, the other candidate at the phase
      // end (a limit may stop Ipopt anywhere).
      if (it.constraintViolation <= 1e-3 * minLoad && it.objective < bestIterate.first) {
        bestIterate.first = it.objective;
        bestIterate.second.assign(x, x + nlp.numVariables());
      }
    };
    hooks.limits = [&] {
      if (opt.stopRequested && opt.stopRequested()) return StopReason::Interrupted;
      if (opt.timeLimit > 0 && since(t0) >= opt.timeLimit) return StopReason::TimeLimit;
      return StopReason::None;
    };
    hooks.stop = [&] {
      if (opt.stopRequested && opt.stopRequested()) return StopReason::Interrupted;
      if (opt.timeLimit > 0 && since(t0) >= opt.timeLimit) return StopReason::TimeLimit;
      if (nearlyConverged) return StopReason::NearlyConverged;
      if (diverging) return StopReason::Diverging;
      return StopReason::None;
    };
    Ipopt::SmartPtr<SandTnlp> tnlp = new SandTnlp(nlp, hooks);
    // Multipliers for `--ipopt warm_start_init_point=yes` (not the default:
    // on the paper Sheet it took more iterations than Ipopt's least-squares
    // estimate, see docs/optimization.md): the previous phase's constraint
    // multipliers (same constraints and scaling; the objective is rescaled
    // by f_s, so they scale by f_s(previous) / f_s(this phase)) and bound
    // multipliers on the central path of mu_init.
    {
      double mu = 0.1;
      o.GetNumericValue("mu_init", mu, "");
      std::vector<double> lambda = warmLambda;
      for (double& l : lambda) l *= warmObjectiveScale / scaling.objective;
      tnlp->setWarmMultipliers(std::move(lambda), mu);
    }
    o.SetIntegerValue("max_iter", remaining);
    const Ipopt::ApplicationReturnStatus st = app->OptimizeTNLP(Ipopt::GetRawPtr(tnlp));
    iterations += std::max(1, tnlp->iterations());
    res.evaluations += nlp.evaluations();
    res.evaluationSeconds += nlp.evaluationSeconds();

    // Keep the phase's design if its equilibria exist (Newton from Ipopt's
    // positions) and the objective did not rise. Both candidates, Ipopt's
    // final point and the best nearly feasible iterate, are polished and the
    // better one is kept: when a limit cut the phase, the final point is
    // wherever the cut fell (on the Dino, 0.83 mm after polishing, where the
    // best nearly feasible iterate was still at the initial design's RMS).
    bool kept = false;
    std::vector<const std::vector<double>*> candidates;
    const bool haveFinal = tnlp->finalPoint().size() == static_cast<std::size_t>(nlp.numVariables());
    if (haveFinal) candidates.push_back(&tnlp->finalPoint());
    if (!bestIterate.second.empty()) candidates.push_back(&bestIterate.second);
    warmLambda.clear();
    // Ipopt's iterates keep within bounds relaxed by bound_relax_factor
    // (1e-8); only its final point is projected back (honor_original_bounds).
    std::vector<double> lowerBound(nlp.numVariables()), upperBound(nlp.numVariables());
    nlp.bounds(lowerBound.data(), upperBound.data());
    for (std::size_t c = 0; c < candidates.size(); ++c) {
      std::vector<double> point = *candidates[c];
      for (std::size_t i = 0; i < point.size(); ++i) point[i] = std::clamp(point[i], lowerBound[i], upperBound[i]);
      const bool isFinal = haveFinal && candidates[c] == &tnlp->finalPoint();
      const double* x = point.data();
      const ControlValues cand = nlp.controls(x);
      const Design d = space.toDesign(cand);
      const std::vector<PoseState> raw = nlp.states(x);
      std::vector<PoseState> polished = raw;
      const auto te = Clock::now();
      const bool ok = solvePoses(model, d, polished, opt.newton, opt.threads);
      res.evaluationSeconds += since(te);
      if (ok) {
        double f = 0.0;
        const double ss = sumSquared(model, objective, d, polished, f);
        if (std::isfinite(f) && (kept ? f < res.objective : f <= res.objective)) {
          res.controls = cand;
          res.design = d;
          res.objective = f;
          res.rms = objective.rms(ss);
          states = polished;
          rawStates = raw;
          kept = true;
          fallbacks.add(cand, f, res.rms,
                        "the design kept at the end of " + describeStep(steps[ph]) + " (iteration " +
                            std::to_string(iterations) + ")");
          // Multipliers for the next phase: Ipopt's final ones, if that is
          // the point kept.
          warmLambda.clear();
          if (isFinal && tnlp->finalMultipliers().size() == static_cast<std::size_t>(nlp.numConstraints())) {
            warmLambda = tnlp->finalMultipliers();
            warmObjectiveScale = scaling.objective;
          }
        }
      }
    }
    const Ipopt::SolverReturn sr = tnlp->status();
    const bool nearlySolved = tnlp->stopReason() == StopReason::NearlyConverged;
    if (tnlp->stopReason() == StopReason::Diverging) {
      // Far from equilibrium Ipopt's linearisations are poor and its
      // iterates rarely come back (each factorization slower than the last):
      // run the phase again from the design kept so far, with the iterates
      // held near equilibrium (see `retry`). A second divergence ends the run.
      if (retry < 1) {
        ++retry;
        --ph;
        continue;
      }
      stop = Outcome::Stalled;
      message = "Ipopt's iterates left equilibrium by more than " + std::to_string(static_cast<int>(kDivergedLoads)) +
                " times the largest load in " + describeStep(steps[ph]) +
                ", also when held near equilibrium; the best design so far is the result";
      break;
    }
    retry = 0;
    if (tnlp->stopReason() != StopReason::None && !nearlySolved) {
      stop = tnlp->stopReason() == StopReason::Interrupted ? Outcome::Interrupted : Outcome::TimeLimit;
      message = stop == Outcome::Interrupted ? "interrupted" : "time limit reached";
      break;
    }
    const bool solved = sr == Ipopt::SUCCESS || sr == Ipopt::STOP_AT_ACCEPTABLE_POINT || nearlySolved;
    if (sr == Ipopt::MAXITER_EXCEEDED) {
      stop = Outcome::MaxIterations;
      message = "iteration limit reached";
      break;
    }
    if (!solved) {
      std::ostringstream m;
      m << "Ipopt, " << phaseName(phase) << " at level " << phase.level << ": "
        << (sr == Ipopt::UNASSIGNED ? applicationStatusName(st) : solverReturnName(sr))
        << (kept ? "" : "; the phase's design was not kept");
      stop = sr == Ipopt::STOP_AT_TINY_STEP ? Outcome::Stalled : Outcome::NumericalFailure;
      message = m.str();
      // A failed phase with a usable best design so far is not a failed run.
      if (stop == Outcome::NumericalFailure && res.objective < res.initialObjective) stop = Outcome::Stalled;
      break;
    }
    // A solved phase that found nothing better leaves the best design as it
    // was; the schedule goes on.
    if (targetsMet || res.objective <= kTargetsMetRatio * res.initialObjective) {
      message = "every target met to round-off";
      break;
    }
    if (stalled && ph + 1 == steps.size()) {
      std::ostringstream m;
      m << "no meaningful progress: over the last " << opt.stallWindow
        << " iterations near equilibrium the objective fell by less than " << opt.stallRelativeDecrease * 100.0
        << "%, or the RMS by less than " << kMeaningfulRmsPerIteration * opt.stallWindow * 100.0
        << "% of the initial design's";
      message = m.str();
    }
    // The rounds end when one (rest shape, then radii) lowers the objective
    // by less than roundRelativeDecrease.
    if (round > 0 && phase.radii) {
      const double gain = (roundStart - res.objective) / std::max(roundStart, 1e-300);
      if (gain < opt.roundRelativeDecrease ||
          !meaningfulGain(roundStart, res.objective, res.initialObjective, iterations - roundStartIteration)) {
        std::ostringstream m;
        m << "a rest-shape/radii round lowered the objective by less than " << opt.roundRelativeDecrease * 100.0
          << "%, or the RMS by less than " << kMeaningfulRmsPerIteration * 100.0
          << "% of the initial design's per iteration";
        message = m.str();
        break;
      }
    }
  }
  if (monitor) {
    monitor->stop();
    if (adoptConfirmed(*monitor, stop, res, rawStates, fallbacks)) {
      message += "; the best design confirmed during the run (iteration " + std::to_string(monitor->best()->iteration) +
                 ") is better than the last phase's and is the result";
    }
  }
  res.iterations = iterations;
  res.states = rawStates;
  res.fallbacks = fallbacks.designs();
  return finish(stop, message);
}

}  // namespace rodmesh
