// Trust-region Newton-CG with bounds (solver/trust_region.hh) on analytic
// problems: Rosenbrock free and bound-constrained, a convex quadratic whose
// solution binds many bounds at once, a saddle (negative curvature), a wrong
// model, failing evaluations, limits; the CG step itself on small cases.
#include "solver/trust_region.hh"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace rodmesh {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
constexpr double kInf = std::numeric_limits<double>::infinity();

// Extended Rosenbrock: sum over pairs of 100 (x_{2i+1} - x_{2i}^2)^2 + (1 - x_{2i})^2.
struct Rosenbrock {
  int evaluations = 0;
  VectorXd at;
  double f(const VectorXd& x) const {
    double s = 0;
    for (int i = 0; i + 1 < x.size(); i += 2)
      s += 100 * std::pow(x[i + 1] - x[i] * x[i], 2) + std::pow(1 - x[i], 2);
    return s;
  }
  VectorXd g(const VectorXd& x) const {
    VectorXd r = VectorXd::Zero(x.size());
    for (int i = 0; i + 1 < x.size(); i += 2) {
      const double a = x[i + 1] - x[i] * x[i];
      r[i] = -400 * x[i] * a - 2 * (1 - x[i]);
      r[i + 1] = 200 * a;
    }
    return r;
  }
  MatrixXd H(const VectorXd& x) const {
    MatrixXd h = MatrixXd::Zero(x.size(), x.size());
    for (int i = 0; i + 1 < x.size(); i += 2) {
      h(i, i) = 1200 * x[i] * x[i] - 400 * x[i + 1] + 2;
      h(i, i + 1) = h(i + 1, i) = -400 * x[i];
      h(i + 1, i + 1) = 200;
    }
    return h;
  }
  TrustRegionProblem problem() {
    TrustRegionProblem p;
    p.value = [this](const VectorXd& x, double& v) {
      ++evaluations;
      v = f(x);
      return true;
    };
    p.prepare = [this](const VectorXd& x, VectorXd& gr) {
      at = x;
      gr = g(x);
      return true;
    };
    p.hessian = [this](const VectorXd& v) -> VectorXd { return H(at) * v; };
    return p;
  }
};

// First-order optimality on the box: free components of the gradient small,
// components at a bound pointing outward (or small).
void expectKkt(const VectorXd& x, const VectorXd& g, const VectorXd& lo, const VectorXd& hi, double tol) {
  for (int i = 0; i < x.size(); ++i) {
    if (x[i] <= lo[i]) EXPECT_GE(g[i], -tol) << i;
    else if (x[i] >= hi[i]) EXPECT_LE(g[i], tol) << i;
    else EXPECT_LE(std::abs(g[i]), tol) << i;
  }
}

TEST(TrustRegion, RosenbrockUnconstrained) {
  Rosenbrock rb;
  TrustRegionOptions o;
  o.gradientTolerance = 1e-10;
  o.relativeDecrease = 0;
  const VectorXd lo = VectorXd::Constant(2, -kInf), hi = VectorXd::Constant(2, kInf);
  const TrustRegionResult r = minimizeTrustRegion(rb.problem(), VectorXd((VectorXd(2) << -1.2, 1).finished()), lo, hi, o);
  ASSERT_EQ(r.status.outcome, Outcome::Converged) << r.status.message;
  EXPECT_NEAR(r.x[0], 1.0, 1e-8);
  EXPECT_NEAR(r.x[1], 1.0, 1e-8);
  // Newton: a few dozen steps (BFGS-like methods need about twice as many).
  EXPECT_LE(r.iterations, 30);
  // The history starts at iteration 0 and reports CG products and radii.
  ASSERT_EQ(static_cast<int>(r.history.size()), r.iterations + 1);
  EXPECT_GT(r.history.back().cgIterations, 0);
  EXPECT_GT(r.history.back().radius, 0.0);
}

