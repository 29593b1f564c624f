#include "solver/bfgs.hh"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <utility>

#include "solver/format.hh"

namespace rodmesh {
namespace {

using Clock = std::chrono::steady_clock;
using Eigen::VectorXd;

constexpr double kInf = std::numeric_limits<double>::infinity();
// A BFGS direction d is used only if -Pg'd >= kMinDescentCosine |Pg| |d|.
constexpr double kMinDescentCosine = 1e-8;
// A curvature pair is used only if y's > kMinCurvatureCosine |s| |y|.
constexpr double kMinCurvatureCosine = 1e-10;
// Bounds on the factor of a rejected (but evaluated) line-search probe.
constexpr double kMinBacktrack = 0.1, kMaxBacktrack = 0.5;

double infNorm(const VectorXd& v) { return v.size() ? v.lpNorm<Eigen::Infinity>() : 0.0; }

enum class Eval { Ok, Failed, Stop };
enum class Search { Accepted, Failed, Stop };

// One minimisation: the problem, counters and the best point, shared by the
// main loop and the line search.
class BfgsRun {
 public:
  BfgsRun(const BfgsObjective& objective, const VectorXd& lower, const VectorXd& upper, const BfgsOptions& options,
          const BfgsCallbacks& callbacks, BfgsResult& result)
      : objective_(objective),
        lower_(lower),
        upper_(upper),
        opt_(options),
        cb_(callbacks),
        res_(result),
        t0_(Clock::now()) {}

  double elapsed() const { return std::chrono::duration<double>(Clock::now() - t0_).count(); }
  const Status& stopStatus() const { return stop_; }

  VectorXd project(const VectorXd& x) const { return x.cwiseMax(lower_).cwiseMin(upper_); }

  // The gradient with the components of held variables (at a bound, gradient
  // pointing outward) set to zero.
  bool held(const VectorXd& x, const VectorXd& g, Eigen::Index i) const {
    return (x[i] <= lower_[i] && g[i] > 0) || (x[i] >= upper_[i] && g[i] < 0);
  }
  VectorXd projectedGradient(const VectorXd& x, const VectorXd& g) const {
    VectorXd pg = g;
    for (Eigen::Index i = 0; i < x.size(); ++i)
      if (held(x, g, i)) pg[i] = 0;
    return pg;
  }

  // Drops the components of d that would move a variable at a bound outward.
  void dropBlocked(const VectorXd& x, VectorXd& d) const {
    for (Eigen::Index i = 0; i < x.size(); ++i)
      if ((x[i] <= lower_[i] && d[i] < 0) || (x[i] >= upper_[i] && d[i] > 0)) d[i] = 0;
  }

  // Polls the stop request and the time limit, then calls the objective. A
  // non-finite value or gradient counts as a failed evaluation.
  Eval evaluate(const VectorXd& x, double& f, VectorXd* g) {
    if (cb_.stopRequested && cb_.stopRequested()) {
      stop_ = {Outcome::Interrupted, "stop requested"};
      return Eval::Stop;
    }
    if (opt_.timeLimit > 0 && elapsed() >= opt_.timeLimit) {
      stop_ = {Outcome::TimeLimit, formatMessage("time limit of %g s reached", opt_.timeLimit)};
      return Eval::Stop;
    }
    ++res_.evaluations;
    if (g) ++res_.gradientEvaluations;
    double value = kInf;
    bool ok = objective_(x, value, g);
    ok = ok && std::isfinite(value) && (!g || (g->size() == x.size() && g->allFinite()));
    if (!ok) {
      ++res_.failedEvaluations;
      return Eval::Failed;
    }
    f = value;
    if (f < res_.f) {
      res_.f = f;
      res_.x = x;
    }
    return Eval::Ok;
  }

  struct SearchInfo {
    bool backtracked = false;  // the accepted step is shorter than the first trial
    double lastLength = 0;     // |step|_inf of the last trial
    int failed = 0;            // failed evaluations in this search
  };

