// Design targets taken from buckled and snapped-through configurations: the
// initial design sits on the other side of a bifurcation or a limit point
// from the hidden design that made the targets. Both optimizers must end
// cleanly (finite, within bounds, never worse than the initial design) and,
// since the targets are reachable, lower the RMS measured on the equilibria
// of the archived design re-solved from rest, as `rodmesh simulate` would.
#include "model/design_space.hh"
#include "nlp/sand.hh"
#include "solver/design_optimizer.hh"
#include "solver/equilibrium.hh"
#include "tests/testutil/design_problems.hh"
#include "tests/testutil/scenes.hh"

#include <gtest/gtest.h>

#include <cmath>

namespace rodmesh {
namespace {

constexpr double kPi = 3.14159265358979323846;

// RMS of the design's equilibria, solved from rest, against the targets.
double rmsFromRest(const Scene& scene, const Design& d, bool* converged) {
  SceneModel model(scene);
  const SimulationResult sim = simulateAll(model, d, NewtonOptions{});
  *converged = sim.allConverged;
  return rmsError(sim);
}

// Largest transverse (y) excursion of a pose's positions.
double sway(const std::vector<Vec3>& x) {
  double m = 0.0;
  for (const Vec3& p : x) m = std::max(m, std::abs(p.y()));
  return m;
}

// A planar column: 20 edges over 0.2 m along +x, clamped at x = 0, radius
// 1 mm, compressed at its tip by 0.8 of the initial design's Euler load
// (clamped-free: pi^2 EI / (4 L^2)) with a lateral imperfection of 1% of the
// axial force. The hidden design's radii are 0.75 of the initial ones, so
// the same load is 2.5 times its Euler load: the targets are a buckled
// column, the initial design's equilibrium a nearly straight one.
Scene column() {
  Scene s = testutil::cantilever(20, 0.2, 0.001, 0.001, Vec3::UnitZ());
  const double E = s.material.youngModulus, I = kPi * std::pow(0.001, 4) / 4.0, L = 0.2;
  const double P = 0.8 * kPi * kPi * E * I / (4.0 * L * L);
  s.poses[0].forces.push_back({testutil::tipVertex(s), Vec3(-P, 0.01 * P, 0.0)});
  testutil::freeRadii(s);
  return s;
}

// A shallow planar arch: 24 edges, span 0.2 m, rise 8 mm, both ends
// clamped, radius 1 mm, a downward force at the crown. The force is between
// the limit loads of the hidden design (radii 0.8 of the initial ones,
// snapped through: the crown below the supports) and of the initial design
// (not snapped), as the test checks before optimizing.
Scene arch(double force) {
  Scene s;
  s.sourcePath = "<arch>";
  s.material = Material{1e7, 0.4, 1000.0};
  Rod rod;
  const int n = 24;
  const double span = 0.2, rise = 0.008;
  for (int i = 0; i <= n; ++i) {
    const double x = span * i / n - 0.5 * span;
    s.vertices.push_back(Vec3(x, rise * (1.0 - 4.0 * x * x / (span * span)), 0.0));
    rod.vertices.push_back(i);
  }
  s.rods.push_back(rod);
  s.radii.assign(s.vertices.size(), Vec2(0.001, 0.001));
  s.normals.assign(s.vertices.size(), Vec3::UnitZ());
  Pose p;
  p.name = "press";
  p.clamped = {{0}, {n}};
  p.forces.push_back({n / 2, Vec3(0.0, -force, 0.0)});
  s.poses.push_back(p);
  testutil::freeRadii(s);
  return s;
}

double crownHeight(const Scene& s, double radiusScale) {
  Scene h = s;
  for (Vec2& r : h.radii) r *= radiusScale;
  SceneModel m(h);
  const SimulationResult sim = simulateAll(m, Design::fromScene(h), NewtonOptions{});
  EXPECT_TRUE(sim.allConverged);
  return sim.poses[0].positions[s.vertices.size() / 2].y();
}

enum class Method { Sand, Reduced };

// `recover`: the RMS from rest must fall to 5% of the initial one; else the
// run must only end cleanly and be no worse than the initial design.
void expectClean(const Scene& scene, Method method, bool recover) {
  SceneModel model(scene);
  const DesignSpace space(scene, model.effects());
  DesignOptimizerResult r;
  if (method == Method::Sand) {
    SandOptions o;
    o.readOptionsFile = false;
    o.optimizer.maxIterations = 200;
    r = optimizeSand(model, space, o);
  } else {
    DesignOptimizerOptions o;
    o.maxIterations = 200;
    r = optimizeReduced(model, space, o);
  }
  SCOPED_TRACE(outcomeName(r.outcome) + std::string(": ") + r.message);
  EXPECT_FALSE(r.message.empty());
  ASSERT_TRUE(std::isfinite(r.objective) && std::isfinite(r.rms));
  EXPECT_LE(r.objective, r.initialObjective * (1 + 1e-12));
  for (const Vec2& rr : r.design.radii) {
    ASSERT_TRUE(rr.allFinite());
    EXPECT_GE(rr.minCoeff(), space.radiusLower() - 1e-12);
    EXPECT_LE(rr.maxCoeff(), space.radiusUpper() + 1e-12);
  }
  for (const DesignIterate& it : r.history)
    EXPECT_TRUE(std::isfinite(it.objective) && std::isfinite(it.rms) && std::isfinite(it.constraintViolation));
  bool converged = false;
  const double rms = rmsFromRest(scene, r.design, &converged);
  ASSERT_TRUE(converged);
  EXPECT_LE(rms, r.initialRms * (1 + 1e-9)) << "from rest " << rms << ", optimizer " << r.rms;
  if (recover) {
    EXPECT_LT(rms, 0.05 * r.initialRms) << "from rest " << rms << ", optimizer " << r.rms << ", initial "
                                        << r.initialRms;
  }
}

class Instability : public testing::TestWithParam<Method> {};

TEST_P(Instability, BuckledColumnTargets) {
  Scene s = column();
  testutil::setScaledRadiiTargets(s, 0.75);
  // The premise: the targets sway far more than the initial design does.
  SceneModel m(s);
  const SimulationResult initial = simulateAll(m, Design::fromScene(s), NewtonOptions{});
  ASSERT_TRUE(initial.allConverged);
  ASSERT_GT(sway(s.poses[0].target), 5.0 * sway(initial.poses[0].positions));
  // A known weakness of SAND here: Ipopt's linearized steps across the
  // column's large rotations stretch its axially stiff edges, and its
  // iterates stay hundreds of times the load away from equilibrium; what it
  // ends with depends on where the iteration budget cuts it (from-rest RMS
  // 8% to 100% of the initial one for 200 to 600 iterations). The reduced
  // method, which re-solves the equilibria by Newton with an energy line
  // search at every step, recovers the design.
  expectClean(s, GetParam(), GetParam() == Method::Reduced);
}

TEST_P(Instability, SnappedArchTargets) {
  Scene s = arch(0.0012);
  // The premise: the hidden design snaps through, the initial one does not.
  ASSERT_LT(crownHeight(s, 0.8), 0.0);
  ASSERT_GT(crownHeight(s, 1.0), 0.0);
  testutil::setScaledRadiiTargets(s, 0.8);
  expectClean(s, GetParam(), true);
}

INSTANTIATE_TEST_SUITE_P(Methods, Instability, testing::Values(Method::Sand, Method::Reduced),
                         [](const testing::TestParamInfo<Method>& i) {
                           return i.param == Method::Sand ? "sand" : "reduced";
                         });

}  // namespace
}  // namespace rodmesh