TEST(TrustRegion, RosenbrockWithAnActiveUpperBound) {
  Rosenbrock rb;
  TrustRegionOptions o;
  o.gradientTolerance = 1e-10;
  o.relativeDecrease = 0;
  const VectorXd lo = VectorXd::Constant(2, -2.0), hi = (VectorXd(2) << 0.5, 2.0).finished();
  const TrustRegionResult r = minimizeTrustRegion(rb.problem(), VectorXd((VectorXd(2) << -1.2, 1).finished()), lo, hi, o);
  ASSERT_EQ(r.status.outcome, Outcome::Converged) << r.status.message;
  EXPECT_EQ(r.x[0], 0.5);
  EXPECT_NEAR(r.x[1], 0.25, 1e-8);
  expectKkt(r.x, rb.g(r.x), lo, hi, 1e-7);
}

TEST(TrustRegion, ExtendedRosenbrockInABox) {
  Rosenbrock rb;
  TrustRegionOptions o;
  o.gradientTolerance = 1e-10;
  o.relativeDecrease = 0;
  const int n = 20;
  VectorXd lo(n), hi(n), x0(n);
  for (int i = 0; i < n; ++i) {
    lo[i] = -1.5;
    hi[i] = i % 4 == 0 ? 0.7 : 1.5;  // every other pair's first variable cannot reach 1
    x0[i] = i % 2 ? 1.0 : -1.2;
  }
  const TrustRegionResult r = minimizeTrustRegion(rb.problem(), x0, lo, hi, o);
  ASSERT_EQ(r.status.outcome, Outcome::Converged) << r.status.message;
  expectKkt(r.x, rb.g(r.x), lo, hi, 1e-6);
  for (int i = 0; i < n; i += 2) {
    EXPECT_NEAR(r.x[i], i % 4 == 0 ? 0.7 : 1.0, 1e-7);
    EXPECT_NEAR(r.x[i + 1], r.x[i] * r.x[i], 1e-7);
  }
}

// A strictly convex quadratic whose minimizer over the box has most
// variables at a bound: CG holds every bound it reaches and goes on, so the
// solution takes a few iterations, not one per active bound.
TEST(TrustRegion, ConvexQuadraticBindsManyBoundsPerIteration) {
  const int n = 40;
  std::mt19937 rng(3);
  std::normal_distribution<double> N(0.0, 1.0);
  MatrixXd A(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) A(i, j) = N(rng);
  const MatrixXd H = A.transpose() * A / n + 0.1 * MatrixXd::Identity(n, n);
  VectorXd b(n);
  for (int i = 0; i < n; ++i) b[i] = 5 * N(rng);
  const VectorXd lo = VectorXd::Constant(n, -1.0), hi = VectorXd::Constant(n, 1.0);
  TrustRegionProblem p;
  p.value = [&](const VectorXd& x, double& f) {
    f = 0.5 * x.dot(H * x) - b.dot(x);
    return true;
  };
  p.prepare = [&](const VectorXd& x, VectorXd& g) {
    g = H * x - b;
    return true;
  };
  p.hessian = [&](const VectorXd& v) -> VectorXd { return H * v; };
  TrustRegionOptions o;
  o.initialRadius = 100;
  o.maxRadius = 100;
  o.gradientTolerance = 1e-10;
  o.relativeDecrease = 0;
  o.maxCgIterations = 400;
  const TrustRegionResult r = minimizeTrustRegion(p, VectorXd::Zero(n), lo, hi, o);
  ASSERT_EQ(r.status.outcome, Outcome::Converged) << r.status.message;
  expectKkt(r.x, H * r.x - b, lo, hi, 1e-8);
  int active = 0;
  for (int i = 0; i < n; ++i) active += r.x[i] == lo[i] || r.x[i] == hi[i];
  EXPECT_GE(active, n / 2);
  EXPECT_LT(r.iterations, active / 2) << active << " active bounds";
}

