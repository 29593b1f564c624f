// Taylor tests of the connection term at hard connections: two nearly
// collinear edges, a flat six-valent star, a stiffness ratio of 1000 between
// incident rods, and a connection rotated by nearly 180 degrees from rest
// (with reference-frame charts anchored at the rotated state).
#include "model/pose_system.hh"
#include "solver/equilibrium.hh"
#include "tests/testutil/scenes.hh"
#include "tests/testutil/taylor.hh"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

namespace rodmesh {
namespace {

using testutil::taylorTest;
using testutil::taylorTestScalar;

enum class Hard { NearlyCollinear, FlatStar6, StiffnessRatio1000, Rotated179 };

// A star: k rods of two edges each leaving vertex 0 at the given angles in
// the z = 0 plane (slightly curved), far ends fixed.
// Rod 0 is thicker by thickScale (stiffness ~ r^4).
Scene star(const std::vector<double>& angles, double thickScale) {
  std::vector<Vec3> dirs;
  for (double a : angles) dirs.push_back(Vec3(std::cos(a), std::sin(a), 0.0));
  return testutil::connectionStar(dirs, {thickScale});
}

Scene hardScene(Hard h) {
  constexpr double kPi = 3.14159265358979323846;
  switch (h) {
    case Hard::NearlyCollinear: return star({0.0, kPi - 1e-3}, 1.0);
    case Hard::FlatStar6: return star({0.0, kPi / 3, 2 * kPi / 3, kPi, 4 * kPi / 3, 5 * kPi / 3}, 1.0);
    case Hard::StiffnessRatio1000: return star({0.0, 2.1, 4.2}, std::pow(1000.0, 0.25));
    case Hard::Rotated179: return star({0.0, 2.1, 4.2}, 1.0);
  }
  return {};
}

const char* hardName(Hard h) {
  switch (h) {
    case Hard::NearlyCollinear: return "NearlyCollinear";
    case Hard::FlatStar6: return "FlatStar6";
    case Hard::StiffnessRatio1000: return "StiffnessRatio1000";
    case Hard::Rotated179: return "Rotated179";
  }
  return "?";
}

class HardConnection : public testing::TestWithParam<Hard> {
 protected:
  void SetUp() override {
    scene_ = hardScene(GetParam());
    model_ = std::make_unique<SceneModel>(scene_);
    design_ = Design::fromScene(scene_);
    const PoseSystem& sys = model_->pose(0);
    ASSERT_EQ(sys.termCount(PoseSystem::termKindIndex("connection")), 1);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    std::vector<Vec3> x = design_.restPositions;
    Eigen::VectorXd theta = Eigen::VectorXd::Zero(model_->network().numEdges());
    if (GetParam() == Hard::Rotated179) {
      // Rotate the free part of the star by 179 degrees about z around the
      // connection (the fixed far ends stay; the second edges of the rods are
      // strongly stretched, which does not matter for the derivatives).
      const Eigen::Matrix3d R = Eigen::AngleAxisd(179.0 * 3.14159265358979323846 / 180.0, Vec3::UnitZ()).toRotationMatrix();
      for (std::size_t v = 0; v < x.size(); ++v) x[v] = R * x[v];
    }
    for (Vec3& p : x) p += 0.0015 * Vec3(U(rng), U(rng), U(rng));
    for (int e = 0; e < theta.size(); ++e) theta[e] = 0.4 * U(rng);
    u_ = sys.dofsFrom(x, theta);
    state_ = sys.withRestCharts(u_, design_);
    if (GetParam() == Hard::Rotated179) {
      // Anchor every chart at the current frames, as the solver does.
      std::optional<PoseState> anchored = sys.reanchored(state_, design_, 2.0);
      ASSERT_TRUE(anchored.has_value());
      state_ = std::move(*anchored);
    }
    du_.resize(sys.numDofs());
    for (int i = 0; i < sys.numDofs(); ++i) du_[i] = i >= sys.numVertexDofs() ? 0.5 * U(rng) : 0.001 * U(rng);
    dp_.resize(design_.numParameters());
    const int nv = static_cast<int>(x.size());
    for (int v = 0; v < nv; ++v) {
      for (int c = 0; c < 3; ++c) dp_[Design::restIndex(v, c)] = 0.001 * U(rng);
      for (int c = 0; c < 2; ++c) dp_[design_.radiusIndex(v, c)] = 0.2 * design_.radii[v][c] * U(rng);
    }
  }
  const PoseSystem& sys() { return model_->pose(0); }
  // The state at unknowns u (the fixture's charts and load factor).
  PoseState at(const Eigen::VectorXd& u) const {
    PoseState s = state_;
    s.u = u;
    return s;
  }
  const PoseSystem::Terms kTerms = PoseSystem::Terms::named("connection");

