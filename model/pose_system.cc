#include "model/pose_system.hh"

#include "model/pose_system_detail.hh"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace rodmesh {

using namespace detail;

// ------------------------------------------------------------------------

PoseSystem::PoseSystem(const Scene& scene, const RodNetwork& network, const EffectSet& effects, int poseIndex)
    : scene_(scene), net_(network), fx_(effects), pose_(poseIndex) {
  const Pose& pose = scene.poses.at(poseIndex);
  const int nv = network.numVertices();
  const int ne = network.numEdges();
  D_ = fx_.planar ? 2 : 3;
  twist_ = fx_.has(Effect::Twist);

  held_.assign(nv, false);
  heldExplicit_.assign(nv, false);
  heldTarget_ = scene.vertices;
  for (const FixedVertex& f : pose.fixed) {
    held_[f.vertex] = true;
    if (f.position) {
      heldExplicit_[f.vertex] = true;
      heldTarget_[f.vertex] = *f.position;
    }
  }
  std::vector<bool> clamped(nv, false);
  for (const ClampedVertex& c : pose.clamped) {
    held_[c.vertex] = true;
    heldExplicit_[c.vertex] = false;  // a clamp holds the vertex at rest
    clamped[c.vertex] = true;
  }
  buildHandles();
  vertexDof_.assign(nv, -1);
  int n = 0;
  for (int v = 0; v < nv; ++v)
    if (!held_[v]) { vertexDof_[v] = n; n += D_; }
  nVertexDofs_ = n;
  nDofs_ = n + (twist_ ? ne : 0);

  double total = 0.0;
  for (const Edge& e : network.edges()) total += (scene.vertices[e.b] - scene.vertices[e.a]).norm();
  momentArm_ = total / std::max(1, ne);

  auto storage = std::make_shared<TermStorage>();
  const TermSetup setup{scene, network, fx_, pose, clamped, twist_};
  TermBlocks::each([&](auto index) {
    constexpr int I = decltype(index)::value;
    TermBlocks::Block<I>::collect(setup, std::get<I>(storage->elements));
  });
  terms_ = std::move(storage);
  // Internal variables: block by block, element by element, initial values.
  std::vector<double> initial;
  TermBlocks::each([&](auto index) {
    constexpr int I = decltype(index)::value;
    using Block = TermBlocks::Block<I>;
    internalOffset_.push_back(static_cast<int>(initial.size()));
    if constexpr (InternalCount<Block>::value > 0) {
      for (const auto& el : std::get<I>(terms_->elements)) {
        initial.resize(initial.size() + InternalCount<Block>::value);
        Block::initial(el, initial.data() + initial.size() - InternalCount<Block>::value);
      }
    }
  });
  initialInternal_ = Eigen::Map<const Eigen::VectorXd>(initial.data(), static_cast<Eigen::Index>(initial.size()));

  buildPattern();
}

Charts PoseSystem::restCharts(const Design& d) const {
  const int ne = net_.numEdges();
  Charts c;
  c.tangent.resize(ne);
  c.director.resize(ne);
  for (int e = 0; e < ne; ++e) {
    const EdgeFrame f = net_.restFrame(e, d.restPositions);
    c.tangent[e] = f.t;
    c.director[e] = f.d1;
  }
  return c;
}

namespace {
// Transport of v from unit a to unit b (double).
Vec3 transportD(const Vec3& a, const Vec3& b, const Vec3& v) {
  const Vec3 c = a.cross(b);
  const double d = a.dot(b);
  return d * v + c.cross(v) + (c.dot(v) / (1.0 + d)) * c;
}
double signedAngleD(const Vec3& p, const Vec3& q, const Vec3& t) { return std::atan2(p.cross(q).dot(t), p.dot(q)); }
}  // namespace

std::optional<PoseState> PoseSystem::reanchored(const PoseState& s, const Design& d, double cosLimit) const {
  const std::vector<Vec3> x = positions(s, d);
  std::optional<PoseState> out;
  for (int e = 0; e < net_.numEdges(); ++e) {
    const Edge& ed = net_.edges()[e];
    const Vec3 t = (x[ed.b] - x[ed.a]).normalized();
    if (t.dot(s.charts.tangent[e]) >= cosLimit) continue;
    if (!out) out = s;
    out->charts.director[e] = transportD(s.charts.tangent[e], t, s.charts.director[e]).normalized();
    out->charts.tangent[e] = t;
  }
  return out;
}