// f = -x^2 + y^2 on [-1, 1]^2 from near the saddle: negative curvature takes
// x to its bound.
TEST(TrustRegion, NegativeCurvatureGoesToTheBound) {
  TrustRegionProblem p;
  p.value = [](const VectorXd& x, double& f) {
    f = -x[0] * x[0] + x[1] * x[1];
    return true;
  };
  p.prepare = [](const VectorXd& x, VectorXd& g) {
    g = (VectorXd(2) << -2 * x[0], 2 * x[1]).finished();
    return true;
  };
  p.hessian = [](const VectorXd& v) -> VectorXd { return (VectorXd(2) << -2 * v[0], 2 * v[1]).finished(); };
  TrustRegionOptions o;
  o.initialRadius = 0.1;
  o.gradientTolerance = 1e-12;
  o.relativeDecrease = 0;
  const VectorXd lo = VectorXd::Constant(2, -1.0), hi = VectorXd::Constant(2, 1.0);
  const TrustRegionResult r = minimizeTrustRegion(p, (VectorXd(2) << 0.01, 0.5).finished(), lo, hi, o);
  ASSERT_EQ(r.status.outcome, Outcome::Converged) << r.status.message;
  EXPECT_EQ(r.x[0], 1.0);
  EXPECT_NEAR(r.x[1], 0.0, 1e-10);
  EXPECT_GE(r.negativeCurvatureSteps, 1);
  EXPECT_EQ(r.gaussNewtonSteps, 0);
  // With a Gauss-Newton operator (positive definite here) in place of the
  // negative curvature: the same minimizer, the steps taken with it.
  p.gaussNewton = [](const VectorXd& v) -> VectorXd { return (VectorXd(2) << 1 * v[0], 2 * v[1]).finished(); };
  o.gaussNewtonOnNegativeCurvature = true;
  const TrustRegionResult rg = minimizeTrustRegion(p, (VectorXd(2) << 0.01, 0.5).finished(), lo, hi, o);
  ASSERT_EQ(rg.status.outcome, Outcome::Converged) << rg.status.message;
  EXPECT_EQ(rg.x[0], 1.0);
  EXPECT_NEAR(rg.x[1], 0.0, 1e-10);
  EXPECT_GE(rg.gaussNewtonSteps, 1);
}

// A model with half the true curvature overshoots into a region where the
// objective cannot be evaluated: the step is rejected, the radius shrinks,
// and the run still converges.
TEST(TrustRegion, FailedEvaluationsShrinkTheRadius) {
  TrustRegionProblem p;
  int failed = 0;
  p.value = [&](const VectorXd& x, double& f) {
    if (x[0] > 2.5) {
      ++failed;
      return false;
    }
    f = (x[0] - 1) * (x[0] - 1);
    return true;
  };
  p.prepare = [](const VectorXd& x, VectorXd& g) {
    g = VectorXd::Constant(1, 2 * (x[0] - 1));
    return true;
  };
  p.hessian = [](const VectorXd& v) -> VectorXd { return 1.0 * v; };
  TrustRegionOptions o;
  o.initialRadius = 10;
  o.gradientTolerance = 1e-6;
  o.relativeDecrease = 0;
  const VectorXd lo = VectorXd::Constant(1, -kInf), hi = VectorXd::Constant(1, kInf);
  const TrustRegionResult r = minimizeTrustRegion(p, VectorXd::Constant(1, -1.0), lo, hi, o);
  ASSERT_EQ(r.status.outcome, Outcome::Converged) << r.status.message;
  EXPECT_NEAR(r.x[0], 1.0, 1e-5);
  EXPECT_GE(failed, 1);
  EXPECT_EQ(r.failedEvaluations, failed);
  EXPECT_GE(r.rejectedSteps, 1);
}