  Scene scene_;
  std::unique_ptr<SceneModel> model_;
  Design design_;
  Eigen::VectorXd u_, du_, dp_;
  PoseState state_;
};

constexpr double kMinOrder = 1.85;

TEST_P(HardConnection, GradientHessianAndThirdOrder) {
  const PoseSystem& s = sys();
  Eigen::VectorXd g;
  Eigen::SparseMatrix<double> Hs;
  const double E = s.evaluate(state_, design_, &g, &Hs, kTerms);
  ASSERT_TRUE(std::isfinite(E));
  EXPECT_GT(E, 0.0) << "the perturbed connection must store energy";
  const Eigen::MatrixXd H = Eigen::MatrixXd(Hs).selfadjointView<Eigen::Lower>();
  auto energy = [&](const Eigen::VectorXd& u) { return s.energy(at(u), design_, kTerms); };
  auto gradient = [&](const Eigen::VectorXd& u) {
    Eigen::VectorXd gg;
    s.evaluate(at(u), design_, &gg, nullptr, kTerms);
    return gg;
  };
  EXPECT_TAYLOR_ORDER(taylorTestScalar(energy, u_, du_, g.dot(du_)), kMinOrder);
  EXPECT_TAYLOR_ORDER(taylorTest(gradient, u_, du_, H * du_), kMinOrder);

  // Third order: D_v of the Hessian (uu block) along v = du.
  auto huu = [&](const Eigen::VectorXd& u) {
    const JointDerivatives j = s.joint(at(u), design_, kTerms);
    Eigen::MatrixXd M(j.Huu);  // both triangles stored
    return Eigen::VectorXd(Eigen::Map<Eigen::VectorXd>(M.data(), M.size()));
  };
  const JointDerivatives dj = s.jointDirectional(state_, design_, du_, kTerms);
  Eigen::MatrixXd dH(dj.Huu);
  EXPECT_TAYLOR_ORDER(taylorTest(huu, u_, du_, Eigen::Map<Eigen::VectorXd>(dH.data(), dH.size())), kMinOrder);
}

TEST_P(HardConnection, DesignDerivatives) {
  const PoseSystem& s = sys();
  const int n = s.numDofs(), P = design_.numParameters();
  const JointDerivatives j = s.joint(state_, design_, kTerms);
  Eigen::MatrixXd Hup(j.Hup);
  ASSERT_EQ(Hup.rows(), n);
  ASSERT_EQ(Hup.cols(), P);
  const Eigen::VectorXd p0 = design_.toVector();
  auto designOf = [&](const Eigen::VectorXd& p) {
    Design d = design_;
    d.fromVector(p);
    return d;
  };
  auto energyP = [&](const Eigen::VectorXd& p) { return s.energy(state_, designOf(p), kTerms); };
  EXPECT_TAYLOR_ORDER(taylorTestScalar(energyP, p0, dp_, j.gp.dot(dp_)), kMinOrder);
  auto gradU = [&](const Eigen::VectorXd& p) {
    Eigen::VectorXd gg;
    s.evaluate(state_, designOf(p), &gg, nullptr, kTerms);
    return gg;
  };
  EXPECT_TAYLOR_ORDER(taylorTest(gradU, p0, dp_, Hup * dp_), kMinOrder);
}

INSTANTIATE_TEST_SUITE_P(Cases, HardConnection,
                         testing::Values(Hard::NearlyCollinear, Hard::FlatStar6, Hard::StiffnessRatio1000,
                                         Hard::Rotated179),
                         [](const testing::TestParamInfo<Hard>& i) { return std::string(hardName(i.param)); });

// A rigid rotation of a relaxed connection costs no connection energy: the
// best-fit rotation follows it exactly (charts anchored at the rotated frames).
TEST(ConnectionInvariance, RigidRotationCostsNothing) {
  for (double degrees : {30.0, 120.0, 179.0}) {
    Scene s = star({0.0, 2.1, 4.2}, 1.0);
    SceneModel model(s);
    const Design d = Design::fromScene(s);
    const PoseSystem& sys = model.pose(0);
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(degrees * 3.14159265358979323846 / 180.0, Vec3(0.3, -0.5, 1.0).normalized()).toRotationMatrix();
    std::vector<Vec3> x = d.restPositions;
    for (Vec3& p : x) p = R * p;
    // With charts anchored at the rotated rest frames, theta = 0 is the
    // rotated rest material frame.
    const PoseState rotated =
        sys.withRestCharts(sys.dofsFrom(x, Eigen::VectorXd::Zero(model.network().numEdges())), d);
    std::optional<PoseState> anchored = sys.reanchored(rotated, d, 2.0);
    ASSERT_TRUE(anchored.has_value());  // every edge gets a chart at its rotated frame
    PoseState state = std::move(*anchored);
    // Re-anchoring transports the rest director along the shortest arc, which
    // differs from the rigid rotation by a turn about the tangent; undo it
    // through theta so the material frames are the rotated rest frames.
    Eigen::VectorXd theta = Eigen::VectorXd::Zero(model.network().numEdges());
    for (int e = 0; e < theta.size(); ++e) {
      const EdgeFrame f = model.network().restFrame(e, d.restPositions);
      const Vec3 t = R * f.t, want = R * f.d1;
      const Vec3 ref = state.charts.director[e];
      theta[e] = std::atan2(ref.cross(want).dot(t), ref.dot(want));
    }
    state.u = sys.dofsFrom(x, theta);
    const double E = sys.energy(state, d, PoseSystem::Terms::named("connection"));
    EXPECT_LT(std::abs(E), 1e-20) << degrees << " degrees";
  }
}

}  // namespace
}  // namespace rodmesh
