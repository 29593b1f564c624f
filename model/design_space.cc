// DesignSpace: control points, Bézier interpolation along rods, degree-elevation
// levels and the phase free-variable vector (see model/design_space.hh).
#include "model/design_space.hh"

#include <Eigen/Dense>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseQR>
#include <algorithm>
#include <cassert>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace rodmesh {
namespace {

using Triplet = Eigen::Triplet<double>;

// Bernstein polynomials B_{j,m}(s), j = 0..m, by the de Casteljau-style
// recurrence (every step is a convex combination: non-negative, sum 1, and
// exactly [1, 0, ..., 0] at s = 0 and [0, ..., 0, 1] at s = 1).
std::vector<double> bernstein(int m, double s) {
  std::vector<double> b(m + 1, 0.0);
  b[0] = 1.0;
  for (int k = 1; k <= m; ++k) {
    for (int j = k; j >= 1; --j) b[j] = (1.0 - s) * b[j] + s * b[j - 1];
    b[0] *= (1.0 - s);
  }
  return b;
}

double binomial(int n, int k) {
  if (k < 0 || k > n) return 0.0;
  double r = 1.0;
  for (int i = 1; i <= k; ++i) r = r * (n - k + i) / i;
  return r;
}

// Coefficient of degree-d coefficient k in degree-m coefficient j after exact
// degree elevation (m >= d): C(d,k) C(m-d, j-k) / C(m, j).
double elevation(int d, int m, int j, int k) { return binomial(d, k) * binomial(m - d, j - k) / binomial(m, j); }

}  // namespace

DesignSpace::DesignSpace(const Scene& scene, const EffectSet& effects)
    : n_(scene.design.controlPointsPerRod),
      sceneVertices_(scene.vertices),
      planar_(effects.planar),
      planeBasis_(effects.planeBasis) {
  if (n_ < 2)
    throw std::invalid_argument("design.control_points_per_rod must be at least 2, got " + std::to_string(n_));
  const int nv = static_cast<int>(scene.vertices.size());
  const int nr = static_cast<int>(scene.rods.size());

  // Distinct levels: degrees {1, min(2, n-1), n-1}.
  for (int d : {1, std::min(2, n_ - 1), n_ - 1})
    if (degrees_.empty() || d > degrees_.back()) degrees_.push_back(d);

  // Shared end control points, in increasing vertex order.
  endNode_.assign(nv, -1);
  std::vector<bool> isEnd(nv, false);
  for (const Rod& rod : scene.rods) {
    assert(rod.vertices.size() >= 2);
    isEnd[rod.vertices.front()] = isEnd[rod.vertices.back()] = true;
  }
  for (int v = 0; v < nv; ++v)
    if (isEnd[v]) {
      endNode_[v] = numEnds_++;
      controlPoints_.push_back(ControlPoint{-1, v, 0.0});
    }
  for (int r = 0; r < nr; ++r)
    for (int j = 1; j <= n_ - 2; ++j) controlPoints_.push_back(ControlPoint{r, -1, double(j) / (n_ - 1)});

  // Arc fractions on the scene's rest vertices.
  rodVertices_.resize(nr);
  rodArcFractions_.resize(nr);
  for (int r = 0; r < nr; ++r) {
    const std::vector<int>& vs = scene.rods[r].vertices;
    rodVertices_[r] = vs;
    std::vector<double>& s = rodArcFractions_[r];
    s.assign(vs.size(), 0.0);
    for (std::size_t i = 1; i < vs.size(); ++i)
      s[i] = s[i - 1] + (scene.vertices[vs[i]] - scene.vertices[vs[i - 1]]).norm();
    const double length = s.back();
    assert(length > 0.0);
    for (double& x : s) x /= length;
    s.front() = 0.0;
    s.back() = 1.0;
  }

  // W: unit rows for rod-end vertices, Bernstein rows for interior vertices.
  std::vector<Triplet> w;
  std::vector<bool> covered(nv, false);
  for (int v = 0; v < nv; ++v)
    if (endNode_[v] >= 0) {
      w.emplace_back(v, endNode_[v], 1.0);
      covered[v] = true;
    }
  for (int r = 0; r < nr; ++r) {
    const std::vector<int>& vs = rodVertices_[r];
    for (std::size_t i = 1; i + 1 < vs.size(); ++i) {
      const std::vector<double> b = bernstein(n_ - 1, rodArcFractions_[r][i]);
      for (int j = 0; j < n_; ++j)
        if (b[j] != 0.0) w.emplace_back(vs[i], controlIndex(r, j), b[j]);
      covered[vs[i]] = true;
    }
  }
  assert(std::all_of(covered.begin(), covered.end(), [](bool c) { return c; }) && "every vertex belongs to a rod");
  W_.resize(nv, numControlPoints());
  W_.setFromTriplets(w.begin(), w.end());

  // Radius bounds.
  if (scene.design.hasRadiusBounds) {
    radiusMin_ = scene.design.radiusMin;
    radiusMax_ = scene.design.radiusMax;
  } else {
    double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
    for (const Vec2& r : scene.radii) {
      lo = std::min(lo, r.minCoeff());
      hi = std::max(hi, r.maxCoeff());
    }
    radiusMin_ = 0.1 * lo;
    radiusMax_ = 10.0 * hi;
  }
}

