#include "solver/modified_ldlt.hh"

#include <algorithm>
#include <cmath>
#include <limits>

#include "model/pose_system.hh"

namespace rodmesh {
namespace {
constexpr double kEps = std::numeric_limits<double>::epsilon();
}  // namespace

bool ModifiedLdlt::prepare(const Eigen::SparseMatrix<double>& A) {
  const int n = static_cast<int>(A.cols());
  if (!analysed_ || work_.cols() != n || work_.nonZeros() != A.nonZeros()) {
    work_ = A;
    diagSlot_.assign(n, -1);
    for (int c = 0; c < n; ++c)
      for (int k = work_.outerIndexPtr()[c]; k < work_.outerIndexPtr()[c + 1]; ++k)
        if (work_.innerIndexPtr()[k] == c) diagSlot_[c] = k;
    for (int c = 0; c < n; ++c)
      if (diagSlot_[c] < 0) return false;  // the pattern must hold the diagonal
    ldlt_.analyzePattern(work_);
    analysed_ = true;
  }
  std::copy(A.valuePtr(), A.valuePtr() + A.nonZeros(), work_.valuePtr());
  return true;
}

bool ModifiedLdlt::factorize(const Eigen::SparseMatrix<double>& A) {
  negative_ = singular_ = 0;
  worst_ = -1;
  const int n = static_cast<int>(A.cols());
  if (!prepare(A)) return false;
  // Round-off level of each row's pivot: kPivotRoundoff eps times the largest
  // diagonal entry among the row's neighbours, but at most kOwnDiagonal times
  // the row's own (a soft rod attached to a stiff one keeps its own scale).
  Eigen::VectorXd reg = Eigen::VectorXd::Zero(n);
  const double* v = work_.valuePtr();
  double maxDiag = 0.0;
  for (int c = 0; c < n; ++c) maxDiag = std::max(maxDiag, std::abs(v[diagSlot_[c]]));
  for (int c = 0; c < n; ++c)
    for (int k = work_.outerIndexPtr()[c]; k < work_.outerIndexPtr()[c + 1]; ++k) {
      const int r = work_.innerIndexPtr()[k];
      reg[r] = std::max(reg[r], std::abs(v[diagSlot_[c]]));
      reg[c] = std::max(reg[c], std::abs(v[diagSlot_[r]]));
    }
  for (int c = 0; c < n; ++c) {
    const double scale = std::min(reg[c], kOwnDiagonal * std::abs(v[diagSlot_[c]]));
    reg[c] = kPivotRoundoff * kEps * std::max(scale, kEps * maxDiag);
    if (!(reg[c] > 0)) reg[c] = std::numeric_limits<double>::min();
  }
  if (!reg.allFinite()) return false;
  ldlt_.factorize(work_);
  ++factorizations_;
  if (ldlt_.info() != Eigen::Success) {
    // An exactly zero pivot stops the elimination: raise the diagonal by its
    // round-off level and factorize again.
    for (int c = 0; c < n; ++c) work_.valuePtr()[diagSlot_[c]] += reg[c];
    ldlt_.factorize(work_);
    ++factorizations_;
  }
  const Eigen::VectorXd D = ldlt_.vectorD();
  if (ldlt_.info() != Eigen::Success || D.size() != n || !D.allFinite()) return false;
  const Eigen::VectorXd thr = 2.0 * (ldlt_.permutationP() * reg);
  Dmod_.resize(n);
  stiff_.assign(n, 1);
  for (int i = 0; i < n; ++i) {
    if (D[i] < -thr[i]) {
      ++negative_;
      if (worst_ < 0 || D[i] < D[worst_]) worst_ = i;
      Dmod_[i] = -D[i];
    } else if (D[i] <= thr[i]) {
      ++singular_;
      stiff_[i] = 0;
      Dmod_[i] = thr[i];
    } else {
      Dmod_[i] = D[i];
    }
  }
  return true;
}

bool ModifiedLdlt::factorizeShifted(const Eigen::SparseMatrix<double>& A, const Eigen::VectorXd& shift) {
  negative_ = singular_ = 0;
  worst_ = -1;
  if (!prepare(A)) return false;
  for (int c = 0; c < static_cast<int>(A.cols()); ++c) work_.valuePtr()[diagSlot_[c]] += shift[c];
  ldlt_.factorize(work_);
  ++factorizations_;
  if (ldlt_.info() != Eigen::Success) return false;
  Dmod_ = ldlt_.vectorD();
  stiff_.assign(Dmod_.size(), 1);
  return Dmod_.allFinite() && (Dmod_.array() > 0).all();
}

Eigen::VectorXd ModifiedLdlt::solve(const Eigen::VectorXd& b) const {
  Eigen::VectorXd y = ldlt_.permutationP() * b;
  ldlt_.matrixL().solveInPlace(y);
  y.array() /= Dmod_.array();
  ldlt_.matrixU().solveInPlace(y);
  return ldlt_.permutationPinv() * y;
}

Eigen::VectorXd ModifiedLdlt::solveUnmodified(const Eigen::VectorXd& b) const {
  Eigen::VectorXd y = ldlt_.permutationP() * b;
  ldlt_.matrixL().solveInPlace(y);
  y.array() /= ldlt_.vectorD().array();
  ldlt_.matrixU().solveInPlace(y);
  return ldlt_.permutationPinv() * y;
}

double ModifiedLdlt::stiffDecrement(const Eigen::VectorXd& b) const {
  Eigen::VectorXd y = ldlt_.permutationP() * b;
  ldlt_.matrixL().solveInPlace(y);
  double s = 0.0;
  for (int i = 0; i < y.size(); ++i)
    if (stiff_[i]) s += y[i] * y[i] / Dmod_[i];
  return s;
}

Eigen::VectorXd ModifiedLdlt::negativeCurvatureDirection() const {
  if (worst_ < 0) return {};
  Eigen::VectorXd y = Eigen::VectorXd::Zero(Dmod_.size());
  y[worst_] = 1.0;
  ldlt_.matrixU().solveInPlace(y);
  return ldlt_.permutationPinv() * y;
}

namespace roundoff {

Eigen::VectorXd unknownScale(const PoseSystem& sys, const Eigen::VectorXd& u) {
  const int nv = sys.numVertexDofs();
  Eigen::VectorXd a = u.cwiseAbs();
  a.head(nv).array() += sys.momentArm();
  a.tail(u.size() - nv).array() += 1.0;
  return a;
}

Eigen::VectorXd residualFloor(const Eigen::SparseMatrix<double>& A, const Eigen::VectorXd& a) {
  const int n = static_cast<int>(A.cols());
  Eigen::VectorXd q = Eigen::VectorXd::Zero(n);
  for (int c = 0; c < n; ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(A, c); it; ++it) {
      const int r = static_cast<int>(it.row());
      const double h2 = it.value() * it.value();
      q[r] += h2 * a[c] * a[c];
      if (r != c) q[c] += h2 * a[r] * a[r];
    }
  return kEps * q.cwiseSqrt();
}

double energyFloor(const Eigen::SparseMatrix<double>& A, const Eigen::VectorXd& a) {
  double s = 0.0;
  for (int c = 0; c < A.cols(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(A, c); it; ++it)
      s += (it.row() == c ? 1.0 : 2.0) * std::abs(it.value()) * a[it.row()] * a[c];
  return kEps * kEps * s;
}

}  // namespace roundoff
}  // namespace rodmesh
