// The linear algebra shared by the static (solver/newton.*) and dynamic
// (solver/dynamics.*) Newton solvers: a sparse LDL^T whose pivots are judged
// against their own rows' round-off, and estimates of the round-off floor of
// an assembled system.
//
// Pivots. The elimination computes D_k = A_kk - sum_j L_kj^2 D_j with an
// error of some eps times the diagonal entries it combines. A pivot within
// kPivotRoundoff eps of s_k, the largest diagonal entry among its row's
// neighbours but at most kOwnDiagonal times the row's own, is a
// zero-stiffness mode; below minus that it is negative curvature. Measured:
// the rigid-body pivots of free quad and triangle grids, of the free Sheet
// and of the free sphere come out within 50 eps of the neighbours' largest
// diagonal entry and within 4,400 eps of their own, either sign; the tip
// pivot of a thin rod (r = 1e-5 m) on a thick one (r = 1e-2 m) is 2.4e-9 N/m,
// ~1e-3 of its own diagonal entry but 3e-15 of its thick neighbour's, hence
// the cap by the row's own entry.
// The threshold is local, never relative to the largest pivot overall: a
// long cantilever's tip pivot is ~1e-12 of its stiffest one at 10,000
// vertices (it stays above this threshold up to ~50,000 vertices), and a
// floor at 1e-10 of the largest pivot turned Newton into a crawl there.
// Nor is A regularised: the smallest eigenvalue of a 5,000-vertex
// cantilever's Hessian is itself only ~15 eps of its largest diagonal entry,
// so even a shift of 100 eps |A_kk| would swamp the tip mode. Only when the
// elimination meets an exactly zero pivot (a rod free to swing about a pin)
// is the diagonal raised by the round-off level and the matrix factorized
// again.
//
// Modified solves use L |D|' L^T: negative pivots replaced by |D_k| (a descent
// direction with the matrix's own scaling), zero-stiffness ones floored at
// their round-off level (the caller limits the step: a trust radius).
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <vector>

namespace rodmesh {

class PoseSystem;

constexpr double kPivotRoundoff = 1e3;
constexpr double kOwnDiagonal = 100.0;

class ModifiedLdlt {
 public:
  // Factorizes A (lower triangle, full diagonal in its pattern; the pattern
  // must stay the same between calls). False if even the factorization of
  // the round-off-raised matrix failed or produced non-finite pivots.
  bool factorize(const Eigen::SparseMatrix<double>& A);
  // Factorizes A + diag(shift) and requires every pivot to be positive (no
  // classification): the last resort of a caller when factorize fails.
  bool factorizeShifted(const Eigen::SparseMatrix<double>& A, const Eigen::VectorXd& shift);

  int negative() const { return negative_; }
  int singular() const { return singular_; }
  bool modified() const { return negative_ > 0 || singular_ > 0; }
  int factorizations() const { return factorizations_; }

  // (L |D|' L^T)^-1 b.
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const;
  // (L D L^T)^-1 b with the pivots as factorized (of the round-off-raised
  // matrix when the elimination met an exactly zero pivot): the inverse of
  // the matrix itself, for inverse iteration.
  Eigen::VectorXd solveUnmodified(const Eigen::VectorXd& b) const;
  // b^T (L |D|' L^T)^-1 b over the pivots that carry stiffness (zero-stiffness
  // modes left out): the Newton decrement of a gradient b.
  double stiffDecrement(const Eigen::VectorXd& b) const;
  // z = P^T L^-T e_k for the most negative pivot k (z^T A z = D_k < 0);
  // empty when there is no negative pivot.
  Eigen::VectorXd negativeCurvatureDirection() const;

 private:
  using Ldlt = Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>>;
  Ldlt ldlt_;
  Eigen::SparseMatrix<double> work_;
  std::vector<int> diagSlot_;
  bool analysed_ = false;
  Eigen::VectorXd Dmod_;
  std::vector<char> stiff_;  // per pivot: carries stiffness (not a zero-stiffness mode)
  int negative_ = 0, singular_ = 0, worst_ = -1;
  int factorizations_ = 0;
  bool prepare(const Eigen::SparseMatrix<double>& A);
};

// Round-off of an assembled system with unknowns u (PoseSystem layout).
namespace roundoff {
// Per-unknown resolution scale a_i = |u_i| + s_i: s_i the mean edge length
// for a coordinate (the rounding of an edge vector inside the kernels), 1 rad
// for a twist (frame transports are computed to eps in angle).
Eigen::VectorXd unknownScale(const PoseSystem& system, const Eigen::VectorXd& u);
// rho_i = eps sqrt(sum_j A_ij^2 a_j^2) from the lower triangle of A: the
// root-mean-square residual that rounding every unknown u_j by eps a_j
// produces (gradient units: N for coordinates, N m for twists).
Eigen::VectorXd residualFloor(const Eigen::SparseMatrix<double>& A, const Eigen::VectorXd& a);
// eps^2 sum_ij |A_ij| a_i a_j: the energy of rounding every unknown, i.e. the
// Newton decrement that round-off alone can produce.
double energyFloor(const Eigen::SparseMatrix<double>& A, const Eigen::VectorXd& a);
}  // namespace roundoff

}  // namespace rodmesh