void DesignSpace::checkLevel(int level) const {
  if (level < 0 || level >= numLevels())
    throw std::out_of_range("design level " + std::to_string(level) + " outside [0, " +
                            std::to_string(numLevels() - 1) + "]");
}

int DesignSpace::degree(int level) const {
  checkLevel(level);
  return degrees_[level];
}

int DesignSpace::numNodes(int level) const { return numEnds_ + numRods() * (degree(level) - 1); }

int DesignSpace::nodeIndex(int level, int rod, int k) const {
  const int d = degree(level);
  assert(k >= 0 && k <= d);
  if (k == 0) return endNode_[rodVertices_[rod].front()];
  if (k == d) return endNode_[rodVertices_[rod].back()];
  return numEnds_ + rod * (d - 1) + (k - 1);
}

Eigen::SparseMatrix<double> DesignSpace::levelTransfer(int from, int to) const {
  const int d = degree(from), m = degree(to);
  if (from > to) throw std::invalid_argument("levelTransfer: from level must not be finer than to level");
  std::vector<Triplet> t;
  for (int e = 0; e < numEnds_; ++e) t.emplace_back(e, e, 1.0);
  for (int r = 0; r < numRods(); ++r)
    for (int j = 1; j < m; ++j)
      for (int k = std::max(0, j - (m - d)); k <= std::min(d, j); ++k)
        t.emplace_back(nodeIndex(to, r, j), nodeIndex(from, r, k), elevation(d, m, j, k));
  Eigen::SparseMatrix<double> T(numNodes(to), numNodes(from));
  T.setFromTriplets(t.begin(), t.end());
  return T;
}

Eigen::SparseMatrix<double> DesignSpace::vertexMatrix(int level) const {
  Eigen::SparseMatrix<double> W = W_;
  return W * levelMatrix(level);
}

int DesignSpace::numFree(const DesignPhase& phase) const {
  const int N = numNodes(phase.level);
  return (phase.radii ? 2 * N : 0) + (phase.restShape ? displacementDim() * N : 0);
}

ControlValues DesignSpace::initialControls(const Scene& scene) const {
  if (static_cast<int>(scene.radii.size()) != numVertices())
    throw std::invalid_argument("initialControls: expected one radius pair per vertex");
  ControlValues c;
  c.radii.setZero(numControlPoints(), 2);
  c.displacement.setZero(numControlPoints(), 3);
  for (const ControlPoint& cp : controlPoints_)
    if (cp.rod < 0) c.radii.row(endNode_[cp.vertex]) = scene.radii[cp.vertex].transpose();
  const int m = n_ - 1;
  for (int r = 0; r < numRods(); ++r) {
    const std::vector<int>& vs = rodVertices_[r];
    const std::vector<double>& s = rodArcFractions_[r];
    const Eigen::RowVector2d a = scene.radii[vs.front()].transpose(), b = scene.radii[vs.back()].transpose();
    // Linear in arc fraction between the end values (exact Greville representation).
    for (int j = 1; j < m; ++j) c.radii.row(controlIndex(r, j)) = a + (b - a) * (double(j) / m);
    const int rows = static_cast<int>(vs.size()) - 2, cols = n_ - 2;
    if (rows <= 0 || cols <= 0) continue;
    // Minimum-norm least-squares correction of the interior controls.
    Eigen::MatrixXd A(rows, cols), rhs(rows, 2);
    Eigen::RowVector2d lo = a.cwiseMin(b), hi = a.cwiseMax(b);
    for (int i = 0; i < rows; ++i) {
      const std::vector<double> bern = bernstein(m, s[i + 1]);
      for (int j = 1; j < m; ++j) A(i, j - 1) = bern[j];
      const Eigen::RowVector2d rv = scene.radii[vs[i + 1]].transpose();
      rhs.row(i) = rv - (a + (b - a) * s[i + 1]);
      lo = lo.cwiseMin(rv);
      hi = hi.cwiseMax(rv);
    }
    if (rhs.isZero(0.0)) continue;
    const Eigen::MatrixXd delta = A.completeOrthogonalDecomposition().solve(rhs);
    for (int j = 1; j < m; ++j) {
      Eigen::RowVector2d v = c.radii.row(controlIndex(r, j)) + delta.row(j - 1);
      c.radii.row(controlIndex(r, j)) = v.cwiseMax(lo).cwiseMin(hi);
    }
  }
  return c;
}

