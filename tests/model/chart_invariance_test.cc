// The energy depends on the material frames only, not on the reference-frame
// charts that parameterize them (model/pose_system.hh, "Charts"): turning an
// edge's chart director about its chart tangent by phi and lowering its twist
// unknown by phi leaves every material frame, and so the energy and the
// forces, unchanged, for any phi. Angles near pi are where the twist of a
// clamp, a connection or an edge pair is the sum of a twist unknown and a
// reference angle each close to +-pi (a sheet folded over its clamp after
// its charts were re-anchored): taking the two parts modulo 2 pi separately
// made the energy jump there, and Newton lost the loading path of such
// sheets at positive stiffness (benchmarks/sweep2: a clamped hex sheet
// compressed in plane by 0.1 N, 85 times its buckling load).
#include "model/energies/rod_math.hh"
#include "model/scene_model.hh"
#include "tests/testutil/design_problems.hh"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <random>

namespace rodmesh {
namespace {

constexpr double kPi = 3.14159265358979323846;

// `s` with edge e's chart director turned by phi[e] about its chart tangent
// and its twist unknown lowered by phi[e]: the same material frames.
PoseState turnedCharts(const PoseSystem& sys, const PoseState& s, const std::vector<double>& phi) {
  PoseState t = s;
  for (std::size_t e = 0; e < phi.size(); ++e) {
    const Vec3 axis = t.charts.tangent[e].normalized();
    t.charts.director[e] = Eigen::AngleAxisd(phi[e], axis) * t.charts.director[e];
    t.u[sys.thetaDof(static_cast<int>(e))] -= phi[e];
  }
  return t;
}

TEST(ChartInvariance, TurningAChartAndItsTwistUnknownTogetherChangesNothingAtAnyAngle) {
  // Three rods meeting at a connection, one split at a two-rod connection, a
  // clamp, twist in 3D (tests/testutil/design_problems.hh).
  const Scene scene = testutil::designNetwork(false);
  SceneModel model(scene);
  const PoseSystem& sys = model.pose(0);
  ASSERT_TRUE(sys.hasTwist());
  ASSERT_GT(model.network().numConnections(), 0);
  const Design d = Design::fromScene(scene);
  // A generic state: positions off rest by up to a tenth of an edge, twists
  // up to 0.3 rad.
  PoseState s = sys.withRestCharts(sys.restDofs(d), d);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const double h = 0.01;
  for (int i = 0; i < sys.numDofs(); ++i) s.u[i] += i >= sys.numVertexDofs() ? 0.3 * U(rng) : 0.1 * h * U(rng);
  Eigen::VectorXd g0;
  const double E0 = sys.evaluate(s, d, &g0, nullptr);
  ASSERT_GT(E0, 0.0);
  const int edges = model.network().numEdges();
  // Every edge turned alike, and every other edge only (so that edge pairs
  // and a connection's edges differ in their reference angles by phi), for
  // angles on both sides of pi.
  for (double phi : {0.5, 3.0, kPi - 1e-3, kPi + 1e-3, 3.3, 5.0, -3.3}) {
    for (int pattern = 0; pattern < 2; ++pattern) {
      std::vector<double> turn(edges);
      for (int e = 0; e < edges; ++e) turn[e] = pattern == 0 || e % 2 == 0 ? phi : 0.0;
      Eigen::VectorXd g;
      const double E = sys.evaluate(turnedCharts(sys, s, turn), d, &g, nullptr);
      EXPECT_NEAR(E, E0, 1e-10 * E0) << "phi " << phi << ", pattern " << pattern;
      EXPECT_LT((g - g0).lpNorm<Eigen::Infinity>(), 1e-8 * g0.lpNorm<Eigen::Infinity>())
          << "phi " << phi << ", pattern " << pattern;
    }
  }
}

// wrapAngle (model/energies/rod_math.hh) shifts by one multiple of 2 pi: an
// angle in (-pi, pi] is returned unchanged, any other lands in (-pi, pi] at
// the angle's own rounding error, derivatives pass through, and a
// non-finite angle stays non-finite. It used to step by 2 pi at a time:
// 1e17 rad (where 1e17 - 2 pi == 1e17) or an infinite angle never returned.
TEST(ChartInvariance, WrappingAnAngleIsOneShiftWhateverTheAngle) {
  for (double x : {0.0, 1.0, -1.0, kPi, -kPi + 1e-15, 3.0, -3.0}) EXPECT_EQ(wrapAngle(x), x) << x;
  EXPECT_DOUBLE_EQ(wrapAngle(-kPi), kPi);
  for (double x : {0.3, -2.9, 3.1}) {
    for (double k : {1.0, -1.0, 2.0, 7.0, -1e3, 1e6, 1e9, -1e12}) {
      const double a = x + 2 * kPi * k;
      const double w = wrapAngle(a);
      EXPECT_GT(w, -kPi) << a;
      EXPECT_LE(w, kPi) << a;
      EXPECT_NEAR(w, x, 8 * std::numeric_limits<double>::epsilon() * std::abs(a)) << "x " << x << ", k " << k;
    }
  }
  for (double a : {1e17, -1e17, 1e300, -1e300, std::numeric_limits<double>::max()}) {
    const double w = wrapAngle(a);
    EXPECT_GT(w, -kPi) << a;
    EXPECT_LE(w, kPi) << a;
  }
  EXPECT_FALSE(std::isfinite(wrapAngle(std::numeric_limits<double>::infinity())));
  EXPECT_FALSE(std::isfinite(wrapAngle(-std::numeric_limits<double>::infinity())));
  EXPECT_TRUE(std::isnan(wrapAngle(std::numeric_limits<double>::quiet_NaN())));
  // Derivatives pass through a wrap of any size.
  ad::Hess<2> t = ad::Hess<2>::variable(0.4 + 2 * kPi * 1e5, 0);
  t = t * t;  // value about 3.9e11, gradient 2 t in slot 0, Hessian 2
  const ad::Hess<2> w = wrapAngle(t);
  EXPECT_GT(w.v, -kPi);
  EXPECT_LE(w.v, kPi);
  EXPECT_EQ(w.g[0], t.g[0]);
  EXPECT_EQ(w.g[1], 0.0);
  EXPECT_EQ(w.hess(0, 0), 2.0);
}

// A solver's trial step can put a twist unknown many turns away, or
// anywhere: the energy is that of the twist modulo 2 pi, and it is evaluated
// at once (the twists of edge pairs, clamps and connections are wrapped as a
// whole, twist unknowns included).
TEST(ChartInvariance, ATwistUnknownTurnsAwayGivesTheSameEnergyAndAnyTwistIsEvaluated) {
  const Scene scene = testutil::designNetwork(false);
  SceneModel model(scene);
  const PoseSystem& sys = model.pose(0);
  const Design d = Design::fromScene(scene);
  PoseState s = sys.withRestCharts(sys.restDofs(d), d);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (int i = 0; i < sys.numDofs(); ++i) s.u[i] += i >= sys.numVertexDofs() ? 0.3 * U(rng) : 1e-4 * U(rng);
  const double E0 = sys.evaluate(s, d, nullptr, nullptr);
  ASSERT_GT(E0, 0.0);
  const int edges = model.network().numEdges();
  for (double k : {1.0, -3.0, 1e4}) {
    PoseState t = s;
    for (int e = 0; e < edges; e += 2) t.u[sys.thetaDof(e)] += 2 * kPi * k;
    EXPECT_NEAR(sys.evaluate(t, d, nullptr, nullptr), E0, 1e-8 * E0) << "k " << k;
  }
  for (double th : {1e17, -1e300}) {
    PoseState t = s;
    t.u[sys.thetaDof(edges / 2)] = th;
    Eigen::VectorXd g;
    const double E = sys.evaluate(t, d, &g, nullptr);
    EXPECT_TRUE(std::isfinite(E)) << th;
    EXPECT_TRUE(g.allFinite()) << th;
  }
  PoseState t = s;
  t.u[sys.thetaDof(edges / 2)] = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(std::isfinite(sys.evaluate(t, d, nullptr, nullptr)));
}

}  // namespace
}  // namespace rodmesh
