// Taylor tests: check that a claimed derivative is the derivative by watching
// the remainder of the first-order Taylor expansion fall at second order.
//
// For a map F and claimed directional derivative dF = F'(x) d, the remainder
//   r(h) = |F(x + h d) - F(x) - h dF|
// is O(h^2) if dF is right and O(h) if it is wrong. We sweep h over decades,
// estimate the local order log2(r(h) / r(h/2)) where r is well above the
// round-off floor, and report the median. The zeroth-order remainder
// |F(x + h d) - F(x)| is checked to be O(h) with a non-zero slope, so that a
// test cannot pass because F does not depend on x at all.
#pragma once

#include <Eigen/Core>
#include <gtest/gtest.h>

#include <functional>
#include <string>
#include <vector>

namespace rodmesh::testutil {

struct TaylorResult {
  double order = 0.0;          // median observed order of the first-order remainder
  int validPoints = 0;         // step pairs above the round-off floor
  double zerothOrder = 0.0;    // order of |F(x + h d) - F(x)| (should be about 1)
  double derivativeNorm = 0.0; // |dF|
  std::vector<double> steps, remainders;
  std::string table() const;   // steps and remainders for failure messages
};

using VectorFn = std::function<Eigen::VectorXd(const Eigen::VectorXd&)>;

// F: R^n -> R^m, x, direction d, claimed F'(x) d.
TaylorResult taylorTest(const VectorFn& F, const Eigen::VectorXd& x, const Eigen::VectorXd& d,
                        const Eigen::VectorXd& dF, double h0 = 1e-2, int sweeps = 14);

// Scalar convenience wrapper.
TaylorResult taylorTestScalar(const std::function<double(const Eigen::VectorXd&)>& f, const Eigen::VectorXd& x,
                              const Eigen::VectorXd& d, double df, double h0 = 1e-2, int sweeps = 14);

// Central finite differences of F along each coordinate; on failure, the
// component of a claimed Jacobian (m x n, given column by column through
// `claimedColumn`) that disagrees most: "row i, column j: claimed a, fd b".
std::string findBadComponent(const VectorFn& F, const Eigen::VectorXd& x,
                             const std::function<Eigen::VectorXd(int)>& claimedColumn, double h = 1e-6);

}  // namespace rodmesh::testutil

namespace rodmesh::testutil {
// Passes when the order is at least minOrder with at least 3 valid step pairs
// and a non-zero derivative (a zero derivative would make the test vacuous).
testing::AssertionResult taylorCheck(const TaylorResult& r, double minOrder);
}  // namespace rodmesh::testutil

#define EXPECT_TAYLOR_ORDER(result, minOrder) EXPECT_TRUE(::rodmesh::testutil::taylorCheck((result), (minOrder)))