Eigen::VectorXd DesignSpace::pack(const DesignPhase& phase, const ControlValues& controls) const {
  assert(controls.radii.rows() == numControlPoints() && controls.displacement.rows() == numControlPoints());
  const int N = numNodes(phase.level);
  Eigen::VectorXd z(numFree(phase));
  const bool finest = phase.level == numLevels() - 1;
  // Least-squares nodes for control values X (C x k); exact at the finest
  // level (E = I) and whenever X lies in the range of E_L.
  auto fit = [&](const Eigen::MatrixXd& X) -> Eigen::MatrixXd {
    if (finest) return X;
    Eigen::SparseMatrix<double> E = levelMatrix(phase.level);
    E.makeCompressed();
    Eigen::SparseQR<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>> qr(E);
    assert(qr.info() == Eigen::Success);
    return qr.solve(X);
  };
  int offset = 0;
  if (phase.radii) {
    const Eigen::MatrixXd nodes = fit(controls.radii);
    for (int i = 0; i < N; ++i) z.segment<2>(2 * i) = nodes.row(i).transpose();
    offset = 2 * N;
  }
  if (phase.restShape) {
    const Eigen::MatrixXd nodes = fit(controls.displacement);
    for (int i = 0; i < N; ++i) {
      if (planar_)
        z.segment<2>(offset + 2 * i) = planeBasis_.transpose() * nodes.row(i).transpose();
      else
        z.segment<3>(offset + 3 * i) = nodes.row(i).transpose();
    }
  }
  return z;
}

ControlValues DesignSpace::unpack(const DesignPhase& phase, const Eigen::VectorXd& z, const ControlValues& base) const {
  assert(z.size() == numFree(phase));
  const int N = numNodes(phase.level);
  const Eigen::SparseMatrix<double> E = levelMatrix(phase.level);
  ControlValues c = base;
  int offset = 0;
  if (phase.radii) {
    Eigen::MatrixXd nodes(N, 2);
    for (int i = 0; i < N; ++i) nodes.row(i) = z.segment<2>(2 * i).transpose();
    c.radii = E * nodes;
    offset = 2 * N;
  }
  if (phase.restShape) {
    Eigen::MatrixXd nodes(N, 3);
    for (int i = 0; i < N; ++i) {
      if (planar_)
        nodes.row(i) = (planeBasis_ * z.segment<2>(offset + 2 * i)).transpose();
      else
        nodes.row(i) = z.segment<3>(offset + 3 * i).transpose();
    }
    c.displacement = E * nodes;
  }
  return c;
}

namespace {
// Relative rounding of an interpolated radius (a convex combination of at
// most kMaxControlPoints control values) that toDesign snaps back to a bound.
constexpr double kRoundingSlack = 1e-12;
}  // namespace

Design DesignSpace::toDesign(const ControlValues& controls) const {
  assert(controls.radii.rows() == numControlPoints() && controls.displacement.rows() == numControlPoints());
  // Each vertex's radii as its first control value plus the weighted
  // differences from it: the same convex combination, but exactly the
  // control value where the vertex's control values are equal (the initial
  // design then has the scene's radii to the last bit, not a rounding of
  // them, and `simulate` of the scene solves the same design).
  Eigen::MatrixXd radii(W_.rows(), 2);
  for (Eigen::Index v = 0; v < W_.outerSize(); ++v) {
    Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(W_, v);
    if (!it) {
      radii.row(v).setZero();
      continue;
    }
    const Eigen::RowVector2d first = controls.radii.row(it.col());
    Eigen::RowVector2d sum = Eigen::RowVector2d::Zero();
    for (; it; ++it) sum += it.value() * (controls.radii.row(it.col()) - first);
    radii.row(v) = first + sum;
  }
  Eigen::MatrixXd disp = W_ * controls.displacement;
  if (planar_) disp = disp * (planeBasis_ * planeBasis_.transpose());  // rows: (P d)^T = d^T P
  Design d;
  d.restPositions.resize(numVertices());
  d.radii.resize(numVertices());
  for (int v = 0; v < numVertices(); ++v) {
    d.restPositions[v] = sceneVertices_[v] + disp.row(v).transpose();
    // The weights of a vertex are non-negative and sum to one, so its radii
    // lie within the range of the control radii up to rounding. A radius
    // beyond a bound by no more than that rounding (relative 1e-12) is set to
    // the bound, so that "a vertex radius never leaves the bounds" holds to
    // the last digit; farther out (a finite-difference probe of controls
    // outside the bounds) it is left as interpolated, keeping the map smooth.
    for (int k = 0; k < 2; ++k) {
      double r = radii(v, k);
      if (r < radiusMin_ && r >= radiusMin_ * (1.0 - kRoundingSlack)) r = radiusMin_;
      if (r > radiusMax_ && r <= radiusMax_ * (1.0 + kRoundingSlack)) r = radiusMax_;
      d.radii[v][k] = r;
    }
  }
  return d;
}