  // Armijo backtracking along x(a) = P(x + a d), a = 1, ... On success, xNew,
  // fNew and gNew hold the accepted point, its value and its gradient.
  Search lineSearch(const VectorXd& x, double f, const VectorXd& g, const VectorXd& d, VectorXd& xNew, double& fNew,
                    VectorXd& gNew, SearchInfo& info) {
    double a = 1;
    VectorXd gTrial;
    for (int k = 0; k <= opt_.maxBacktracks; ++k) {
      const VectorXd xTrial = project(x + a * d);
      const VectorXd s = xTrial - x;
      info.lastLength = infNorm(s);
      if (info.lastLength < opt_.minStep) return Search::Failed;
      info.backtracked = k > 0;
      const double slope = g.dot(s);  // first-order change along the projected step
      if (!(slope < 0)) {             // the projection folded the step uphill: shorten without evaluating
        a *= kMaxBacktrack;
        continue;
      }
      const double target = f + opt_.armijo * slope;
      double fTrial = kInf;
      Eval e = evaluate(xTrial, fTrial, nullptr);
      if (e == Eval::Stop) return Search::Stop;
      if (e == Eval::Ok && fTrial <= target) {
        // Sufficient decrease: fetch the gradient. The objective is expected to
        // reproduce the value; if it fails or no longer decreases, keep searching.
        e = evaluate(xTrial, fTrial, &gTrial);
        if (e == Eval::Stop) return Search::Stop;
        if (e == Eval::Ok && fTrial <= target) {
          xNew = xTrial;
          fNew = fTrial;
          gNew = gTrial;
          return Search::Accepted;
        }
      }
      if (e == Eval::Failed) {
        ++info.failed;
        a *= opt_.stepShrink;
        continue;
      }
      // Minimiser of the quadratic through f, the slope and fTrial, on [0, 1] along s.
      const double curvature = fTrial - f - slope;
      const double t = curvature > 0 ? -slope / (2 * curvature) : kMaxBacktrack;
      a *= std::clamp(t, kMinBacktrack, kMaxBacktrack);
    }
    return Search::Failed;
  }

