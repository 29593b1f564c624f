#include "solver/trust_region.hh"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <limits>

#include "solver/format.hh"

namespace rodmesh {
namespace {

using Eigen::VectorXd;
using Clock = std::chrono::steady_clock;
constexpr double kInf = std::numeric_limits<double>::infinity();

// Held for an iteration: at a bound with the gradient pointing outward.
bool heldAt(double x, double g, double lo, double hi) { return (x <= lo && g > 0) || (x >= hi && g < 0); }

// tau >= 0 with |s + tau p|_2 = radius (|s| <= radius).
double toRadius(const VectorXd& s, const VectorXd& p, double radius) {
  const double pp = p.squaredNorm(), sp = s.dot(p), ss = s.squaredNorm();
  if (pp == 0) return kInf;
  const double disc = std::max(0.0, sp * sp + pp * (radius * radius - ss));
  return std::max(0.0, (-sp + std::sqrt(disc)) / pp);
}

}  // namespace

std::string TrustRegionOptions::isValid() const {
  if (maxIterations < 0) return "maxIterations must be non-negative";
  if (!(timeLimit >= 0)) return "timeLimit must be non-negative";
  if (!(gradientTolerance >= 0) || !(gradientScale >= 0)) return "gradient tolerance and scale must be non-negative";
  if (!(relativeDecrease >= 0 && relativeDecrease < 1) || stallWindow < 1)
    return "relativeDecrease must lie in [0, 1) and stallWindow be at least 1";
  if (!(initialRadius > 0) || !(maxRadius >= initialRadius) || !(minRadius > 0 && minRadius < initialRadius))
    return "radii must satisfy 0 < minRadius < initialRadius <= maxRadius";
  if (!(acceptRatio >= 0 && acceptRatio < 0.25)) return "acceptRatio must lie in [0, 0.25)";
  if (!(shrink > 0 && shrink < 1) || !(grow > 1)) return "shrink must lie in (0, 1) and grow exceed 1";
  if (maxCgIterations < 1) return "maxCgIterations must be at least 1";
  if (!(forcing > 0 && forcing < 1)) return "forcing must lie in (0, 1)";
  return "";
}

TrustRegionStep steihaugStep(const std::function<VectorXd(const VectorXd&)>& hessian, const VectorXd& x,
                             const VectorXd& g, const VectorXd& lower, const VectorXd& upper, std::vector<char> held,
                             double radius, double tolerance, int maxIterations, const std::function<bool()>& stop) {
  const Eigen::Index n = x.size();
  TrustRegionStep out;
  VectorXd& s = out.s;
  s = VectorXd::Zero(n);
  VectorXd Hs = VectorXd::Zero(n);
  // The model's negative gradient on the free variables.
  auto residual = [&] {
    VectorXd r = -(g + Hs);
    for (Eigen::Index i = 0; i < n; ++i)
      if (held[i]) r[i] = 0;
    return r;
  };
  VectorXd r = residual(), p = r;
  double rr = r.squaredNorm();
  while (std::sqrt(rr) > tolerance && out.cgIterations < maxIterations) {
    // A product can cost seconds (a solve per pose): limits are polled
    // before each, and a stopped CG returns the step it has.
    if (stop && stop()) {
      out.stopped = true;
      break;
    }
    const VectorXd Hp = hessian(p);
    ++out.cgIterations;
    const double kappa = p.dot(Hp);
    // The largest step along p that stays in the box, and who reaches it.
    double tauBox = kInf;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (held[i] || p[i] == 0) continue;
      const double room = p[i] > 0 ? upper[i] - x[i] - s[i] : lower[i] - x[i] - s[i];
      tauBox = std::min(tauBox, std::max(0.0, room / p[i]));
    }
    const double tauRadius = toRadius(s, p, radius);
    double tau;
    bool restart = false;
    if (!(kappa > 0)) {
      out.negativeCurvature = true;
      tau = std::min(tauRadius, tauBox);
      if (!std::isfinite(tau)) break;
      restart = tauBox < tauRadius;
    } else {
      const double alpha = rr / kappa;
      if (alpha <= std::min(tauRadius, tauBox)) {
        s += alpha * p;
        Hs += alpha * Hp;
        r = residual();
        const double rrNew = r.squaredNorm();
        p = r + (rrNew / rr) * p;
        for (Eigen::Index i = 0; i < n; ++i)
          if (held[i]) p[i] = 0;
        rr = rrNew;
        continue;
      }
      tau = std::min(tauRadius, tauBox);
      restart = tauBox < tauRadius;
    }
    s += tau * p;
    Hs += tau * Hp;
    if (!restart) {
      out.reachedRadius = true;
      break;
    }
    // At the box: the variables that reached their bound are held there, and
    // CG starts again on the others from this point.
    bool any = false;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (held[i] || p[i] == 0) continue;
      const double room = p[i] > 0 ? upper[i] - x[i] - s[i] : lower[i] - x[i] - s[i];
      if (std::abs(room) <= 1e-12 * std::max({1.0, std::abs(x[i]), std::abs(tau * p[i])})) {
        s[i] = (p[i] > 0 ? upper[i] : lower[i]) - x[i];
        held[i] = 1;
        any = true;
      }
    }
    if (!any) break;  // round-off: nothing reached a bound after all
    r = residual();
    p = r;
    rr = r.squaredNorm();
  }
  out.predicted = -(g.dot(s) + 0.5 * s.dot(Hs));
  return out;
}