Eigen::SparseMatrix<double> DesignSpace::jacobian(const DesignPhase& phase) const {
  const int N = numNodes(phase.level), nv = numVertices();
  const Eigen::SparseMatrix<double> M = vertexMatrix(phase.level);  // V x N
  std::vector<Triplet> t;
  int offset = 0;
  if (phase.radii) {
    for (int i = 0; i < M.outerSize(); ++i)
      for (Eigen::SparseMatrix<double>::InnerIterator it(M, i); it; ++it)
        for (int c = 0; c < 2; ++c) t.emplace_back(3 * nv + 2 * it.row() + c, 2 * it.col() + c, it.value());
    offset = 2 * N;
  }
  if (phase.restShape) {
    for (int i = 0; i < M.outerSize(); ++i)
      for (Eigen::SparseMatrix<double>::InnerIterator it(M, i); it; ++it) {
        if (planar_) {
          // rest_v += B z_i * M(v, i): P B = B.
          for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 2; ++b)
              if (planeBasis_(a, b) != 0.0)
                t.emplace_back(3 * it.row() + a, offset + 2 * it.col() + b, it.value() * planeBasis_(a, b));
        } else {
          for (int a = 0; a < 3; ++a) t.emplace_back(3 * it.row() + a, offset + 3 * it.col() + a, it.value());
        }
      }
  }
  Eigen::SparseMatrix<double> J(5 * nv, numFree(phase));
  J.setFromTriplets(t.begin(), t.end());
  return J;
}

void DesignSpace::bounds(const DesignPhase& phase, Eigen::VectorXd& lower, Eigen::VectorXd& upper) const {
  const double inf = std::numeric_limits<double>::infinity();
  const int nf = numFree(phase);
  lower.setConstant(nf, -inf);
  upper.setConstant(nf, inf);
  if (phase.radii) {
    const int nr = 2 * numNodes(phase.level);
    lower.head(nr).setConstant(radiusMin_);
    upper.head(nr).setConstant(radiusMax_);
  }
}

std::string DesignSpace::describe() const {
  static const char* names[] = {"linear", "quadratic", "cubic", "quartic", "quintic"};
  std::ostringstream os;
  os << numControlPoints() << " control points (" << numEnds_ << " shared ends + " << numRods() << " rods x " << n_ - 2
     << " interior); levels:";
  for (int L = 0; L < numLevels(); ++L) {
    const int d = degrees_[L];
    os << (L ? "," : "") << " " << L << " ";
    if (d <= 5)
      os << names[d - 1];
    else
      os << "degree " << d;
    os << " " << numNodes(L) << " nodes";
  }
  if (planar_) os << "; planar rest shape (2 displacement components per node)";
  return os.str();
}

bool DesignSpace::fitControls(const Eigen::MatrixXd& vertexField, Eigen::MatrixXd& controls) const {
  if (vertexField.rows() != W_.rows()) return false;
  // A rod with fewer interior vertices than interior control points leaves
  // some controls (or combinations of them) without any vertex: W^T W is
  // then singular. A shift far below its entries (at most the vertex count)
  // picks the fit of least norm there and changes a full-rank fit only at
  // round-off.
  Eigen::SparseMatrix<double> normal = W_.transpose() * W_;
  const double shift = 1e-12 * std::max(1.0, normal.diagonal().maxCoeff());
  for (int i = 0; i < normal.rows(); ++i) normal.coeffRef(i, i) += shift;
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(normal);
  if (ldlt.info() != Eigen::Success) return false;
  controls = ldlt.solve(Eigen::MatrixXd(W_.transpose() * vertexField));
  return ldlt.info() == Eigen::Success && controls.allFinite();
}

}  // namespace rodmesh