 private:
  const BfgsObjective& objective_;
  const VectorXd& lower_;
  const VectorXd& upper_;
  const BfgsOptions& opt_;
  const BfgsCallbacks& cb_;
  BfgsResult& res_;
  Clock::time_point t0_;
  Status stop_;
};

}  // namespace

std::string BfgsOptions::isValid() const {
  if (maxIterations < 1) return "maxIterations must be at least 1";
  if (!(timeLimit >= 0 && std::isfinite(timeLimit))) return "timeLimit must be finite and non-negative (0 = none)";
  if (!(gradientTolerance >= 0 && gradientTolerance < 1)) return "gradientTolerance must lie in [0, 1)";
  if (!(gradientScale >= 0 && std::isfinite(gradientScale)))
    return "gradientScale must be finite and non-negative (0 = initial projected gradient)";
  if (!(relativeDecrease >= 0 && relativeDecrease < 1)) return "relativeDecrease must lie in [0, 1)";
  if (stallWindow < 1) return "stallWindow must be at least 1";
  if (!(minStep > 0 && std::isfinite(minStep))) return "minStep must be positive and finite";
  if (!(initialMaxStep >= minStep && std::isfinite(initialMaxStep)))
    return "initialMaxStep must be finite and at least minStep";
  if (!(maxStepLimit >= initialMaxStep)) return "maxStepLimit must be at least initialMaxStep";
  if (!(stepGrowth >= 1 && std::isfinite(stepGrowth))) return "stepGrowth must be finite and at least 1";
  if (!(stepShrink > 0 && stepShrink < 1)) return "stepShrink must lie in (0, 1)";
  if (!(armijo > 0 && armijo < 0.5)) return "armijo must lie in (0, 0.5)";
  if (maxBacktracks < 1) return "maxBacktracks must be at least 1";
  if (denseLimit < 0) return "denseLimit must be non-negative";
  if (memory < 1) return "memory must be at least 1";
  return "";
}

BfgsResult minimizeBfgs(const BfgsObjective& objective, VectorXd x0, const VectorXd& lower, const VectorXd& upper,
                        const BfgsOptions& opt, const BfgsCallbacks& cb) {
  BfgsResult res;
  res.x = x0;
  double maxStep = opt.initialMaxStep;  // the adaptive cap on |step|_inf
  auto finish = [&](const Status& status, const BfgsRun* run) {
    res.status = status;
    res.maxStep = maxStep;
    if (run) res.timeSeconds = run->elapsed();
    return res;
  };

  // Problem checks.
  const std::string invalid = opt.isValid();
  if (!invalid.empty()) return finish({Outcome::InvalidProblem, "invalid BFGS options: " + invalid}, nullptr);
  const Eigen::Index n = x0.size();
  if (lower.size() != n || upper.size() != n)
    return finish({Outcome::InvalidProblem, "bounds and x0 differ in size"}, nullptr);
  if (!x0.allFinite()) return finish({Outcome::InvalidProblem, "x0 is not finite"}, nullptr);
  for (Eigen::Index i = 0; i < n; ++i)
    if (std::isnan(lower[i]) || std::isnan(upper[i]) || !(lower[i] <= upper[i]) || lower[i] == kInf ||
        upper[i] == -kInf)
      return finish({Outcome::InvalidProblem, "empty or undefined bounds for variable " + std::to_string(i)}, nullptr);

  BfgsRun run(objective, lower, upper, opt, cb, res);
  VectorXd x = run.project(x0);
  res.x = x;

  // Initial point.
  double f = kInf;
  VectorXd g;
  const Eval e0 = run.evaluate(x, f, &g);
  if (e0 == Eval::Stop) return finish(run.stopStatus(), &run);
  if (e0 == Eval::Failed) return finish({Outcome::NumericalFailure, "the initial point could not be evaluated"}, &run);
  VectorXd pg = run.projectedGradient(x, g);
  double pgNorm = infNorm(pg);
  res.projectedGradientNorm = pgNorm;
  const double gradientScale = opt.gradientScale > 0 ? opt.gradientScale : pgNorm;
  const double gradientThreshold = opt.gradientTolerance * gradientScale;

  auto record = [&](int iteration, double step, bool steepest) {
    BfgsIterate it;
    it.iteration = iteration;
    it.f = f;
    it.projectedGradientNorm = pgNorm;
    it.step = step;
    it.maxStep = maxStep;
    it.steepest = steepest;
    it.elapsed = run.elapsed();
    it.evaluations = res.evaluations;
    res.history.push_back(it);
    if (cb.progress) cb.progress(it);
  };
  auto gradientConverged = [&]() -> bool {
    if (pgNorm > gradientThreshold) return false;
    res.status = {Outcome::Converged,
                  formatMessage("projected gradient below tolerance: |Pg|_inf = %.3g <= %.3g * %.3g", pgNorm,
                                opt.gradientTolerance, gradientScale)};
    return true;
  };
  record(0, 0, false);
  if (gradientConverged()) return finish(res.status, &run);

  Eigen::MatrixXd H;       // inverse-Hessian approximation, allocated with the first curvature pair
  bool curvature = false;  // H holds curvature information; otherwise the direction is steepest descent
  // Limited memory (n > denseLimit): the curvature pairs instead of H.
  const bool limited = n > opt.denseLimit;
  std::deque<VectorXd> pairS, pairY;
  std::deque<double> pairRho;
  auto inverseHessianTimes = [&](const VectorXd& v) -> VectorXd {
    if (!limited) return H * v;
    // Two-loop recursion, H0 = (s'y / y'y) I from the newest pair.
    const int m = static_cast<int>(pairS.size());
    std::vector<double> alpha(m);
    VectorXd q = v;
    for (int i = m - 1; i >= 0; --i) {
      alpha[i] = pairRho[i] * pairS[i].dot(q);
      q -= alpha[i] * pairY[i];
    }
    q *= 1 / (pairRho.back() * pairY.back().squaredNorm());  // s'y / y'y
    for (int i = 0; i < m; ++i) q += (alpha[i] - pairRho[i] * pairY[i].dot(q)) * pairS[i];
    return q;
  };
  std::vector<double> accepted{f};
  VectorXd xNew, gNew, d;
  double fNew = kInf;

  // Steepest descent, scaled so that |d|_inf = maxStep (the gradient's length
  // carries no information about a good step without curvature).
  auto steepestDirection = [&]() -> VectorXd { return -pg * (maxStep / pgNorm); };

  for (int iteration = 1; iteration <= opt.maxIterations; ++iteration) {
    bool steepest = !curvature;
    bool fellBack = false;
    if (steepest) {
      d = steepestDirection();
    } else {
      d = -inverseHessianTimes(pg);
      for (Eigen::Index i = 0; i < n; ++i)
        if (run.held(x, g, i)) d[i] = 0;  // d = -H_FF Pg_F on the free variables
      run.dropBlocked(x, d);
      const double slope = pg.dot(d);
      if (!(d.allFinite() && slope < 0 && -slope >= kMinDescentCosine * pg.norm() * d.norm())) {
        fellBack = true;
      } else {
        const double length = infNorm(d);
        if (length > maxStep) d *= maxStep / length;
      }
    }

    BfgsRun::SearchInfo info;
    Search search = Search::Failed;
    if (!fellBack) search = run.lineSearch(x, f, g, d, xNew, fNew, gNew, info);
    if (search == Search::Stop) return finish(run.stopStatus(), &run);
    if (search == Search::Failed && !steepest) {
      // The BFGS direction failed: forget the curvature and retry along steepest descent.
      ++res.fallbacks;
      curvature = false;
      if (!fellBack) maxStep = std::max(opt.minStep, opt.stepShrink * maxStep);
      steepest = true;
      d = steepestDirection();
      info = BfgsRun::SearchInfo();
      search = run.lineSearch(x, f, g, d, xNew, fNew, gNew, info);
      if (search == Search::Stop) return finish(run.stopStatus(), &run);
    }
    if (search == Search::Failed) {
      maxStep = std::max(opt.minStep, opt.stepShrink * maxStep);
      std::string message =
          formatMessage("line search failed along steepest descent: no sufficient decrease down to |step|_inf = %.3g",
                        info.lastLength);
      if (info.failed) message += " (" + std::to_string(info.failed) + " failed evaluations)";
      message += formatMessage("; |Pg|_inf = %.3g, %.3g of the gradient scale", pgNorm, pgNorm / gradientScale);
      return finish({Outcome::Stalled, message}, &run);
    }

    // Accepted.
    const VectorXd s = xNew - x;
    const VectorXd y = gNew - g;
    const double stepLength = infNorm(s);
    const double cap = maxStep;
    if (info.backtracked || info.failed)
      maxStep = std::max(opt.minStep, std::min(maxStep, stepLength));
    else if (infNorm(d) >= cap * (1 - 1e-12))  // the full step was limited by the cap
      maxStep = std::min(opt.maxStepLimit, opt.stepGrowth * maxStep);

    const double sy = s.dot(y);
    if (sy > kMinCurvatureCosine * s.norm() * y.norm() && limited) {
      if (!curvature) pairS.clear(), pairY.clear(), pairRho.clear();  // forgotten after a failed direction
      pairS.push_back(s);
      pairY.push_back(y);
      pairRho.push_back(1 / sy);
      if (static_cast<int>(pairS.size()) > opt.memory) pairS.pop_front(), pairY.pop_front(), pairRho.pop_front();
      curvature = true;
    } else if (sy > kMinCurvatureCosine * s.norm() * y.norm()) {
      if (!curvature) H = Eigen::MatrixXd::Identity(n, n) * (sy / y.squaredNorm());
      // H+ = (I - rho s y') H (I - rho y s') + rho s s', rho = 1 / y's.
      const VectorXd Hy = H * y;
      const double rho = 1 / sy;
      H.noalias() += ((rho * rho * y.dot(Hy) + rho) * s) * s.transpose();
      H.noalias() -= (rho * Hy) * s.transpose();
      H.noalias() -= (rho * s) * Hy.transpose();
      curvature = true;
    } else {
      ++res.skippedUpdates;
    }

    x = std::move(xNew);
    f = fNew;
    g = std::move(gNew);
    pg = run.projectedGradient(x, g);
    pgNorm = infNorm(pg);
    res.projectedGradientNorm = pgNorm;
    res.iterations = iteration;
    if (steepest) ++res.steepestSteps;
    accepted.push_back(f);
    if (cb.accepted) cb.accepted(x);
    record(iteration, stepLength, steepest);

    if (gradientConverged()) return finish(res.status, &run);
    if (iteration >= opt.stallWindow) {
      const double fOld = accepted[iteration - opt.stallWindow];
      if (fOld - f <= opt.relativeDecrease * std::abs(fOld))
        return finish({Outcome::Converged, formatMessage("relative decrease below %.3g over %d iterations",
                                                         opt.relativeDecrease, opt.stallWindow)},
                      &run);
    }
  }
  return finish({Outcome::MaxIterations, "reached " + std::to_string(opt.maxIterations) + " iterations"}, &run);
}

}  // namespace rodmesh