TrustRegionResult minimizeTrustRegion(const TrustRegionProblem& problem, VectorXd x0, const VectorXd& lower,
                                      const VectorXd& upper, const TrustRegionOptions& opt,
                                      const TrustRegionCallbacks& cb) {
  TrustRegionResult res;
  const auto t0 = Clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - t0).count(); };
  double radius = opt.initialRadius;
  auto finish = [&](Status st) {
    res.status = std::move(st);
    res.radius = radius;
    res.timeSeconds = elapsed();
    return res;
  };
  res.x = x0;
  if (std::string why = opt.isValid(); !why.empty())
    return finish({Outcome::InvalidProblem, "invalid trust-region options: " + why});
  const Eigen::Index n = x0.size();
  if (lower.size() != n || upper.size() != n) return finish({Outcome::InvalidProblem, "bounds and x0 differ in size"});
  if (!x0.allFinite()) return finish({Outcome::InvalidProblem, "x0 is not finite"});
  for (Eigen::Index i = 0; i < n; ++i)
    if (std::isnan(lower[i]) || std::isnan(upper[i]) || !(lower[i] <= upper[i]) || lower[i] == kInf ||
        upper[i] == -kInf)
      return finish({Outcome::InvalidProblem, "empty or undefined bounds for variable " + std::to_string(i)});
  if (!problem.value || !problem.prepare || !problem.hessian)
    return finish({Outcome::InvalidProblem, "the problem needs value, prepare and hessian"});

  // Limits before every evaluation.
  Status stop;
  auto limit = [&] {
    if (cb.stopRequested && cb.stopRequested()) {
      stop = {Outcome::Interrupted, "stop requested"};
      return true;
    }
    if (opt.timeLimit > 0 && elapsed() >= opt.timeLimit) {
      stop = {Outcome::TimeLimit, formatMessage("time limit of %.3g s reached", opt.timeLimit)};
      return true;
    }
    return false;
  };
  // Value, then (when `withGradient`) gradient: false if either fails.
  auto evaluate = [&](const VectorXd& x, double& f, VectorXd* g) {
    ++res.evaluations;
    bool ok = problem.value(x, f) && std::isfinite(f);
    if (ok && g) {
      ++res.evaluations;
      ok = problem.prepare(x, *g) && g->size() == n && g->allFinite();
    }
    if (!ok) ++res.failedEvaluations;
    return ok;
  };

  VectorXd x = x0.cwiseMax(lower).cwiseMin(upper), g;
  res.x = x;
  double f = kInf;
  if (limit()) return finish(stop);
  if (!evaluate(x, f, &g)) return finish({Outcome::NumericalFailure, "the initial point could not be evaluated"});
  res.f = f;
  std::vector<char> held(n);
  auto projected = [&] {
    VectorXd pg = g;
    for (Eigen::Index i = 0; i < n; ++i) {
      held[i] = heldAt(x[i], g[i], lower[i], upper[i]);
      if (held[i]) pg[i] = 0;
    }
    return pg;
  };
  VectorXd pg = projected();
  double pgNorm = pg.lpNorm<Eigen::Infinity>();
  const double pg0 = pg.norm();
  res.projectedGradientNorm = pgNorm;
  const double gradientScale = opt.gradientScale > 0 ? opt.gradientScale : pgNorm;
  auto record = [&](TrustRegionIterate it) {
    it.f = f;
    it.projectedGradientNorm = pgNorm;
    it.radius = radius;
    it.elapsed = elapsed();
    it.evaluations = res.evaluations;
    res.history.push_back(it);
    if (cb.progress) cb.progress(it);
  };
  auto gradientConverged = [&] {
    if (pgNorm > opt.gradientTolerance * gradientScale) return false;
    res.status = {Outcome::Converged,
                  formatMessage("projected gradient below tolerance: |Pg|_inf = %.3g <= %.3g * %.3g", pgNorm,
                                opt.gradientTolerance, gradientScale)};
    return true;
  };
  record({});
  if (gradientConverged()) return finish(res.status);

  std::vector<double> accepted{f};
  double acceptedRadius = radius;  // after the last accepted step (at the start: the initial radius)
  int rejected = 0;
  for (int iteration = 1; iteration <= opt.maxIterations;) {
    const double pgNow = pg.norm();
    const double eta = std::min(opt.forcing, pg0 > 0 ? std::sqrt(pgNow / pg0) : opt.forcing);
    TrustRegionStep step =
        steihaugStep(problem.hessian, x, g, lower, upper, held, radius, eta * pgNow, opt.maxCgIterations, limit);
    if (step.stopped) {
      res.cgIterations += step.cgIterations;
      return finish(stop);
    }
    int products = step.cgIterations;
    const bool negative = step.negativeCurvature;
    bool gaussNewton = false;
    if (negative && opt.gaussNewtonOnNegativeCurvature && problem.gaussNewton) {
      step = steihaugStep(problem.gaussNewton, x, g, lower, upper, held, radius, eta * pgNow,
                          std::max(1, opt.maxCgIterations - products), limit);
      if (step.stopped) {
        res.cgIterations += products + step.cgIterations;
        return finish(stop);
      }
      products += step.cgIterations;
      gaussNewton = true;
    }
    res.cgIterations += products;
    const double sNorm = step.s.norm();
    if (!(step.predicted > 0) || sNorm == 0) {
      return finish(
          {Outcome::Stalled, formatMessage("the model predicts no decrease (|Pg|_inf = %.3g, %.3g of the gradient "
                                           "scale)",
                                           pgNorm, pgNorm / gradientScale)});
    }
    VectorXd xNew = (x + step.s).cwiseMax(lower).cwiseMin(upper);
    double fNew = kInf;
    VectorXd gNew;
    if (limit()) return finish(stop);
    bool ok = evaluate(xNew, fNew, nullptr);
    // Near a minimizer both decreases reach the rounding of f, and their
    // ratio is rounding noise: a step that decreases the model by less than
    // f's last digits would be rejected at random and the radius collapse
    // before the gradient test is met. As Conn, Gould and Toint ("Trust-
    // Region Methods", sec. 17.4.2) advise, both decreases are shifted by
    // delta = 10 eps max(1, |f|), so that such steps count as the model
    // predicted and f may rise by rounding only.
    const double delta = 10 * std::numeric_limits<double>::epsilon() * std::max(1.0, std::abs(f));
    const double rho = ok ? (f - fNew + delta) / (step.predicted + delta) : -kInf;
    if (ok && rho > opt.acceptRatio && fNew < f + delta) {
      // The gradient and the products at the probe (its equilibria are the
      // value's).
      ++res.evaluations;
      ok = problem.prepare(xNew, gNew) && gNew.size() == n && gNew.allFinite();
      if (!ok) ++res.failedEvaluations;
    } else {
      ok = false;
    }
    if (!ok) {
      ++rejected;
      ++res.rejectedSteps;
      radius = opt.shrink * std::min(radius, sNorm);
      if (radius < opt.minRadius)
        return finish(
            {Outcome::Stalled,
             formatMessage("trust radius below %.3g (%d rejected steps); |Pg|_inf = %.3g, %.3g of the gradient "
                           "scale",
                           opt.minRadius, rejected, pgNorm, pgNorm / gradientScale)});
      continue;
    }
    // Steps limited by a radius that is still growing say nothing about
    // convergence: a phase started with a small radius doubles it for many
    // iterations, each a small decrease. The relative-decrease test is
    // therefore skipped when the radius after this step is larger than after
    // the last accepted one. Steps accepted and rejected in turn (creeping
    // towards a point where the objective jumps: a fold of a loading path)
    // double the radius at each acceptance, but each rejection quarters it:
    // over the pair it shrinks, and that creep is what the test stops.
    if (rho < 0.25) radius = opt.shrink * sNorm;
    else if (rho > 0.75 && step.reachedRadius) radius = std::min(opt.grow * radius, opt.maxRadius);
    radius = std::max(radius, opt.minRadius);
    const bool growing = radius > acceptedRadius;
    acceptedRadius = radius;
    x = std::move(xNew);
    f = fNew;
    g = std::move(gNew);
    pg = projected();
    pgNorm = pg.lpNorm<Eigen::Infinity>();
    res.x = x;
    res.f = f;
    res.projectedGradientNorm = pgNorm;
    res.iterations = iteration;
    res.negativeCurvatureSteps += negative;
    res.gaussNewtonSteps += gaussNewton;
    accepted.push_back(f);
    if (cb.accepted) cb.accepted(x);
    TrustRegionIterate it;
    it.iteration = iteration;
    it.step = sNorm;
    it.cgIterations = products;
    it.rejected = rejected;
    it.negativeCurvature = negative;
    it.gaussNewton = gaussNewton;
    record(it);
    rejected = 0;
    if (gradientConverged()) return finish(res.status);
    if (iteration >= opt.stallWindow && !growing) {
      const double fOld = accepted[iteration - opt.stallWindow];
      if (fOld - f <= opt.relativeDecrease * std::abs(fOld))
        return finish({Outcome::Converged, formatMessage("relative decrease below %.3g over %d iterations",
                                                         opt.relativeDecrease, opt.stallWindow)});
    }
    ++iteration;
  }
  return finish({Outcome::MaxIterations, "reached " + std::to_string(opt.maxIterations) + " iterations"});
}

}  // namespace rodmesh
