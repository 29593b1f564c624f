// solver/stability.*: the out-of-plane stability check of in-plane equilibria
// against the smallest eigenvalue of the full 3D Hessian (dense, computed
// here independently), on a flat cantilever around its lateral-torsional
// buckling load and on a planar network with connections; and the grouped
// minimum-degree order it factorizes in.
#include "solver/equilibrium.hh"
#include "solver/stability.hh"
#include "tests/testutil/scenes.hh"

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace rodmesh {
namespace {

// Smallest eigenvalue of the full 3D model's Hessian at the planar state,
// diagonally scaled, relative to the largest in magnitude.
double relativeSmallestEigenvalue(const Scene& s, const SceneModel& planar, const std::vector<Vec3>& x) {
  const PoseSystem sys(s, planar.network(), spatialVariant(planar.effects()), 0);
  const Design d = Design::fromScene(s);
  Eigen::VectorXd g;
  Eigen::SparseMatrix<double> Hs;
  sys.evaluate(sys.withRestCharts(sys.dofsFrom(x, Eigen::VectorXd::Zero(planar.network().numEdges())), d), d, &g, &Hs);
  Eigen::MatrixXd H = Eigen::MatrixXd(Hs).selfadjointView<Eigen::Lower>();
  // Symmetric diagonal scaling (same inertia, Sylvester's law): stretching
  // is far stiffer than bending and twisting, unscaled the relevant
  // eigenvalues would drown in the largest.
  const Eigen::VectorXd scale = H.diagonal().cwiseAbs().cwiseSqrt().cwiseInverse();
  H = scale.asDiagonal() * H * scale.asDiagonal();
  const Eigen::VectorXd lambda =
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(H, Eigen::EigenvaluesOnly).eigenvalues();
  return lambda.minCoeff() / lambda.cwiseAbs().maxCoeff();
}

// Solves the (planar) scene and compares the check with the eigenvalues;
// returns the check's verdict.
bool checkAgainstEigenvalues(const Scene& s) {
  SceneModel model(s);
  EXPECT_TRUE(model.effects().planar);
  const SimulationResult r = simulateAll(model, Design::fromScene(s), NewtonOptions{});
  EXPECT_TRUE(r.allConverged);
  EXPECT_TRUE(r.poses[0].outOfPlaneStable.has_value());
  const bool stable = r.poses[0].outOfPlaneStable.value_or(true);
  const double lambda = relativeSmallestEigenvalue(s, model, r.poses[0].positions);
  // Clear-cut cases only: the check's pivot tolerance is 1e-8 of the largest pivot.
  EXPECT_GT(std::abs(lambda), 1e-7) << "the case is too close to neutral to decide";
  EXPECT_EQ(stable, lambda > 0) << "smallest eigenvalue / largest: " << lambda;
  return stable;
}

// A cantilever of 21 vertices, wide in the plane (r_t = 2 r_n), loaded at the
// tip in its plane about its stiff axis by `factor` times the continuum
// lateral-torsional buckling load P_cr = 4.013 sqrt(E I_weak G J) / L^2.
Scene flatCantilever(double factor) {
  Scene s = testutil::cantilever(20, 0.1, 0.002, 0.001, Vec3(0, 0, 1));
  const double E = s.material.youngModulus, G = s.material.shearModulus(), rt = 0.002, rn = 0.001, L = 0.1;
  const double pi = 3.14159265358979;
  const double Iweak = pi * rt * rn * rn * rn / 4;
  const double J = pi * rt * rt * rt * rn * rn * rn / (rt * rt + rn * rn);
  const double Pcr = 4.013 * std::sqrt(E * Iweak * G * J) / (L * L);
  s.poses[0].forces.push_back({20, Vec3(0, -factor * Pcr, 0)});
  return s;
}

TEST(OutOfPlaneStability, AgreesWithTheEigenvaluesAroundLateralTorsionalBuckling) {
  std::vector<bool> verdicts;
  for (double factor : {0.3, 1.0, 1.8, 2.0, 3.0}) {
    SCOPED_TRACE(factor);
    verdicts.push_back(checkAgainstEigenvalues(flatCantilever(factor)));
  }
  // The discrete model (20 edges, finite in-plane deflection) buckles
  // between 1.8 and 2.0 times the continuum load: both sides are covered.
  EXPECT_TRUE(verdicts[2]) << "1.8 P_cr: stable";
  EXPECT_FALSE(verdicts[3]) << "2.0 P_cr: a saddle";
}

TEST(OutOfPlaneStability, AgreesWithTheEigenvaluesOnANetworkWithConnections) {
  // The planar star network with flat sections, clamped at the ends of two
  // arms, the third arm's end pulled sideways in the plane, light and hard.
  for (double load : {0.002, 2.0}) {
    SCOPED_TRACE(load);
    testutil::StarNetworkOptions o;
    o.radiusBase = Vec2(0.002, 0.0005);
    o.radiusStep = Vec2(0.0, 0.0);
    Scene s = testutil::starNetwork(o);
    s.gravity.reset();
    s.normals.assign(s.vertices.size(), Vec3(0, 0, 1));
    Pose p;
    p.name = "p";
    p.clamped = {{6}, {9}};
    p.forces.push_back({3, Vec3(0.0, load, 0.0)});
    s.poses.push_back(p);
    checkAgainstEigenvalues(s);
  }
}

TEST(GroupedMinimumDegreeOrder, IsAPermutationKeepingEachGroupTogetherInItsOrder) {
  // A star: group 0 (one unknown) coupled to 29 groups of 1 to 3 unknowns,
  // which are coupled only within themselves.
  std::vector<int> group;
  for (int g = 0; g < 30; ++g)
    for (int k = 0; k < 1 + g % 3; ++k) group.push_back(g);
  const int n = static_cast<int>(group.size());
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j <= i; ++j)
      if (group[i] == group[j] || group[j] == 0) t.emplace_back(i, j, 1.0);
  Eigen::SparseMatrix<double> A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  const std::vector<int> order = groupedMinimumDegreeOrder(A, group, 30);
  ASSERT_EQ(static_cast<int>(order.size()), n);
  std::vector<int> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  for (int i = 0; i < n; ++i) ASSERT_EQ(sorted[i], i) << "not a permutation";
  for (int i = 1; i < n; ++i) {
    if (group[i] == group[i - 1]) {
      EXPECT_EQ(order[i], order[i - 1] + 1) << "group " << group[i] << " split or reordered";
    }
  }
  // Minimum degree eliminates the hub (degree 29) after the leaves (degree
  // 1), at worst tied with the last leaf: no fill.
  EXPECT_GE(order[0], n - 4);
  EXPECT_THROW(groupedMinimumDegreeOrder(A, std::vector<int>(n - 1, 0), 1), std::invalid_argument);
}

}  // namespace
}  // namespace rodmesh
