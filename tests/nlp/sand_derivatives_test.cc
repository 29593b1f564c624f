// SAND's nonlinear program: exact derivatives. Taylor tests of the
// objective gradient, the constraint Jacobian and the Hessian of the
// Lagrangian (against the Jacobian's own finite differences) on a network
// with connections, gravity, anisotropic sections, twist, a clamp, a vertex
// held at rest and one at an explicit position, radii and rest shape free;
// 3D and planar. Then Ipopt's own second-order derivative checker on the
// same problem, through the optimizer.
#include "model/design_space.hh"
#include "nlp/sand.hh"
#include "nlp/sand_nlp.hh"
#include "tests/testutil/design_problems.hh"
#include "tests/testutil/taylor.hh"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

namespace rodmesh {
namespace {

using Sparse = Eigen::SparseMatrix<double>;

Sparse fromTriplets(int rows, int cols, const std::vector<int>& r, const std::vector<int>& c, const double* v) {
  std::vector<Eigen::Triplet<double>> t;
  for (std::size_t i = 0; i < r.size(); ++i) t.emplace_back(r[i], c[i], v[i]);
  Sparse m(rows, cols);
  m.setFromTriplets(t.begin(), t.end());
  return m;
}

struct Fixture {
  Scene scene;
  std::unique_ptr<SceneModel> model;
  std::unique_ptr<DesignSpace> space;
  std::unique_ptr<TargetObjective> objective;
  std::unique_ptr<SandNlp> nlp;
};

// The SAND problem at the equilibria of the scene's design, joint phase.
std::unique_ptr<Fixture> makeProblem(bool planar, const DesignPhase* phaseIn = nullptr) {
  auto f = std::make_unique<Fixture>();
  f->scene = testutil::designNetwork(planar);
  f->model = std::make_unique<SceneModel>(f->scene);
  f->space = std::make_unique<DesignSpace>(f->scene, f->model->effects());
  f->objective = std::make_unique<TargetObjective>(f->scene, f->model->effects());
  const DesignPhase phase = phaseIn ? *phaseIn : DesignPhase{true, true, f->space->numLevels() - 1};
  const ControlValues c0 = f->space->initialControls(f->scene);
  const Design d0 = f->space->toDesign(c0);
  std::vector<PoseState> states;
  SandScaling sc;
  sc.objective = 1e-6;
  for (int k = 0; k < f->model->numPoses(); ++k) {
    const PoseSystem& sys = f->model->pose(k);
    PoseState s = sys.restState(d0);
    const NewtonReport r = solveEquilibrium(sys, d0, s, NewtonOptions{});
    EXPECT_TRUE(r.converged()) << r.message;
    states.push_back(s);
    sc.load.push_back(loadScale(sys, d0));
  }
  sc.variable = designVariableScale(*f->space, phase, f->scene);
  f->nlp = std::make_unique<SandNlp>(*f->model, *f->space, *f->objective, phase, c0, states, sc, 1);
  return f;
}

// A point near the starting one (off equilibrium) and a direction.
void pointAndDirection(SandNlp& nlp, unsigned seed, Eigen::VectorXd& x, Eigen::VectorXd& d) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  x = nlp.startingPoint();
  d.resize(x.size());
  for (int i = 0; i < x.size(); ++i) {
    const bool design = i >= nlp.designOffset();
    // positions in m (~1e-4), twists in rad, design values scaled O(1).
    const double s = design ? 0.05 : 2e-4;
    x[i] += s * U(rng);
    d[i] = s * U(rng);
  }
}

class SandDerivatives : public testing::TestWithParam<bool> {};

TEST_P(SandDerivatives, ObjectiveGradientPassesTaylor) {
  auto f = makeProblem(GetParam());
  SandNlp& nlp = *f->nlp;
  Eigen::VectorXd x, d;
  pointAndDirection(nlp, 1, x, d);
  Eigen::VectorXd g(nlp.numVariables());
  ASSERT_TRUE(nlp.gradient(x.data(), g.data()));
  auto F = [&](const Eigen::VectorXd& y) {
    double v = 0.0;
    EXPECT_TRUE(nlp.objective(y.data(), v));
    return v;
  };
  EXPECT_TAYLOR_ORDER(testutil::taylorTestScalar(F, x, d, g.dot(d), 1.0), 1.9);
  // The design part alone (the rest shape moves the held vertices).
  Eigen::VectorXd dz = Eigen::VectorXd::Zero(d.size());
  dz.tail(d.size() - nlp.designOffset()) = d.tail(d.size() - nlp.designOffset());
  EXPECT_TAYLOR_ORDER(testutil::taylorTestScalar(F, x, dz, g.dot(dz), 1.0), 1.9);
}

TEST_P(SandDerivatives, ConstraintJacobianPassesTaylor) {
  auto f = makeProblem(GetParam());
  SandNlp& nlp = *f->nlp;
  Eigen::VectorXd x, d;
  pointAndDirection(nlp, 2, x, d);
  std::vector<double> vals(nlp.jacobianNonZeros());
  ASSERT_TRUE(nlp.jacobian(x.data(), vals.data()));
  const Sparse J = fromTriplets(nlp.numConstraints(), nlp.numVariables(), nlp.jacobianRows(), nlp.jacobianCols(),
                                vals.data());
  auto C = [&](const Eigen::VectorXd& y) {
    Eigen::VectorXd c(nlp.numConstraints());
    EXPECT_TRUE(nlp.constraints(y.data(), c.data()));
    return c;
  };
  EXPECT_TAYLOR_ORDER(testutil::taylorTest(C, x, d, J * d, 1.0), 1.9);
  Eigen::VectorXd dz = Eigen::VectorXd::Zero(d.size());
  dz.tail(d.size() - nlp.designOffset()) = d.tail(d.size() - nlp.designOffset());
  EXPECT_TAYLOR_ORDER(testutil::taylorTest(C, x, dz, J * dz, 1.0), 1.9);
}

TEST_P(SandDerivatives, LagrangianHessianPassesTaylorAgainstTheJacobian) {
  auto f = makeProblem(GetParam());
  SandNlp& nlp = *f->nlp;
  Eigen::VectorXd x, d;
  pointAndDirection(nlp, 3, x, d);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  Eigen::VectorXd lambda(nlp.numConstraints());
  for (int i = 0; i < lambda.size(); ++i) lambda[i] = U(rng);
  const double sigma = 0.7;
  // Structure: lower triangle only.
  for (int i = 0; i < nlp.hessianNonZeros(); ++i) ASSERT_GE(nlp.hessianRows()[i], nlp.hessianCols()[i]);
  std::vector<double> hv(nlp.hessianNonZeros());
  ASSERT_TRUE(nlp.hessian(x.data(), sigma, lambda.data(), hv.data()));
  const Sparse L = fromTriplets(nlp.numVariables(), nlp.numVariables(), nlp.hessianRows(), nlp.hessianCols(), hv.data());
  const Sparse H = L.selfadjointView<Eigen::Lower>();
  // Gradient of the Lagrangian from the gradient and the Jacobian.
  auto G = [&](const Eigen::VectorXd& y) {
    Eigen::VectorXd g(nlp.numVariables());
    EXPECT_TRUE(nlp.gradient(y.data(), g.data()));
    std::vector<double> jv(nlp.jacobianNonZeros());
    EXPECT_TRUE(nlp.jacobian(y.data(), jv.data()));
    const Sparse J = fromTriplets(nlp.numConstraints(), nlp.numVariables(), nlp.jacobianRows(), nlp.jacobianCols(),
                                  jv.data());
    return Eigen::VectorXd(sigma * g + J.transpose() * lambda);
  };
  EXPECT_TAYLOR_ORDER(testutil::taylorTest(G, x, d, H * d, 1.0), 1.9);
  Eigen::VectorXd dz = Eigen::VectorXd::Zero(d.size());
  dz.tail(d.size() - nlp.designOffset()) = d.tail(d.size() - nlp.designOffset());
  EXPECT_TAYLOR_ORDER(testutil::taylorTest(G, x, dz, H * dz, 1.0), 1.9);
  Eigen::VectorXd du = d - dz;
  EXPECT_TAYLOR_ORDER(testutil::taylorTest(G, x, du, H * du, 1.0), 1.9);
}

// Entry by entry: every column of the Jacobian and of the Lagrangian's
// Hessian against central differences (truncation O(h^2)), relative to the
// column's largest entry.
TEST_P(SandDerivatives, EveryEntryMatchesCentralDifferences) {
  auto f = makeProblem(GetParam());
  SandNlp& nlp = *f->nlp;
  Eigen::VectorXd x, d;
  pointAndDirection(nlp, 5, x, d);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  Eigen::VectorXd lambda(nlp.numConstraints());
  for (int i = 0; i < lambda.size(); ++i) lambda[i] = U(rng);
  const double sigma = 1.3;
  std::vector<double> jv(nlp.jacobianNonZeros()), hv(nlp.hessianNonZeros());
  ASSERT_TRUE(nlp.jacobian(x.data(), jv.data()));
  ASSERT_TRUE(nlp.hessian(x.data(), sigma, lambda.data(), hv.data()));
  const Sparse J = fromTriplets(nlp.numConstraints(), nlp.numVariables(), nlp.jacobianRows(), nlp.jacobianCols(),
                                jv.data());
  const Sparse L = fromTriplets(nlp.numVariables(), nlp.numVariables(), nlp.hessianRows(), nlp.hessianCols(), hv.data());
  const Sparse H = L.selfadjointView<Eigen::Lower>();
  auto C = [&](const Eigen::VectorXd& y) {
    Eigen::VectorXd c(nlp.numConstraints());
    EXPECT_TRUE(nlp.constraints(y.data(), c.data()));
    return c;
  };
  auto G = [&](const Eigen::VectorXd& y) {
    Eigen::VectorXd g(nlp.numVariables());
    EXPECT_TRUE(nlp.gradient(y.data(), g.data()));
    std::vector<double> v(nlp.jacobianNonZeros());
    EXPECT_TRUE(nlp.jacobian(y.data(), v.data()));
    const Sparse Jy = fromTriplets(nlp.numConstraints(), nlp.numVariables(), nlp.jacobianRows(), nlp.jacobianCols(),
                                   v.data());
    return Eigen::VectorXd(sigma * g + Jy.transpose() * lambda);
  };
  // Steps by the variable's unit: positions in m (1e-6), twists in rad and
  // the scaled design values, both O(1) (1e-4; at 1e-6 rad a twist column's
  // differences are round-off, their error growing as the step shrinks).
  std::vector<char> twist(static_cast<std::size_t>(nlp.numVariables()), 0);
  for (int k = 0; k < nlp.numPoses(); ++k) {
    const PoseSystem& sys = f->model->pose(k);
    for (int i = sys.numVertexDofs(); i < sys.numDofs(); ++i) twist[static_cast<std::size_t>(nlp.poseOffset(k) + i)] = 1;
  }
  double worstJ = 0.0, worstH = 0.0;
  int worstJcol = -1, worstHcol = -1;
  for (int j = 0; j < nlp.numVariables(); ++j) {
    const double h = j >= nlp.designOffset() || twist[static_cast<std::size_t>(j)] ? 1e-4 : 1e-6;
    Eigen::VectorXd xp = x, xm = x;
    xp[j] += h;
    xm[j] -= h;
    const Eigen::VectorXd fdJ = (C(xp) - C(xm)) / (2 * h), fdH = (G(xp) - G(xm)) / (2 * h);
    const Eigen::VectorXd cj = J.col(j), ch = H.col(j);
    const double sj = std::max(cj.lpNorm<Eigen::Infinity>(), fdJ.lpNorm<Eigen::Infinity>());
    const double sh = std::max(ch.lpNorm<Eigen::Infinity>(), fdH.lpNorm<Eigen::Infinity>());
    if (sj > 0 && (fdJ - cj).lpNorm<Eigen::Infinity>() / sj > worstJ) {
      worstJ = (fdJ - cj).lpNorm<Eigen::Infinity>() / sj;
      worstJcol = j;
    }
    if (sh > 0 && (fdH - ch).lpNorm<Eigen::Infinity>() / sh > worstH) {
      worstH = (fdH - ch).lpNorm<Eigen::Infinity>() / sh;
      worstHcol = j;
    }
  }
  EXPECT_LT(worstJ, 1e-6) << "Jacobian column " << worstJcol;
  EXPECT_LT(worstH, 1e-6) << "Hessian column " << worstHcol;
}

TEST_P(SandDerivatives, EvaluationsAreCachedConsistently) {
  // Constraint values from the simulation path (trial points) and from the
  // joint derivatives (after a Jacobian) agree.
  auto f = makeProblem(GetParam());
  SandNlp& nlp = *f->nlp;
  Eigen::VectorXd x, d;
  pointAndDirection(nlp, 4, x, d);
  Eigen::VectorXd c1(nlp.numConstraints()), c2(nlp.numConstraints());
  ASSERT_TRUE(nlp.constraints(x.data(), c1.data()));
  std::vector<double> jv(nlp.jacobianNonZeros());
  ASSERT_TRUE(nlp.jacobian(x.data(), jv.data()));
  ASSERT_TRUE(nlp.constraints(x.data(), c2.data()));
  ASSERT_GT(c1.norm(), 0.0);
  EXPECT_LE((c1 - c2).norm(), 1e-10 * c1.norm());
}

INSTANTIATE_TEST_SUITE_P(Dimensions, SandDerivatives, testing::Values(false, true),
                         [](const testing::TestParamInfo<bool>& i) { return i.param ? "planar" : "spatial"; });

// Ipopt's derivative checker (second order) on the full SAND problem (3D:
// twist, connections, gravity, clamp, held vertices, radii and rest shape):
// every Jacobian and Hessian-of-the-Lagrangian entry against Ipopt's own
// forward differences, through the optimizer's TNLP, so that the wiring
// (index maps, lower triangle, multiplier order, scaling) is checked by a
// second party, at the point Ipopt starts from. Forward differences cannot
// resolve this problem to Ipopt's default 1e-4: over perturbations 1e-8 ...
// 1e-6 the largest relative discrepancy is smallest at 2e-8 (truncation
// the other way: 2.9e-2 at 1e-7). At h = 2e-8 a forward difference of
// Jacobian entries of O(1e6) carries a round-off of about
// 2 eps 1e6 / h = 1.1e-2 (eps = 1.1e-16), and the discrepancies measured are
// of that size and move with the compiler's rounding: 3.4e-3 with one build
// of the same source, 1.006e-2 with another (two second-derivative entries
// of 0.26 against 0.27). The tolerance is 3e-2, about three times that
// bound: the checker still finds a wrong multiplier order, a transposed
// block or a missing triangle (errors of O(1)), and
// EveryEntryMatchesCentralDifferences above checks every entry to 1e-6 with
// central differences.
TEST(SandIpopt, DerivativeCheckerReportsNoErrors) {
  for (bool planar : {false}) {
    const Scene scene = testutil::designNetwork(planar);
    SceneModel model(scene);
    const DesignSpace space(scene, model.effects());
    SandOptions o;
    o.optimizer.schedule = Schedule::Joint;
    o.optimizer.maxIterations = 1;
    o.warmupIterations = 0;  // Ipopt from the first iteration
    o.readOptionsFile = false;
    const std::string out =
        (std::filesystem::temp_directory_path() / ("rodmesh_dercheck_" + std::to_string(planar) + "_" +
                                                      std::to_string(::getpid()) + ".txt"))
            .string();
    o.ipopt = {{"derivative_test", "second-order"},
               {"derivative_test_perturbation", "2e-8"},
               {"derivative_test_tol", "3e-2"},
               // By default Ipopt checks at a point perturbed by up to 10 in
               // every variable: rods moved by metres.
               {"point_perturbation_radius", "0"},
               {"output_file", out},
               {"file_print_level", "5"}};
    const DesignOptimizerResult r = optimizeSand(model, space, o);
    std::ifstream in(out);
    ASSERT_TRUE(in.good()) << "Ipopt wrote no output file";
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string text = ss.str();
    std::remove(out.c_str());
    EXPECT_NE(text.find("Starting derivative checker for second derivatives"), std::string::npos) << text;
    EXPECT_NE(text.find("No errors detected by derivative checker"), std::string::npos)
        << (planar ? "planar: " : "spatial: ") << text.substr(0, 6000);
    EXPECT_NE(r.outcome, Outcome::InvalidProblem) << r.message;
  }
}

}  // namespace
}  // namespace rodmesh
