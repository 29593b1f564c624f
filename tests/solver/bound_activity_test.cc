// Radius bounds that hold a design back (solver/bound_activity.hh): which
// control radii are held at a bound, and the first-order gain of moving the
// bound, checked against the objective re-solved with the bound moved.
#include "solver/bound_activity.hh"
#include "solver/design_optimizer.hh"
#include "solver/equilibrium.hh"
#include "tests/testutil/design_problems.hh"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

namespace rodmesh {
namespace {

struct Problem {
  Scene scene;
  std::unique_ptr<SceneModel> model;
  std::unique_ptr<DesignSpace> space;
  std::unique_ptr<TargetObjective> objective;
};

// The bent cantilever (radii free in [0.5, 2] mm) with targets from its
// equilibrium at radii targetScale x 1 mm.
Problem cantileverWithTargets(double targetScale) {
  Problem s;
  s.scene = testutil::bentCantilever(2e-3);
  testutil::setScaledRadiiTargets(s.scene, targetScale);
  s.model = std::make_unique<SceneModel>(s.scene);
  s.space = std::make_unique<DesignSpace>(s.scene, s.model->effects());
  s.objective = std::make_unique<TargetObjective>(s.scene, s.model->effects());
  return s;
}

// Every control radius at `radius`, and its equilibria from rest.
ControlValues uniformControls(const Problem& s, double radius, std::vector<PoseState>& states) {
  ControlValues c = s.space->initialControls(s.scene);
  c.radii.setConstant(radius);
  const Design d = s.space->toDesign(c);
  const SimulationResult r = simulateAll(*s.model, d, NewtonOptions{});
  EXPECT_TRUE(r.allConverged);
  states.clear();
  for (const PoseResult& p : r.poses) states.push_back(p.state);
  return c;
}

// The objective (re-solved) after the bound at `bound` moved to
// bound * factor, taking with it the values that activity `a` holds there
// (held[i] == side); the other values stay.
double objectiveWithBoundMoved(const Problem& s, const ControlValues& c, const RadiusBoundActivity& a, int side,
                               double factor) {
  const DesignPhase phase{true, false, s.space->numLevels() - 1};
  Eigen::VectorXd z = s.space->pack(phase, c);
  for (Eigen::Index i = 0; i < z.size(); ++i)
    if (a.held[i] == side) z[i] *= factor;
  const ControlValues moved = s.space->unpack(phase, z, c);
  const SimulationResult r = simulateAll(*s.model, s.space->toDesign(moved), NewtonOptions{});
  EXPECT_TRUE(r.allConverged);
  std::vector<PoseState> states;
  for (const PoseResult& p : r.poses) states.push_back(p.state);
  ReducedObjective ro(*s.model, *s.space, *s.objective, phase, c, NewtonOptions{}, 1, states);
  double f = std::nan("");
  EXPECT_TRUE(ro.evaluate(z, f, nullptr));
  return f;
}

// d ln f / d ln bound by central differences of the bound (side -1: the
// minimum, +1: the maximum) against the reported elasticity: agreement to
// 1e-4 and an error of second order in the step.
void expectElasticity(const Problem& s, const ControlValues& c, const RadiusBoundActivity& a, int side) {
  const double elasticity = side < 0 ? a.lowerElasticity : a.upperElasticity;
  auto quotient = [&](double h) {
    return (std::log(objectiveWithBoundMoved(s, c, a, side, 1 + h)) -
            std::log(objectiveWithBoundMoved(s, c, a, side, 1 - h))) /
           (std::log1p(h) - std::log1p(-h));
  };
  const double h = 2e-3;
  const double e1 = std::abs(quotient(h) - elasticity);
  const double e2 = std::abs(quotient(h / 2) - elasticity);
  EXPECT_LT(e2, 1e-4 * std::abs(elasticity));
  // The difference quotient's error falls by 4 when h halves (unless both
  // are round-off).
  if (e1 > 1e-9 * std::abs(elasticity)) {
    EXPECT_LT(e2, 0.35 * e1) << "h " << h << ": " << e1 << ", h/2: " << e2;
  }
}

TEST(BoundActivity, ATargetStifferThanTheLargestRadiusHoldsEveryRadiusAtTheMaximum) {
  const Problem s = cantileverWithTargets(2.5);  // 2.5 mm radii made the targets; at most 2 mm allowed
  std::vector<PoseState> states;
  const ControlValues c = uniformControls(s, s.space->radiusUpper(), states);
  const RadiusBoundActivity a = radiusBoundActivity(*s.model, *s.space, *s.objective, c, states, NewtonOptions{});
  ASSERT_TRUE(a.computed);
  EXPECT_EQ(a.total, 2 * s.space->numControlPoints());
  EXPECT_EQ(a.atUpper, a.total);
  EXPECT_EQ(a.atLower, 0);
  EXPECT_EQ(a.lowerElasticity, 0.0);
  EXPECT_LT(a.upperElasticity, 0.0);
  expectElasticity(s, c, a, +1);
  const std::string text = describeBoundActivity(a);
  EXPECT_NE(text.find(std::to_string(a.total) + " of " + std::to_string(a.total) + " control radii"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("at 2 mm"), std::string::npos) << text;
}

TEST(BoundActivity, ATargetSofterThanTheSmallestRadiusHoldsTheRadiiAtTheMinimum) {
  const Problem s = cantileverWithTargets(0.35);  // 0.35 mm made the targets; at least 0.5 mm allowed
  std::vector<PoseState> states;
  const ControlValues c = uniformControls(s, s.space->radiusLower(), states);
  const RadiusBoundActivity a = radiusBoundActivity(*s.model, *s.space, *s.objective, c, states, NewtonOptions{});
  ASSERT_TRUE(a.computed);
  // Every value but the free tip's pair, which carries no bending moment
  // (its gradient is 1e-4 of the clamp's and of either sign).
  EXPECT_GE(a.atLower, a.total - 2);
  EXPECT_EQ(a.atUpper, 0);
  EXPECT_GT(a.lowerElasticity, 0.0);
  EXPECT_EQ(a.upperElasticity, 0.0);
  expectElasticity(s, c, a, -1);
}

TEST(BoundActivity, RadiiAwayFromTheBoundsAreNotHeld) {
  const Problem s = cantileverWithTargets(2.5);
  std::vector<PoseState> states;
  // 1.2 mm: the objective wants thicker rods, and nothing stops them yet.
  const ControlValues c = uniformControls(s, 1.2e-3, states);
  const RadiusBoundActivity a = radiusBoundActivity(*s.model, *s.space, *s.objective, c, states, NewtonOptions{});
  ASSERT_TRUE(a.computed);
  EXPECT_EQ(a.atLower + a.atUpper, 0);
  EXPECT_TRUE(describeBoundActivity(a).empty());
  // Just inside the maximum (as an interior-point optimizer stops) the same
  // radii count as held.
  const double nearMax = s.space->radiusUpper() - 0.5 * kAtBoundFraction *
                                                      (s.space->radiusUpper() - s.space->radiusLower());
  const ControlValues n = uniformControls(s, nearMax, states);
  const RadiusBoundActivity b = radiusBoundActivity(*s.model, *s.space, *s.objective, n, states, NewtonOptions{});
  EXPECT_EQ(b.atUpper, b.total);
}

TEST(BoundActivity, NotComputedWithoutEquilibria) {
  const Problem s = cantileverWithTargets(2.5);
  std::vector<PoseState> states;
  const ControlValues c = uniformControls(s, 1e-3, states);
  const RadiusBoundActivity a = radiusBoundActivity(*s.model, *s.space, *s.objective, c, {}, NewtonOptions{});
  EXPECT_FALSE(a.computed);
  EXPECT_TRUE(describeBoundActivity(a).empty());
}

}  // namespace
}  // namespace rodmesh