Eigen::VectorXd PoseSystem::materialTwists(const PoseState& s, const Design& d) const {
  Eigen::VectorXd th = twists(s.u);
  if (!twist_) return th;
  const std::vector<Vec3> x = positions(s, d);
  for (int e = 0; e < net_.numEdges(); ++e) {
    const Edge& ed = net_.edges()[e];
    const Vec3 t = (x[ed.b] - x[ed.a]).normalized();
    const Vec3 ref = transportD(s.charts.tangent[e], t, s.charts.director[e]);
    const EdgeFrame rest = net_.restFrame(e, d.restPositions);
    const Vec3 restRef = transportD(rest.t, t, rest.d1);
    th[e] += signedAngleD(restRef, ref, t);
  }
  return th;
}

// Handles: the vertices held at explicit positions, grouped by the edges
// between them (groups of two or more).
void PoseSystem::buildHandles() {
  const int nv = static_cast<int>(held_.size());
  std::vector<int> parent(nv);
  for (int v = 0; v < nv; ++v) parent[v] = v;
  auto find = [&](int v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (const Edge& e : net_.edges())
    if (heldExplicit_[e.a] && heldExplicit_[e.b]) parent[find(e.a)] = find(e.b);
  std::vector<std::vector<int>> groups(nv);
  for (int v = 0; v < nv; ++v)
    if (heldExplicit_[v]) groups[find(v)].push_back(v);
  for (std::vector<int>& g : groups)
    if (g.size() >= 2) handles_.push_back(std::move(g));
}

namespace {

// The rotation (angle about a unit axis) that best turns the offsets a_i
// onto b_i in the least-squares sense, from A = sum a_i b_i^T (Kabsch: the
// SVD of A); about `normal` only when it is given (a planar scene); the
// smallest one taking the line of the a_i onto that of the b_i when the
// a_i lie on one line.
Eigen::AngleAxisd bestRotation(const Eigen::Matrix3d& A, const Eigen::Vector3d* normal,
                               const Eigen::Matrix<double, 3, 2>& basis) {
  if (normal) {
    const Eigen::Matrix2d A2 = basis.transpose() * A * basis;
    return Eigen::AngleAxisd(std::atan2(A2(0, 1) - A2(1, 0), A2(0, 0) + A2(1, 1)), *normal);
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d sv = svd.singularValues();
  if (!(sv(1) > 1e-9 * sv(0)))
    return Eigen::AngleAxisd(Eigen::Quaterniond::FromTwoVectors(svd.matrixU().col(0), svd.matrixV().col(0)));
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return Eigen::AngleAxisd(Eigen::Matrix3d(svd.matrixV() * D * svd.matrixU().transpose()));
}

}  // namespace

// A held vertex sits at its rest position r under the current design, or,
// when fixed at an explicit position p, moves there from rest with the load
// factor L: on a straight line, x = r + L (p - r), unless it belongs to a
// handle (docs/model.md, "Unknowns of a pose"). A handle's least-squares
// rigid motion from its rest positions r_i to its prescribed p_i (rotation
// R by angle a about a fixed axis, centroids c_r -> c_p) leaves residuals e_i = p_i -
// (R (r_i - c_r) + c_p); with q the largest |e_i| over the largest |p_i -
// r_i|, the handle turns by the angle s(q) a L, with s = 1 up to q = 1% (a
// rigid handle, as held in a hand, keeps its shape on the way: on straight
// lines it would shorten by cos(a/2) at half the load, 29% for a quarter
// turn, and at a half turn its vertices would meet), falling smoothly to 0
// at q = 10% (straight lines again; no part of a group that is not one
// rigid body turns away and back), its centroid moves on a straight line
// and what the turn by s(q) a leaves of p_i is added in proportion to L.
// Both ways x = r at L = 0 and x = p at L = 1, and the motion depends on
// the design's rest positions and the prescribed ones only, so that a
// scene made of the archived design (its rest positions as the scene's)
// follows the same path. Design derivatives are taken at the full load,
// where x = p (heldDesignCoefficient 0), and at rest (1). A planar scene
// keeps held vertices in its plane (their rest positions are projected
// onto it, turns are about its normal).
void PoseSystem::heldPositions(const Design& d, double loadFactor, std::vector<Vec3>& x) const {
  auto rest = [&](int v) {
    const Vec3& r = d.restPositions[v];
    return D_ == 2 ? Vec3(fx_.planeOrigin + fx_.planeBasis * (fx_.planeBasis.transpose() * (r - fx_.planeOrigin))) : r;
  };
  for (std::size_t v = 0; v < held_.size(); ++v) {
    if (!held_[v]) continue;
    const Vec3 r = rest(static_cast<int>(v));
    x[v] = heldExplicit_[v] ? Vec3(r + loadFactor * (heldTarget_[v] - r)) : r;
  }
  if (loadFactor == 0.0 || loadFactor == 1.0) return;
  const Eigen::Vector3d normal =
      D_ == 2 ? Eigen::Vector3d(fx_.planeBasis.col(0).cross(fx_.planeBasis.col(1)).normalized())
              : Eigen::Vector3d::Zero();
  std::vector<Vec3> r;  // a handle's rest positions (projected in a planar scene)
  for (const std::vector<int>& g : handles_) {
    r.resize(g.size());
    Vec3 cr = Vec3::Zero(), cp = Vec3::Zero();
    for (std::size_t i = 0; i < g.size(); ++i) {
      r[i] = rest(g[i]);
      cr += r[i];
      cp += heldTarget_[g[i]];
    }
    cr /= static_cast<double>(g.size());
    cp /= static_cast<double>(g.size());
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    double largestMove = 0.0;
    for (std::size_t i = 0; i < g.size(); ++i) {
      A += (r[i] - cr) * (heldTarget_[g[i]] - cp).transpose();
      largestMove = std::max(largestMove, (heldTarget_[g[i]] - r[i]).norm());
    }
    if (!(largestMove > 0.0)) continue;
    const Eigen::AngleAxisd turn = bestRotation(A, D_ == 2 ? &normal : nullptr, fx_.planeBasis);
    if (!std::isfinite(turn.angle()) || !turn.axis().allFinite() || turn.angle() == 0.0) continue;
    const Eigen::Matrix3d R = turn.toRotationMatrix();
    double largestResidual = 0.0;
    for (std::size_t i = 0; i < g.size(); ++i)
      largestResidual = std::max(largestResidual, (heldTarget_[g[i]] - (R * (r[i] - cr) + cp)).norm());
    // s(q): 1 below 1%, 0 above 10%, a smoothstep between.
    const double t = std::clamp((largestResidual / largestMove - 0.01) / 0.09, 0.0, 1.0);
    const double share = 1.0 - t * t * (3.0 - 2.0 * t);
    if (share == 0.0) continue;
    const Eigen::Matrix3d full = Eigen::AngleAxisd(share * turn.angle(), turn.axis()).toRotationMatrix();
    const Eigen::Matrix3d part = Eigen::AngleAxisd(loadFactor * share * turn.angle(), turn.axis()).toRotationMatrix();
    for (std::size_t i = 0; i < g.size(); ++i) {
      const Vec3 left = heldTarget_[g[i]] - (full * (r[i] - cr) + cp);
      x[g[i]] = part * (r[i] - cr) + cr + loadFactor * (cp - cr + left);
    }
  }
}

double PoseSystem::heldDesignCoefficient(int v, double loadFactor) const {
  if (!held_[v]) return 0.0;
  return heldExplicit_[v] ? 1.0 - loadFactor : 1.0;
}

std::vector<double> PoseSystem::heldCoefficients(double loadFactor) const {
  std::vector<double> c(held_.size());
  for (std::size_t v = 0; v < c.size(); ++v) c[v] = heldDesignCoefficient(static_cast<int>(v), loadFactor);
  return c;
}

PoseState PoseSystem::restState(const Design& d) const { return PoseState{restDofs(d), restCharts(d), 0.0, {}}; }

std::vector<Vec3> PoseSystem::positions(const PoseState& s, const Design& d) const {
  const Eigen::VectorXd& u = s.u;
  std::vector<Vec3> x(vertexDof_.size());
  for (std::size_t v = 0; v < x.size(); ++v) {
    const int k = vertexDof_[v];
    if (k < 0) continue;  // held: below
    if (D_ == 3) x[v] = u.segment<3>(k);
    else x[v] = fx_.planeOrigin + fx_.planeBasis * u.segment<2>(k);
  }
  heldPositions(d, s.loadFactor, x);
  return x;
}

Eigen::VectorXd PoseSystem::twists(const Eigen::VectorXd& u) const {
  const int ne = net_.numEdges();
  if (!twist_) return Eigen::VectorXd::Zero(ne);
  return u.segment(nVertexDofs_, ne);
}

Eigen::VectorXd PoseSystem::dofsFrom(const std::vector<Vec3>& x, const Eigen::VectorXd& theta) const {
  Eigen::VectorXd u(nDofs_);
  for (std::size_t v = 0; v < x.size(); ++v) {
    const int k = vertexDof_[v];
    if (k < 0) continue;
    if (D_ == 3) u.segment<3>(k) = x[v];
    else u.segment<2>(k) = fx_.planeBasis.transpose() * (x[v] - fx_.planeOrigin);
  }
  if (twist_) u.segment(nVertexDofs_, net_.numEdges()) = theta;
  return u;
}

Eigen::VectorXd PoseSystem::restDofs(const Design& d) const {
  return dofsFrom(d.restPositions, Eigen::VectorXd::Zero(net_.numEdges()));
}

double PoseSystem::roundoffForce(const Design& d) const {
  double ea = 0.0, extent = 0.0, shortest = std::numeric_limits<double>::max();
  for (std::size_t v = 0; v < d.radii.size(); ++v) {
    ea = std::max(ea, stiffness::stretching(scene_.material.youngModulus, d.radii[v][0], d.radii[v][1]));
    extent = std::max(extent, d.restPositions[v].cwiseAbs().maxCoeff());
  }
  for (const Edge& e : net_.edges()) shortest = std::min(shortest, (d.restPositions[e.b] - d.restPositions[e.a]).norm());
  return 1e3 * std::numeric_limits<double>::epsilon() * ea * std::max(1.0, extent / shortest);
}

Eigen::VectorXd PoseSystem::forceResidual(const Eigen::VectorXd& g) const {
  Eigen::VectorXd r = g;
  if (twist_) r.segment(nVertexDofs_, net_.numEdges()) /= momentArm_;
  return r;
}

BuildCtx PoseSystem::context(const std::vector<Vec3>& x, const Eigen::VectorXd& theta, const Design& d,
                             const std::vector<double>* heldCoef, const Charts& charts, double loadFactor,
                             Terms terms) const {
  BuildCtx c{&x, &theta, &d, &vertexDof_, &fx_.planeBasis, fx_.planeOrigin, D_, twist_, nVertexDofs_, heldCoef,
             &charts, loadFactor, terms};
  c.scene = &scene_;
  c.net = &net_;
  c.fx = &fx_;
  c.internal = initialInternal_.data();
  return c;
}

const double* PoseSystem::internalOf(const PoseState& s) const {
  if (s.internal.size() == 0) return initialInternal_.data();
  if (s.internal.size() != initialInternal_.size())
    throw std::invalid_argument("pose " + std::to_string(pose_) + ": the state has " +
                                std::to_string(s.internal.size()) + " internal variables, the model " +
                                std::to_string(initialInternal_.size()));
  return s.internal.data();
}

std::optional<PoseState> PoseSystem::advancedInternal(const PoseState& s, const Design& d) const {
  if (numInternal() == 0) return std::nullopt;
  const std::vector<Vec3> x = positions(s, d);
  const Eigen::VectorXd theta = twists(s.u);
  BuildCtx ctx = context(x, theta, d, nullptr, s.charts, s.loadFactor, Terms::All);
  Eigen::VectorXd next = Eigen::Map<const Eigen::VectorXd>(internalOf(s), numInternal());
  bool changed = false;
  TermBlocks::each([&](auto index) {
    constexpr int I = decltype(index)::value;
    using Block = TermBlocks::Block<I>;
    if constexpr (InternalCount<Block>::value > 0) {
      double* internal = next.data() + internalOffset_[I];
      for (const auto& el : std::get<I>(terms_->elements)) {
        changed = Block::update(el, ctx, internal) || changed;
        internal += InternalCount<Block>::value;
      }
    }
  });
  if (!changed) return std::nullopt;
  PoseState out = s;
  out.internal = std::move(next);
  return out;
}

const std::vector<TermKind>& PoseSystem::termKinds() {
  static const std::vector<TermKind> kinds = [] {
    std::vector<TermKind> k;
    TermBlocks::each([&](auto index) {
      using Block = TermBlocks::Block<decltype(index)::value>;
      k.push_back({Block::kName, Block::kLinear, Block::kLoad, Block::kDesign, InternalCount<Block>::value});
    });
    return k;
  }();
  return kinds;
}

int PoseSystem::termKindIndex(const std::string& name) {
  const std::vector<TermKind>& kinds = termKinds();
  for (std::size_t i = 0; i < kinds.size(); ++i)
    if (name == kinds[i].name) return static_cast<int>(i);
  return -1;
}

int PoseSystem::termCount(int kind) const {
  int n = -1;
  TermBlocks::each([&](auto index) {
    if (decltype(index)::value == kind) n = static_cast<int>(std::get<decltype(index)::value>(terms_->elements).size());
  });
  if (n < 0) throw std::out_of_range("no energy term kind " + std::to_string(kind));
  return n;
}

TermSet TermSet::named(const std::string& name) {
  const int k = PoseSystem::termKindIndex(name);
  if (k >= 0) return only(k);
  std::string known;
  for (const TermKind& t : PoseSystem::termKinds()) known += std::string(known.empty() ? "" : ", ") + t.name;
  throw std::invalid_argument("unknown energy term '" + name + "' (known: " + known + ")");
}

TermSet TermSet::loads() {
  TermSet s(0u);
  const std::vector<TermKind>& kinds = PoseSystem::termKinds();
  for (std::size_t i = 0; i < kinds.size(); ++i)
    if (kinds[i].load) s = s | only(static_cast<int>(i));
  return s;
}

// The simulation Hessian's pattern (lower triangle, full diagonal) and the
// value slot of every (i >= j) pair of each stencil's unknowns, from the one
// stencil list (evaluated at the scene's rest state: only structure is used).
void PoseSystem::buildPattern() {
  const Design d0 = Design::fromScene(scene_);
  const std::vector<Vec3> x = d0.restPositions;
  const Eigen::VectorXd theta = Eigen::VectorXd::Zero(net_.numEdges());
  const std::vector<double> hc = heldCoefficients(1.0);
  const Charts charts = restCharts(d0);
  std::vector<std::vector<int>> stencilDofs;
  withLayout([&](auto Dc, auto TWc) {
    constexpr int D = decltype(Dc)::value;
    constexpr bool TW = decltype(TWc)::value;
    const BuildCtx ctx = context(x, theta, d0, &hc, charts, 1.0, Terms::All);
    forEachStencil<D, TW>(ctx, [&](const auto&, const LocalStencil& ls, int) {
      stencilDofs.emplace_back(ls.sdofs, ls.sdofs + ls.ns);
    });
  });
  // Column-wise row lists of the lower triangle.
  std::vector<std::vector<int>> cols(nDofs_);
  for (int i = 0; i < nDofs_; ++i) cols[i].push_back(i);  // full diagonal, for shifts
  for (const auto& dofs : stencilDofs)
    for (int i : dofs)
      for (int j : dofs)
        if (i >= 0 && j >= 0 && i > j) cols[j].push_back(i);
  std::vector<int> outer(nDofs_ + 1, 0);
  for (int c = 0; c < nDofs_; ++c) {
    auto& rows = cols[c];
    std::sort(rows.begin(), rows.end());
    rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
    outer[c + 1] = outer[c] + static_cast<int>(rows.size());
  }
  hessianPattern_.resize(nDofs_, nDofs_);
  hessianPattern_.resizeNonZeros(outer[nDofs_]);
  for (int c = 0; c <= nDofs_; ++c) hessianPattern_.outerIndexPtr()[c] = outer[c];
  for (int c = 0; c < nDofs_; ++c) std::copy(cols[c].begin(), cols[c].end(), hessianPattern_.innerIndexPtr() + outer[c]);
  std::fill(hessianPattern_.valuePtr(), hessianPattern_.valuePtr() + outer[nDofs_], 0.0);

  stencils_.clear();
  stencilSlots_.clear();
  for (const auto& dofs : stencilDofs) {
    Stencil st;
    st.offset = static_cast<int>(stencilSlots_.size());
    st.size = static_cast<int>(dofs.size());
    for (int i = 0; i < st.size; ++i)
      for (int j = 0; j <= i; ++j) {
        int slot = -1;
        if (dofs[i] >= 0 && dofs[j] >= 0) {
          const int r = std::max(dofs[i], dofs[j]), c = std::min(dofs[i], dofs[j]);
          const int* b = hessianPattern_.innerIndexPtr() + outer[c];
          const int* e = hessianPattern_.innerIndexPtr() + outer[c + 1];
          slot = static_cast<int>(std::lower_bound(b, e, r) - hessianPattern_.innerIndexPtr());
        }
        stencilSlots_.push_back(slot);
      }
    stencils_.push_back(st);
  }
}


double PoseSystem::evaluate(const PoseState& s, const Design& d, Eigen::VectorXd* gradient,
                            Eigen::SparseMatrix<double>* hessian, Terms terms) const {
  detail::SimOut out;
  if (gradient) {
    gradient->setZero(nDofs_);
    out.gradient = gradient;
  }
  if (hessian) {
    const bool samePattern = hessian->rows() == nDofs_ && hessian->cols() == nDofs_ &&
                             hessian->nonZeros() == hessianPattern_.nonZeros() && hessian->isCompressed();
    if (samePattern) std::fill(hessian->valuePtr(), hessian->valuePtr() + hessian->nonZeros(), 0.0);
    else *hessian = hessianPattern_;
    out.hessian = hessian;
  }
  withLayout([&](auto Dc, auto TWc) { runSim<decltype(Dc)::value, decltype(TWc)::value>(s, d, terms, out); });
  return out.energy;
}

}  // namespace rodmesh
