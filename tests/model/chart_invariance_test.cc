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
#include "model/scene_model.hh"
#include "tests/testutil/design_problems.hh"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
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

}  // namespace
}  // namespace rodmesh