// A phase that starts with a tiny radius (inherited from a phase that ended
// against a fold) doubles it for many iterations, each decreasing f by
// little: that is the radius's limit, not convergence. On a quadratic from
// radius 1e-8 with the relative-decrease test over 10 iterations, the run
// must reach the minimizer, not stop after the first ten doublings.
// f = c + |x - 1|^2 / 2 (plus `jump` where x0 >= 0.5), gradient and
// Hessian those of the quadratic; the stall test over 10 iterations at
// 1e-3, minRadius 1e-12.
TrustRegionProblem shiftedQuadratic(double c, double jump, TrustRegionOptions& o) {
  TrustRegionProblem p;
  p.value = [c, jump](const VectorXd& x, double& f) {
    f = c + 0.5 * (x.array() - 1).square().sum() + (x[0] >= 0.5 ? jump : 0.0);
    return true;
  };
  p.prepare = [](const VectorXd& x, VectorXd& g) {
    g = x.array() - 1;
    return true;
  };
  p.hessian = [](const VectorXd& v) -> VectorXd { return v; };
  o.minRadius = 1e-12;
  o.relativeDecrease = 1e-3;
  o.stallWindow = 10;
  o.gradientTolerance = 1e-8;
  return p;
}

TEST(TrustRegion, ARadiusStillGrowingIsNotAStall) {
  TrustRegionOptions o;
  const TrustRegionProblem p = shiftedQuadratic(1.0, 0.0, o);
  o.initialRadius = 1e-8;
  const VectorXd lo = VectorXd::Constant(3, -kInf), hi = VectorXd::Constant(3, kInf);
  const TrustRegionResult r = minimizeTrustRegion(p, VectorXd::Zero(3), lo, hi, o);
  ASSERT_EQ(r.status.outcome, Outcome::Converged) << r.status.message;
  EXPECT_LT((r.x.array() - 1).abs().maxCoeff(), 1e-6) << r.status.message;
  EXPECT_GT(r.iterations, 10);
}

// The minimum of a smooth model lies beyond a cliff (the objective jumps at
// x0 = 0.5, as an optimizer's objective jumps where a loading path passes a
// fold). Steps are accepted and rejected in turn, each accepted one halfway
// to the cliff and growing the radius, which shrinks over every pair: the
// iterates creep towards the cliff with ever smaller decreases. The
// relative-decrease test ends that creep; it must not count the radius's
// growth after each accepted step as a radius still growing (the run would
// otherwise go on until the radius falls below minRadius).
TEST(TrustRegion, CreepingTowardsACliffIsAStall) {
  TrustRegionOptions o;
  const TrustRegionProblem p = shiftedQuadratic(0.0, 10.0, o);
  o.initialRadius = 0.1;
  const VectorXd lo = VectorXd::Constant(1, -kInf), hi = VectorXd::Constant(1, kInf);
  const TrustRegionResult r = minimizeTrustRegion(p, VectorXd::Zero(1), lo, hi, o);
  EXPECT_EQ(r.status.outcome, Outcome::Converged) << r.status.message;
  EXPECT_NE(r.status.message.find("relative decrease"), std::string::npos) << r.status.message;
  EXPECT_LT(r.x[0], 0.5);
  EXPECT_GT(r.x[0], 0.49);
  EXPECT_GT(r.radius, o.minRadius * 1e3);
}

TEST(TrustRegion, LimitsAndInvalidOptions) {
  Rosenbrock rb;
  TrustRegionOptions o;
  o.maxIterations = 3;
  o.relativeDecrease = 0;
  const VectorXd lo = VectorXd::Constant(2, -kInf), hi = VectorXd::Constant(2, kInf);
  const VectorXd x0 = (VectorXd(2) << -1.2, 1).finished();
  TrustRegionResult r = minimizeTrustRegion(rb.problem(), x0, lo, hi, o);
  EXPECT_EQ(r.status.outcome, Outcome::MaxIterations);
  EXPECT_EQ(r.iterations, 3);
  EXPECT_LT(r.f, rb.f(x0));
  TrustRegionCallbacks cb;
  int polls = 0;
  cb.stopRequested = [&] { return ++polls > 4; };
  o.maxIterations = 100;
  r = minimizeTrustRegion(rb.problem(), x0, lo, hi, o, cb);
  EXPECT_EQ(r.status.outcome, Outcome::Interrupted);
  o.initialRadius = -1;
  r = minimizeTrustRegion(rb.problem(), x0, lo, hi, o);
  EXPECT_EQ(r.status.outcome, Outcome::InvalidProblem);
}

