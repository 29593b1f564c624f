// The imperfection test of reported designs (solver/equilibrium.hh,
// addImperfectionSensitivity): its radius pattern, a smooth response (a
// cantilever under a tip load) and a jump (a shallow arch loaded to just
// below its limit point, which radii 0.1% off snap through).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "model/scene_model.hh"
#include "solver/equilibrium.hh"
#include "tests/testutil/design_problems.hh"
#include "tests/testutil/scenes.hh"

namespace rodmesh {
namespace {

TEST(RadiusImperfection, ChangesEveryRadiusByTheGivenFractionWithAFixedMixOfSigns) {
  Scene s = testutil::straightRod(40, 1.0, 0.002, 0.003);
  const Design d = Design::fromScene(s);
  const Design plus = radiusImperfection(d, 1e-3, 1), minus = radiusImperfection(d, 1e-3, -1);
  ASSERT_EQ(plus.radii.size(), d.radii.size());
  int positive = 0;
  for (std::size_t v = 0; v < d.radii.size(); ++v)
    for (int k = 0; k < 2; ++k) {
      const double up = plus.radii[v][k] / d.radii[v][k] - 1, down = minus.radii[v][k] / d.radii[v][k] - 1;
      EXPECT_NEAR(std::abs(up), 1e-3, 1e-12) << v << " " << k;
      EXPECT_NEAR(up, -down, 1e-12) << "the two signs are opposite changes";
      positive += up > 0;
    }
  // 82 radii: both signs well represented (a binomial count this far from
  // 41 has probability below 1e-4), and the same pattern on every call.
  EXPECT_GT(positive, 20);
  EXPECT_LT(positive, 62);
  EXPECT_EQ(radiusImperfection(d, 1e-3, 1).radii, plus.radii);
  EXPECT_EQ(plus.restPositions, d.restPositions) << "the rest shape is not changed";
}

// A 0.3 m cantilever (r = 2 mm) under a tip load `load` (N, downwards),
// solved from rest and tested.
PoseResult testedCantilever(double load) {
  Scene s = testutil::cantilever(30, 0.3, 0.002, 0.002, Vec3(0, 0, 1));
  if (load != 0.0) s.poses[0].forces.push_back({30, Vec3(0, 0, -load)});
  const SceneModel model(s);
  const Design d = Design::fromScene(s);
  SimulationResult sim = simulateAll(model, d, NewtonOptions{});
  EXPECT_TRUE(sim.allConverged);
  addImperfectionSensitivity(model, d, NewtonOptions{}, sim);
  return sim.poses.at(0);
}

TEST(ImperfectionSensitivity, ACantileverRespondsSmoothly) {
  const PoseResult p = testedCantilever(0.05);
  ASSERT_TRUE(p.imperfectionGap && p.largestDisplacement);
  EXPECT_GT(*p.largestDisplacement, 0.01) << "a visibly bent cantilever";
  // Relative radius changes e change a bending stiffness by about 4 e: the
  // tip moves by a few e of its displacement, not more.
  EXPECT_GT(*p.imperfectionGap, 0.0);
  EXPECT_LT(*p.imperfectionGap, 5 * kImperfectionRadiusChange * *p.largestDisplacement);
  EXPECT_FALSE(p.imperfectionSensitive());
}

TEST(ImperfectionSensitivity, APoseWithNothingAppliedIsJudgedAgainstTheStructuresSize) {
  const PoseResult p = testedCantilever(0.0);
  ASSERT_TRUE(p.imperfectionGap && p.largestDisplacement);
  // The rest state, whatever the radii: no motion, judged against 1e-6 of
  // the 0.3 m rod rather than against nothing.
  EXPECT_LT(*p.imperfectionGap, 1e-12);
  EXPECT_NEAR(*p.largestDisplacement, 1e-6 * 0.3, 1e-12);
  EXPECT_FALSE(p.imperfectionSensitive());
}

TEST(ImperfectionSensitivity, AnArchJustBelowItsLimitLoadSnapsUnderIt) {
  Scene s = testutil::invertibleArch();
  s.design = DesignSpec{};
  const Design d = Design::fromScene(s);
  const int crown = 20;
  // The crown load where the arch snaps through, by bisection: up below it,
  // inverted above. Within a load step of the critical point the path may
  // find no equilibrium beyond it that round-off does not decide (a saddle
  // whose descent is below the energy's last digits): the solve then says
  // that it lost the path at a critical point, and the arch did not stay up
  // to that load.
  auto staysUp = [&](double load) {
    Scene t = s;
    t.poses[0].forces[0].force = Vec3(0, 0, -load);
    const SceneModel m(t);
    const SimulationResult r = simulateAll(m, d, NewtonOptions{});
    if (!r.allConverged) {
      const std::string& why = r.poses[0].report.message;
      EXPECT_NE(why.find("the equilibrium path was lost"), std::string::npos) << load << ": " << why;
      EXPECT_NE(why.find("a limit or bifurcation point"), std::string::npos) << load << ": " << why;
      EXPECT_GT(r.poses[0].report.loadFactor, 0.99) << load << ": lost near the full load only";
      return false;
    }
    return r.poses[0].positions[crown].z() > 0;
  };
  double up = 0.01, down = 10.0;
  ASSERT_TRUE(staysUp(up));
  ASSERT_FALSE(staysUp(down));
  while (down - up > 1e-6 * up) {
    const double mid = 0.5 * (up + down);
    (staysUp(mid) ? up : down) = mid;
  }
  s.poses[0].forces[0].force = Vec3(0, 0, -up);
  const SceneModel model(s);
  SimulationResult sim = simulateAll(model, d, NewtonOptions{});
  ASSERT_TRUE(sim.allConverged);
  ASSERT_GT(sim.poses[0].positions[crown].z(), 0.0);
  addImperfectionSensitivity(model, d, NewtonOptions{}, sim);
  const PoseResult& p = sim.poses[0];
  ASSERT_TRUE(p.imperfectionGap);
  // One of the two imperfections lowers the limit load below the load: the
  // crown ends below the chord, more than the rise (5 cm) away.
  EXPECT_GT(*p.imperfectionGap, 0.05);
  EXPECT_TRUE(p.imperfectionSensitive());
  // Half the load leaves it far from its limit point: smooth again.
  s.poses[0].forces[0].force = Vec3(0, 0, -0.5 * up);
  const SceneModel half(s);
  SimulationResult relaxed = simulateAll(half, d, NewtonOptions{});
  ASSERT_TRUE(relaxed.allConverged);
  addImperfectionSensitivity(half, d, NewtonOptions{}, relaxed);
  EXPECT_FALSE(relaxed.poses[0].imperfectionSensitive()) << *relaxed.poses[0].imperfectionGap;
}

}  // namespace
}  // namespace rodmesh
