// Reduced Hessian-vector products (solver/reduced_hessian.hh) against the
// Taylor remainder of the reduced gradient, every probe re-solving every
// pose's equilibrium: radii, rest shape and both, 3D and planar, on the
// network of the gradient test (connections, gravity, twist, a clamp, a
// vertex held at rest and one at an explicit position). The Gauss-Newton
// product against J_q^T W J_q from finite differences of the re-solved
// positions, and its symmetry and sign.
#include "model/design_space.hh"
#include "solver/design_optimizer.hh"
#include "solver/reduced_hessian.hh"
#include "tests/testutil/design_problems.hh"
#include "tests/testutil/taylor.hh"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace rodmesh {
namespace {

struct Case {
  bool planar;
  bool radii, rest;
};

class ReducedHessianProduct : public testing::TestWithParam<Case> {
 protected:
  void SetUp() override {
    const Case c = GetParam();
    scene_ = testutil::designNetwork(c.planar);
    model_ = std::make_unique<SceneModel>(scene_);
    space_ = std::make_unique<DesignSpace>(scene_, model_->effects());
    objective_ = std::make_unique<TargetObjective>(scene_, model_->effects());
    phase_ = DesignPhase{c.radii, c.rest, space_->numLevels() - 1};
    base_ = space_->initialControls(scene_);
    newton_.tolerance = 1e-13;  // probes must resolve O(h^2) changes of the gradient
    const Design d0 = space_->toDesign(base_);
    std::vector<PoseState> warm;
    for (int p = 0; p < model_->numPoses(); ++p) warm.push_back(model_->pose(p).restState(d0));
    ro_ = std::make_unique<ReducedObjective>(*model_, *space_, *objective_, phase_, base_, newton_, 1, warm);
    z0_ = space_->pack(phase_, base_);
    double f0;
    Eigen::VectorXd g;
    ASSERT_TRUE(ro_->evaluate(z0_, f0, &g));
    ro_->accept(z0_);
    f0_ = f0;
    g0_ = g;
  }
  // Radii by 10% of their value, displacements by 0.3 mm.
  Eigen::VectorXd direction(unsigned seed) const {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    Eigen::VectorXd dz(z0_.size());
    const int nr = phase_.radii ? 2 * space_->numNodes(phase_.level) : 0;
    for (int i = 0; i < dz.size(); ++i) dz[i] = i < nr ? 0.1 * z0_[i] * U(rng) : 3e-4 * U(rng);
    return dz;
  }
  Scene scene_;
  std::unique_ptr<SceneModel> model_;
  std::unique_ptr<DesignSpace> space_;
  std::unique_ptr<TargetObjective> objective_;
  DesignPhase phase_;
  ControlValues base_;
  NewtonOptions newton_;
  std::unique_ptr<ReducedObjective> ro_;
  Eigen::VectorXd z0_, g0_;
  double f0_ = 0.0;
};

TEST_P(ReducedHessianProduct, MatchesTaylorRemainderOfTheResolvedGradient) {
  ReducedHessian rh(*model_, *space_, *objective_, phase_, 1);
  ASSERT_TRUE(rh.prepare(z0_, base_, ro_->warmStates()));
  // Its value and gradient are the reduced objective's.
  EXPECT_NEAR(rh.value(), f0_, 1e-12 * f0_);
  ASSERT_EQ(rh.gradient().size(), g0_.size());
  EXPECT_LE((rh.gradient() - g0_).norm(), 1e-9 * g0_.norm());
  const Eigen::VectorXd dz = direction(11);
  const Eigen::VectorXd Hv = rh.product(dz);
  auto grad = [&](const Eigen::VectorXd& z) {
    double f;
    Eigen::VectorXd g;
    EXPECT_TRUE(ro_->evaluate(z, f, &g));
    return g;
  };
  const auto r = testutil::taylorTest(grad, z0_, dz, Hv, 1.0, 10);
  EXPECT_TAYLOR_ORDER(r, 1.85) << r.table();
  // The Gauss-Newton product is not the Hessian here (the targets are not
  // met): its remainder is first order only.
  const auto rgn = testutil::taylorTest(grad, z0_, dz, rh.gaussNewtonProduct(dz), 1.0, 10);
  EXPECT_LT(rgn.order, 1.5) << rgn.table();
}

TEST_P(ReducedHessianProduct, IsSymmetric) {
  ReducedHessian rh(*model_, *space_, *objective_, phase_, 1);
  ASSERT_TRUE(rh.prepare(z0_, base_, ro_->warmStates()));
  const Eigen::VectorXd a = direction(3), b = direction(4);
  const double ab = a.dot(rh.product(b)), ba = b.dot(rh.product(a));
  EXPECT_NEAR(ab, ba, 1e-9 * std::max(std::abs(ab), 1e-300));
  const double gab = a.dot(rh.gaussNewtonProduct(b)), gba = b.dot(rh.gaussNewtonProduct(a));
  EXPECT_NEAR(gab, gba, 1e-9 * std::max(std::abs(gab), 1e-300));
}

// v^T (Gauss-Newton) v = sum_k w_k |dq_k/dz v|^2, dq/dz v by central
// differences of the positions re-solved at z0 +- h v.
TEST_P(ReducedHessianProduct, GaussNewtonIsTheSquaredPositionJacobian) {
  ReducedHessian rh(*model_, *space_, *objective_, phase_, 1);
  const std::vector<PoseState> states0 = ro_->warmStates();
  ASSERT_TRUE(rh.prepare(z0_, base_, states0));
  const Eigen::VectorXd v = direction(5);
  const double h = 1e-4;
  auto positions = [&](const Eigen::VectorXd& z) {
    const Design d = space_->toDesign(space_->unpack(phase_, z, base_));
    std::vector<std::vector<Vec3>> x;
    for (int k = 0; k < model_->numPoses(); ++k) {
      const PoseSystem& sys = model_->pose(k);
      PoseState st = states0[k];
      const NewtonReport rep = solveEquilibrium(sys, d, st, newton_);
      EXPECT_TRUE(rep.converged());
      x.push_back(sys.positions(st, d));
    }
    return x;
  };
  const auto xp = positions(z0_ + h * v), xm = positions(z0_ - h * v);
  double expected = 0.0;
  for (int k = 0; k < model_->numPoses(); ++k)
    for (std::size_t i = 0; i < xp[k].size(); ++i)
      expected += objective_->weight(k) * ((xp[k][i] - xm[k][i]) / (2 * h)).squaredNorm();
  const double got = v.dot(rh.gaussNewtonProduct(v));
  ASSERT_GT(expected, 0.0);
  EXPECT_NEAR(got, expected, 1e-5 * expected);
  // ... so it is never negative, where the exact Hessian may be.
  for (unsigned s = 20; s < 30; ++s) {
    const Eigen::VectorXd a = direction(s);
    EXPECT_GE(a.dot(rh.gaussNewtonProduct(a)), 0.0);
  }
}

std::string caseName(const testing::TestParamInfo<Case>& i) {
  std::string s = i.param.planar ? "planar_" : "spatial_";
  if (i.param.radii) s += "radii";
  if (i.param.radii && i.param.rest) s += "_";
  if (i.param.rest) s += "rest";
  return s;
}

INSTANTIATE_TEST_SUITE_P(Parameters, ReducedHessianProduct,
                         testing::Values(Case{false, true, false}, Case{false, false, true}, Case{false, true, true},
                                         Case{true, true, false}, Case{true, false, true}, Case{true, true, true}),
                         caseName);

}  // namespace
}  // namespace rodmesh