TEST(SteihaugStep, StopsAtTheRadiusAndAtTheBox) {
  auto identity = [](const VectorXd& v) -> VectorXd { return v; };
  const VectorXd x = VectorXd::Zero(2), lo = VectorXd::Constant(2, -kInf);
  // Along the gradient to the radius.
  TrustRegionStep s = steihaugStep(identity, x, (VectorXd(2) << -10, 0).finished(), lo,
                                   VectorXd::Constant(2, kInf), {0, 0}, 1.0, 1e-12, 10);
  EXPECT_TRUE(s.reachedRadius);
  EXPECT_NEAR(s.s[0], 1.0, 1e-14);
  EXPECT_NEAR(s.predicted, 10 - 0.5, 1e-12);
  // The Newton step (1, 1) leaves the box x0 <= 0.25: CG stops there, holds
  // x0 and finishes along x1.
  s = steihaugStep(identity, x, (VectorXd(2) << -1, -1).finished(), lo, (VectorXd(2) << 0.25, kInf).finished(), {0, 0},
                   10.0, 1e-12, 10);
  EXPECT_FALSE(s.reachedRadius);
  EXPECT_EQ(s.s[0], 0.25);
  EXPECT_NEAR(s.s[1], 1.0, 1e-14);
  EXPECT_NEAR(s.predicted, 0.25 + 1 - 0.5 * (0.0625 + 1), 1e-14);
  // A held variable does not move.
  s = steihaugStep(identity, x, (VectorXd(2) << -1, -1).finished(), lo, VectorXd::Constant(2, kInf), {1, 0}, 10.0,
                   1e-12, 10);
  EXPECT_EQ(s.s[0], 0.0);
  EXPECT_NEAR(s.s[1], 1.0, 1e-14);
}

// A stop request is answered between two Hessian products of CG, not only
// between evaluations: in the optimizer a product costs a solve per pose, and
// one CG loop of hundreds of them must not run past a time limit.
TEST(TrustRegion, StopIsAnsweredInsideTheCgLoop) {
  const int n = 200;
  // An ill-conditioned quadratic: CG needs many products for one step.
  VectorXd d(n);
  for (int i = 0; i < n; ++i) d[i] = std::pow(10.0, 6.0 * i / (n - 1));
  int products = 0;
  bool stopAfterFive = false;
  TrustRegionProblem p;
  p.value = [&](const VectorXd& x, double& v) {
    v = 0.5 * x.dot(d.cwiseProduct(x)) - x.sum();
    return true;
  };
  p.prepare = [&](const VectorXd& x, VectorXd& g) {
    g = d.cwiseProduct(x) - VectorXd::Ones(n);
    return true;
  };
  p.hessian = [&](const VectorXd& v) -> VectorXd {
    ++products;
    return d.cwiseProduct(v);
  };
  TrustRegionOptions o;
  o.initialRadius = 1e6;
  o.forcing = 1e-12;
  TrustRegionCallbacks cb;
  cb.stopRequested = [&] { return stopAfterFive && products >= 5; };
  const VectorXd lo = VectorXd::Constant(n, -kInf), hi = VectorXd::Constant(n, kInf);
  // Without a stop, the first step takes more than 50 products.
  const TrustRegionResult full = minimizeTrustRegion(p, VectorXd::Zero(n), lo, hi, o);
  ASSERT_GT(full.history.size(), 1u);
  ASSERT_GT(full.history[1].cgIterations, 50);
  products = 0;
  stopAfterFive = true;
  const TrustRegionResult r = minimizeTrustRegion(p, VectorXd::Zero(n), lo, hi, o, cb);
  EXPECT_EQ(r.status.outcome, Outcome::Interrupted) << r.status.message;
  EXPECT_EQ(products, 5);
  EXPECT_EQ(r.cgIterations, 5);
  EXPECT_EQ(r.x, VectorXd::Zero(n)) << "the result is the last accepted point";
}

}  // namespace
}  // namespace rodmesh
