#include "model/pose_system.hh"

#include "model/energies/bend_twist.hh"
#include "model/energies/clamp.hh"
#include "model/energies/connection.hh"
#include "model/energies/gravity.hh"
#include "model/energies/stretch.hh"

#include <algorithm>
#include <exception>
#include <functional>
#include <pthread.h>
#include <limits>
#include <stdexcept>
#include <type_traits>

namespace rodmesh {

Eigen::VectorXd Design::toVector() const {
  const int n = static_cast<int>(restPositions.size());
  Eigen::VectorXd p(5 * n);
  for (int v = 0; v < n; ++v) {
    p.segment<3>(3 * v) = restPositions[v];
    p.segment<2>(3 * n + 2 * v) = radii[v];
  }
  return p;
}

void Design::fromVector(const Eigen::VectorXd& p) {
  const int n = static_cast<int>(p.size() / 5);
  restPositions.resize(n);
  radii.resize(n);
  for (int v = 0; v < n; ++v) {
    restPositions[v] = p.segment<3>(3 * v);
    radii[v] = p.segment<2>(3 * n + 2 * v);
  }
}

namespace {

using Mat32 = Eigen::Matrix<double, 3, 2>;

// How a local variable of a kernel depends on the stencil's unknowns (x) or on
// the design parameters (p): sum of at most two coef * variable.
struct LinMap {
  int idx[2];
  double coef[2];
  void set(int i0, double c0, int i1 = -1, double c1 = 0.0) {
    idx[0] = i0; coef[0] = c0; idx[1] = i1; coef[1] = c1;
  }
};

constexpr int kMaxLocal = 32;    // local variables of one kind (x or p) per stencil
constexpr int kMaxStencil = 28;  // unknowns per stencil

// Builds a 3-vector from D local scalars w and a constant offset c:
// D = 3: the scalars themselves; D = 2: c + B w.
template <int D, class S>
V3<S> embed(const S* w, const Vec3& c, const Mat32& B) {
  if constexpr (D == 3) {
    return V3<S>(w[0], w[1], w[2]);
  } else {
    V3<S> r;
    for (int i = 0; i < 3; ++i) r[i] = S(c[i]) + w[0] * B(i, 0) + w[1] * B(i, 1);
    return r;
  }
}

double partOf(double x, bool) { return x; }
double partOf(const ad::Dual& x, bool derivative) { return derivative ? x.d : x.v; }

// One stencil, described by its local variables: values, maps to the stencil's
// unknowns (x part) and to design parameters (p part).
struct LocalStencil {
  // Filled incrementally by the add* builders; only the first nx / np / ns
  // entries are meaningful.
  int nx = 0, np = 0;
  double xv[kMaxLocal];
  double pv[kMaxLocal];
  LinMap xmap[kMaxLocal];
  LinMap pmap[kMaxLocal];
  int ns = 0;
  int sdofs[kMaxStencil];  // global unknown per stencil position, -1 if held
};

// Evaluates kernel `k` on the local stencil with N seeded variables: the x
// variables only (N == nx, p constants) or x and p (N == nx + np). With a
// direction (T = Dual) the x variables carry it in their dual parts.
template <int N, class T, bool Joint, class Kern>
ad::Hess<N, T> evalLocal(const Kern& k, const LocalStencil& ls, const double* xdir) {
  using H = ad::Hess<N, T>;
  H x[N];
  const int nx = ls.nx;
  for (int i = 0; i < nx; ++i) {
    T val;
    if constexpr (std::is_same_v<T, ad::Dual>) val = ad::Dual(ls.xv[i], xdir ? xdir[i] : 0.0);
    else val = ls.xv[i];
    x[i] = H::variable(val, i);
  }
  if constexpr (!Joint) {
    // Simulation: design data are constants, evaluated in double.
    return k(x, ls.pv);
  } else {
    for (int i = 0; i < ls.np; ++i) x[nx + i] = H::variable(T(ls.pv[i]), nx + i);
    return k(x, x + nx);
  }
}

// Adds a sim-mode result (x variables only) into the global gradient and the
// Hessian value slots.
template <int N>
void scatterSim(const ad::Hess<N, double>& r, const LocalStencil& ls, const int* slots, Eigen::VectorXd* g,
                double* hv) {
  if (g) {
    for (int k = 0; k < ls.nx; ++k)
      for (int a = 0; a < 2; ++a) {
        const int pos = ls.xmap[k].idx[a];
        if (pos < 0) continue;
        const int I = ls.sdofs[pos];
        if (I >= 0) (*g)[I] += ls.xmap[k].coef[a] * r.g[k];
      }
  }
  if (hv) {
    double Hs[kMaxStencil][kMaxStencil] = {};
    for (int k = 0; k < ls.nx; ++k)
      for (int l = 0; l <= k; ++l) {
        const double h = r.h[ad::Hess<N, double>::hidx(k, l)];
        if (h == 0.0) continue;
        for (int a = 0; a < 2; ++a) {
          const int pa = ls.xmap[k].idx[a];
          if (pa < 0) continue;
          for (int b = 0; b < 2; ++b) {
            const int pb = ls.xmap[l].idx[b];
            if (pb < 0) continue;
            const double c = ls.xmap[k].coef[a] * ls.xmap[l].coef[b] * h;
            Hs[pa][pb] += c;
            if (k != l) Hs[pb][pa] += c;
          }
        }
      }
    int s = 0;
    for (int i = 0; i < ls.ns; ++i)
      for (int j = 0; j <= i; ++j, ++s)
        if (slots[s] >= 0) hv[slots[s]] += Hs[i][j];
  }
}

// Adds a joint-mode result into gradients and Hessian-block triplets.
template <int N, class T>
void scatterJoint(const ad::Hess<N, T>& r, const LocalStencil& ls, bool derivative, JointDerivatives& out) {
  const int nx = ls.nx;
  auto globalX = [&](int k, int a, int& I, double& c) {
    const int pos = ls.xmap[k].idx[a];
    if (pos < 0) return false;
    I = ls.sdofs[pos];
    c = ls.xmap[k].coef[a];
    return I >= 0;
  };
  auto globalP = [&](int k, int a, int& I, double& c) {
    I = ls.pmap[k].idx[a];
    c = ls.pmap[k].coef[a];
    return I >= 0;
  };
  out.energy += partOf(r.v, derivative);
  for (int k = 0; k < N; ++k) {
    const double gk = partOf(r.g[k], derivative);
    if (gk == 0.0) continue;
    for (int a = 0; a < 2; ++a) {
      int I;
      double c;
      if (k < nx) {
        if (globalX(k, a, I, c)) out.gu[I] += c * gk;
      } else if (globalP(k - nx, a, I, c)) {
        out.gp[I] += c * gk;
      }
    }
  }
  for (int k = 0; k < N; ++k)
    for (int l = 0; l < N; ++l) {
      const double h = partOf(r.h[ad::Hess<N, T>::hidx(k, l)], derivative);
      if (h == 0.0) continue;
      for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b) {
          int I, J;
          double ca, cb;
          const bool kx = k < nx, lx = l < nx;
          const bool okI = kx ? globalX(k, a, I, ca) : globalP(k - nx, a, I, ca);
          if (!okI) continue;
          const bool okJ = lx ? globalX(l, b, J, cb) : globalP(l - nx, b, J, cb);
          if (!okJ) continue;
          const double v = ca * cb * h;
          if (kx && lx) {
            if (I >= J) out.Huu.emplace_back(I, J, v);
          } else if (kx && !lx) {
            out.Hup.emplace_back(I, J, v);
          } else if (!kx && !lx) {
            if (I >= J) out.Hpp.emplace_back(I, J, v);
          }
        }
    }
}

}  // namespace

// ------------------------------------------------------------------------

PoseSystem::PoseSystem(const Scene& scene, const RodNetwork& network, const EffectSet& effects, int poseIndex)
    : scene_(scene), net_(network), fx_(effects), pose_(poseIndex) {
  const Pose& pose = scene.poses.at(poseIndex);
  const int nv = network.numVertices();
  const int ne = network.numEdges();
  D_ = fx_.planar ? 2 : 3;
  twist_ = fx_.has(Effect::Twist);

  held_.assign(nv, false);
  heldTarget_ = scene.vertices;
  for (const FixedVertex& f : pose.fixed) {
    held_[f.vertex] = true;
    if (f.position) heldTarget_[f.vertex] = *f.position;
  }
  std::vector<bool> clamped(nv, false);
  for (const ClampedVertex& c : pose.clamped) {
    held_[c.vertex] = true;
    clamped[c.vertex] = true;
  }
  pointForce_.assign(nv, Vec3::Zero());
  for (const PointForce& f : pose.forces) pointForce_[f.vertex] += f.force;
  for (const TwistingMoment& m : pose.twistingMoments) {
    // The edge at the free end; theta turns the frame about the edge
    // direction a -> b, the moment is about the outward direction.
    const int e = network.vertexEdges()[m.vertex].front();
    const double sign = network.edges()[e].b == m.vertex ? 1.0 : -1.0;
    edgeMoment_.emplace_back(e, sign * m.moment);
  }

  vertexDof_.assign(nv, -1);
  int n = 0;
  for (int v = 0; v < nv; ++v)
    if (!held_[v]) { vertexDof_[v] = n; n += D_; }
  nVertexDofs_ = n;
  nDofs_ = n + (twist_ ? ne : 0);

  double total = 0.0;
  for (const Edge& e : network.edges()) total += (scene.vertices[e.b] - scene.vertices[e.a]).norm();
  momentArm_ = total / std::max(1, ne);

  if (fx_.has(Effect::Stretch))
    for (int e = 0; e < ne; ++e) stretch_.push_back({e});
  if (fx_.has(Effect::Bend) || twist_)
    for (const InteriorVertex& iv : network.interiorVertices())
      if (!clamped[iv.vertex]) bend_.push_back({iv.vertex, iv.edgeIn, iv.edgeOut});
  if (fx_.has(Effect::Bend) || twist_)
    for (int v = 0; v < nv; ++v)
      if (clamped[v])
        for (int e : network.vertexEdges()[v]) clamp_.push_back({v, e});
  if (fx_.has(Effect::Connections) && (fx_.has(Effect::Bend) || twist_))
    for (const Connection& c : network.connections()) {
      if (clamped[c.vertex]) continue;  // the clamp holds every incident edge
      const int k = static_cast<int>(c.edges.size());
      if (k > energies::kMaxConnectionValence)
        throw std::invalid_argument("connection at vertex " + std::to_string(c.vertex) + " joins " + std::to_string(k) +
                                    " edges; at most " + std::to_string(energies::kMaxConnectionValence) + " are supported");
      ConnSt st{c.vertex, k, {}};
      for (int i = 0; i < k; ++i) st.edges[i] = c.edges[i];
      conn_.push_back(st);
    }

  for (int e = 0; e < ne; ++e) sceneRestFrames_.push_back(network.restFrame(e, scene.vertices));
  resetCharts(Design::fromScene(scene));
  buildPattern();
}

void PoseSystem::resetCharts(const Design& d) {
  const int ne = net_.numEdges();
  chartT_.resize(ne);
  chartD_.resize(ne);
  for (int e = 0; e < ne; ++e) {
    const EdgeFrame f = net_.restFrame(e, d.restPositions);
    chartT_[e] = f.t;
    chartD_[e] = f.d1;
  }
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

bool PoseSystem::reanchorCharts(const Eigen::VectorXd& u, double cosLimit) {
  const std::vector<Vec3> x = positions(u);
  bool changed = false;
  for (int e = 0; e < net_.numEdges(); ++e) {
    const Edge& ed = net_.edges()[e];
    const Vec3 t = (x[ed.b] - x[ed.a]).normalized();
    if (t.dot(chartT_[e]) >= cosLimit) continue;
    chartD_[e] = transportD(chartT_[e], t, chartD_[e]).normalized();
    chartT_[e] = t;
    changed = true;
  }
  return changed;
}

Eigen::VectorXd PoseSystem::materialTwists(const Eigen::VectorXd& u) const {
  Eigen::VectorXd th = twists(u);
  if (!twist_) return th;
  const std::vector<Vec3> x = positions(u);
  for (int e = 0; e < net_.numEdges(); ++e) {
    const Edge& ed = net_.edges()[e];
    const Vec3 t = (x[ed.b] - x[ed.a]).normalized();
    const Vec3 ref = transportD(chartT_[e], t, chartD_[e]);
    const Vec3 restRef = transportD(sceneRestFrames_[e].t, t, sceneRestFrames_[e].d1);
    th[e] += signedAngleD(restRef, ref, t);
  }
  return th;
}

Vec3 PoseSystem::heldPosition(int v) const {
  return scene_.vertices[v] + loadFactor_ * (heldTarget_[v] - scene_.vertices[v]);
}

std::vector<Vec3> PoseSystem::positions(const Eigen::VectorXd& u) const {
  std::vector<Vec3> x(vertexDof_.size());
  for (std::size_t v = 0; v < x.size(); ++v) {
    const int k = vertexDof_[v];
    if (k < 0) x[v] = heldPosition(static_cast<int>(v));
    else if (D_ == 3) x[v] = u.segment<3>(k);
    else x[v] = fx_.planeOrigin + fx_.planeBasis * u.segment<2>(k);
  }
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

// Calls fn(dofs, count) for every stencil with a Hessian, in the fixed order
// stretch, bend, clamp.
template <class Fn>
void PoseSystem::forEachStencilDofs(Fn&& fn) const {
  int buf[kMaxStencil];
  auto vtx = [&](int v, int& n) {
    for (int k = 0; k < D_; ++k) buf[n++] = vertexDof_[v] < 0 ? -1 : vertexDof_[v] + k;
  };
  const auto& edges = net_.edges();
  for (const StretchSt& s : stretch_) {
    int n = 0;
    vtx(edges[s.edge].a, n);
    vtx(edges[s.edge].b, n);
    fn(buf, n);
  }
  for (const BendSt& s : bend_) {
    int n = 0;
    vtx(edges[s.e0].a, n);
    vtx(s.vertex, n);
    vtx(edges[s.e1].b, n);
    if (twist_) { buf[n++] = thetaDof(s.e0); buf[n++] = thetaDof(s.e1); }
    fn(buf, n);
  }
  for (const ClampSt& s : clamp_) {
    int n = 0;
    vtx(edges[s.edge].a, n);
    vtx(edges[s.edge].b, n);
    if (twist_) buf[n++] = thetaDof(s.edge);
    fn(buf, n);
  }
  for (const ConnSt& s : conn_) {
    int n = 0;
    vtx(s.vertex, n);
    for (int i = 0; i < s.k; ++i) {
      const Edge& e = edges[s.edges[i]];
      vtx(e.a == s.vertex ? e.b : e.a, n);
    }
    if (twist_)
      for (int i = 0; i < s.k; ++i) buf[n++] = thetaDof(s.edges[i]);
    fn(buf, n);
  }
}

void PoseSystem::buildPattern() {
  // Column-wise row lists of the lower triangle.
  std::vector<std::vector<int>> cols(nDofs_);
  for (int i = 0; i < nDofs_; ++i) cols[i].push_back(i);  // full diagonal, for shifts
  forEachStencilDofs([&](const int* dofs, int n) {
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        if (dofs[i] >= 0 && dofs[j] >= 0 && dofs[i] > dofs[j]) cols[dofs[j]].push_back(dofs[i]);
  });
  std::vector<int> outer(nDofs_ + 1, 0);
  for (int c = 0; c < nDofs_; ++c) {
    auto& rows = cols[c];
    std::sort(rows.begin(), rows.end());
    rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
    outer[c + 1] = outer[c] + static_cast<int>(rows.size());
  }
  hessian_.resize(nDofs_, nDofs_);
  hessian_.resizeNonZeros(outer[nDofs_]);
  for (int c = 0; c <= nDofs_; ++c) hessian_.outerIndexPtr()[c] = outer[c];
  for (int c = 0; c < nDofs_; ++c)
    std::copy(cols[c].begin(), cols[c].end(), hessian_.innerIndexPtr() + outer[c]);
  std::fill(hessian_.valuePtr(), hessian_.valuePtr() + outer[nDofs_], 0.0);

  stencils_.clear();
  stencilDofs_.clear();
  stencilSlots_.clear();
  forEachStencilDofs([&](const int* dofs, int n) {
    Stencil st;
    st.offset = static_cast<int>(stencilSlots_.size());
    st.size = n;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j <= i; ++j) {
        int slot = -1;
        if (dofs[i] >= 0 && dofs[j] >= 0) {
          const int r = std::max(dofs[i], dofs[j]), c = std::min(dofs[i], dofs[j]);
          const int* b = hessian_.innerIndexPtr() + outer[c];
          const int* e = hessian_.innerIndexPtr() + outer[c + 1];
          slot = static_cast<int>(std::lower_bound(b, e, r) - hessian_.innerIndexPtr());
        }
        stencilSlots_.push_back(slot);
      }
    stencils_.push_back(st);
  });
}

// ------------------------------------------------------------------------
// Local stencil builders: values and maps of each kernel's local variables.

namespace {

struct BuildCtx {
  const std::vector<Vec3>* x;      // current positions
  const Eigen::VectorXd* theta;    // current twists (zeros without twist)
  const Design* d;
  const std::vector<int>* vdof;
  const Mat32* B;
  Vec3 origin;
  int D;
  bool twist;
  int nThetaBase;  // first theta unknown
};

// Appends vertex v's unknowns to the stencil; returns its first position.
int addVertex(LocalStencil& ls, const BuildCtx& c, int v) {
  const int pos = ls.ns;
  const int k = (*c.vdof)[v];
  for (int i = 0; i < c.D; ++i) ls.sdofs[ls.ns++] = k < 0 ? -1 : k + i;
  return pos;
}
int addTheta(LocalStencil& ls, const BuildCtx& c, int e) {
  const int pos = ls.ns;
  ls.sdofs[ls.ns++] = c.nThetaBase + e;
  return pos;
}

// Local x variables for an edge vector from vertex a (stencil position pa) to
// b (pb): D scalars w with e = off + B w; returns the offset.
Vec3 addEdgeVars(LocalStencil& ls, const BuildCtx& c, int a, int b, int pa, int pb) {
  const Vec3 e = (*c.x)[b] - (*c.x)[a];
  Vec3 off = Vec3::Zero();
  if (c.D == 3) {
    for (int i = 0; i < 3; ++i) ls.xv[ls.nx + i] = e[i];
  } else {
    const Eigen::Vector2d w = c.B->transpose() * e;
    off = e - (*c.B) * w;
    ls.xv[ls.nx] = w[0];
    ls.xv[ls.nx + 1] = w[1];
  }
  for (int i = 0; i < c.D; ++i) ls.xmap[ls.nx + i].set(pb + i, 1.0, pa + i, -1.0);
  ls.nx += c.D;
  return off;
}

// Local x variables for a vertex position: x = off + B w (D == 2) or w.
Vec3 addPointVars(LocalStencil& ls, const BuildCtx& c, int v, int pv) {
  const Vec3 x = (*c.x)[v];
  Vec3 off = Vec3::Zero();
  if (c.D == 3) {
    for (int i = 0; i < 3; ++i) ls.xv[ls.nx + i] = x[i];
  } else {
    const Eigen::Vector2d w = c.B->transpose() * (x - c.origin);
    off = x - (*c.B) * w;
    ls.xv[ls.nx] = w[0];
    ls.xv[ls.nx + 1] = w[1];
  }
  for (int i = 0; i < c.D; ++i) ls.xmap[ls.nx + i].set(pv + i, 1.0);
  ls.nx += c.D;
  return off;
}

void addThetaVar(LocalStencil& ls, const BuildCtx& c, int e, int pos) {
  ls.xv[ls.nx] = (*c.theta)[e];
  ls.xmap[ls.nx].set(pos, 1.0);
  ls.nx++;
}

// Design variables: rest edge vector (a -> b), then radii of listed vertices.
void addRestEdge(LocalStencil& ls, const BuildCtx& c, int a, int b) {
  const Vec3 E = c.d->restPositions[b] - c.d->restPositions[a];
  for (int i = 0; i < 3; ++i) {
    ls.pv[ls.np] = E[i];
    ls.pmap[ls.np].set(Design::restIndex(b, i), 1.0, Design::restIndex(a, i), -1.0);
    ls.np++;
  }
}
void addRadii(LocalStencil& ls, const BuildCtx& c, int v) {
  for (int i = 0; i < 2; ++i) {
    ls.pv[ls.np] = c.d->radii[v][i];
    ls.pmap[ls.np].set(c.d->radiusIndex(v, i), 1.0);
    ls.np++;
  }
}

// Kernels as callables on (x locals of scalar S, p locals of scalar P).
template <int D, bool TW>
struct StretchK {
  energies::StretchConst k;
  Vec3 off;
  const Mat32* B;
  template <class S, class P>
  S operator()(const S* x, const P* p) const {
    const V3<S> e = embed<D>(x, off, *B);
    const auto rest = energies::stretchRest(V3<P>(p[0], p[1], p[2]), p[3], p[4], p[5], p[6], k);
    return energies::stretchEnergy(e, rest);
  }
};
template <int D, bool TW>
struct BendK {
  energies::BendTwistConst k;
  Vec3 off0, off1;
  const Mat32* B;
  template <class S, class P>
  S operator()(const S* x, const P* p) const {
    const S th0 = TW ? x[2 * D] : S(0.0);
    const S th1 = TW ? x[2 * D + 1] : S(0.0);
    const auto rest = energies::bendTwistRest(V3<P>(p[0], p[1], p[2]), V3<P>(p[3], p[4], p[5]), p[6], p[7], k);
    if constexpr (ad::IsHessDouble<S>::value && std::is_same_v<P, double>) {
      // Simulation: each edge's frame depends on its own D + 1 variables;
      // differentiate it over those and lift into the stencil's variables.
      constexpr int M = D + (TW ? 1 : 0);
      const int slots0[4] = {0, 1, D == 3 ? 2 : 2 * D, 2 * D};
      const int slots1[4] = {D, D + 1, D == 3 ? D + 2 : 2 * D + 1, 2 * D + 1};
      const energies::EdgeState<S> a = edgeStateLifted<S, M>(x, 0, TW ? 2 * D : -1, off0, k.chartT0, k.chartD0, slots0);
      const energies::EdgeState<S> b = edgeStateLifted<S, M>(x, D, TW ? 2 * D + 1 : -1, off1, k.chartT1, k.chartD1, slots1);
      return energies::bendTwistFromStates(a, b, th0, th1, rest, k);
    } else {
      const V3<S> e0 = embed<D>(x, off0, *B);
      const V3<S> e1 = embed<D>(x + D, off1, *B);
      return energies::bendTwistEnergy(e0, e1, th0, th1, rest, k);
    }
  }

  // The state of one edge from its D position variables (at x[first]) and
  // its twist (x[theta], or none), differentiated over M = D (+1) variables
  // and lifted to the stencil's variable slots.
  template <class S, int M>
  energies::EdgeState<S> edgeStateLifted(const S* x, int first, int theta, const Vec3& off, const Vec3& chartT,
                                         const Vec3& chartD, const int* slots) const {
    using Hm = ad::Hess<M, double>;
    constexpr int N = ad::IsHessDouble<S>::n;
    Hm w[3];
    for (int i = 0; i < D; ++i) w[i] = Hm::variable(x[first + i].v, i);
    const Hm th = theta >= 0 ? Hm::variable(x[theta].v, D) : Hm(0.0);
    const energies::EdgeState<Hm> st = energies::edgeState(embed<D>(w, off, *B), th, chartT, chartD);
    auto liftV = [&](const V3<Hm>& v) {
      return V3<S>(ad::lift<N, M>(v.x, slots), ad::lift<N, M>(v.y, slots), ad::lift<N, M>(v.z, slots));
    };
    return {liftV(st.t), liftV(st.u), liftV(st.m1), liftV(st.m2)};
  }
};
template <int D, bool TW>
struct ClampK {
  energies::ClampConst k;
  Vec3 off;
  const Mat32* B;
  template <class S, class P>
  S operator()(const S* x, const P* p) const {
    const V3<S> e = embed<D>(x, off, *B);
    const S th = TW ? x[D] : S(0.0);
    const auto rest = energies::clampRest(V3<P>(p[0], p[1], p[2]), p[3], p[4], k);
    return energies::clampEnergy(e, th, rest, k);
  }
};
template <int D, bool TW, int K>
struct ConnectionK {
  energies::ConnectionConst<K> k;
  Vec3 off[K];
  const Mat32* B;
  template <class S, class P>
  S operator()(const S* x, const P* p) const {
    V3<S> e[K];
    S th[K];
    for (int i = 0; i < K; ++i) {
      e[i] = embed<D>(x + D * i, off[i], *B);
      th[i] = TW ? x[D * K + i] : S(0.0);
    }
    V3<P> E[K];
    for (int i = 0; i < K; ++i) E[i] = V3<P>(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
    const auto rest = energies::connectionRest<P, K>(E, p + 3 * K, k);
    return energies::connectionEnergy<S, P, K>(e, th, rest, k);
  }
};

template <int D, bool TW>
struct GravityK {
  energies::GravityConst k;
  Vec3 offA, offB;
  const Mat32* B;
  template <class S, class P>
  S operator()(const S* x, const P* p) const {
    static_assert(std::is_same_v<S, P>, "gravity is evaluated with AD in joint mode only");
    const V3<S> xa = embed<D>(x, offA, *B);
    const V3<S> xb = embed<D>(x + D, offB, *B);
    const V3<S> E(p[0], p[1], p[2]);
    return energies::gravityEnergy(xa, xb, E, p[3], p[4], p[5], p[6], k);
  }
};

}  // namespace

// Visits every energy stencil: builds its LocalStencil and kernel and hands
// them to `visit(kernel, stencil, stencilIndexOrMinus1)`.
#define RODMESH_FOR_EACH_STENCIL(D, TW, CTX, VISIT)                                                    \
  do {                                                                                                 \
    const auto& edges_ = net_.edges();                                                                 \
    const double E_ = scene_.material.youngModulus, G_ = scene_.material.shearModulus();               \
    int sidx_ = 0;                                                                                     \
    if (use(Terms::Stretch))                                                                           \
      for (const StretchSt& s : stretch_) {                                                            \
        LocalStencil ls;                                                                               \
        const Edge& ed = edges_[s.edge];                                                               \
        const int pa = addVertex(ls, CTX, ed.a), pb = addVertex(ls, CTX, ed.b);                        \
        StretchK<D, TW> kern{{E_}, addEdgeVars(ls, CTX, ed.a, ed.b, pa, pb), (CTX).B};                 \
        addRestEdge(ls, CTX, ed.a, ed.b);                                                              \
        addRadii(ls, CTX, ed.a);                                                                       \
        addRadii(ls, CTX, ed.b);                                                                       \
        VISIT(kern, ls, sidx_);                                                                        \
        ++sidx_;                                                                                       \
      }                                                                                                \
    else                                                                                               \
      sidx_ += static_cast<int>(stretch_.size());                                                      \
    if (use(Terms::BendTwist))                                                                         \
      for (const BendSt& s : bend_) {                                                                  \
        LocalStencil ls;                                                                               \
        const int a = edges_[s.e0].a, v = s.vertex, c = edges_[s.e1].b;                                \
        const int pa = addVertex(ls, CTX, a), pv = addVertex(ls, CTX, v), pc = addVertex(ls, CTX, c);  \
        BendK<D, TW> kern;                                                                             \
        kern.k.n0 = net_.edgeNormals()[s.e0];                                                          \
        kern.k.n1 = net_.edgeNormals()[s.e1];                                                          \
        kern.k.chartT0 = chartT_[s.e0];                                                                \
        kern.k.chartD0 = chartD_[s.e0];                                                                \
        kern.k.chartT1 = chartT_[s.e1];                                                                \
        kern.k.chartD1 = chartD_[s.e1];                                                                \
        kern.k.youngModulus = E_;                                                                      \
        kern.k.shearModulus = G_;                                                                      \
        kern.k.bend = fx_.has(Effect::Bend);                                                           \
        kern.k.twist = TW;                                                                             \
        kern.B = (CTX).B;                                                                              \
        kern.off0 = addEdgeVars(ls, CTX, a, v, pa, pv);                                                \
        kern.off1 = addEdgeVars(ls, CTX, v, c, pv, pc);                                                \
        if (TW) {                                                                                      \
          const int t0 = addTheta(ls, CTX, s.e0), t1 = addTheta(ls, CTX, s.e1);                        \
          addThetaVar(ls, CTX, s.e0, t0);                                                              \
          addThetaVar(ls, CTX, s.e1, t1);                                                              \
        }                                                                                              \
        addRestEdge(ls, CTX, a, v);                                                                    \
        addRestEdge(ls, CTX, v, c);                                                                    \
        addRadii(ls, CTX, v);                                                                          \
        VISIT(kern, ls, sidx_);                                                                        \
        ++sidx_;                                                                                       \
      }                                                                                                \
    else                                                                                               \
      sidx_ += static_cast<int>(bend_.size());                                                         \
    if (use(Terms::Clamp))                                                                             \
      for (const ClampSt& s : clamp_) {                                                                \
        LocalStencil ls;                                                                               \
        const Edge& ed = edges_[s.edge];                                                               \
        const int pa = addVertex(ls, CTX, ed.a), pb = addVertex(ls, CTX, ed.b);                        \
        ClampK<D, TW> kern;                                                                            \
        kern.k.n = net_.edgeNormals()[s.edge];                                                         \
        kern.k.chartT = chartT_[s.edge];                                                               \
        kern.k.chartD = chartD_[s.edge];                                                               \
        kern.k.youngModulus = E_;                                                                      \
        kern.k.shearModulus = G_;                                                                      \
        kern.k.bend = fx_.has(Effect::Bend);                                                           \
        kern.k.twist = TW;                                                                             \
        kern.B = (CTX).B;                                                                              \
        kern.off = addEdgeVars(ls, CTX, ed.a, ed.b, pa, pb);                                           \
        if (TW) addThetaVar(ls, CTX, s.edge, addTheta(ls, CTX, s.edge));                               \
        addRestEdge(ls, CTX, ed.a, ed.b);                                                              \
        addRadii(ls, CTX, s.vertex);                                                                   \
        VISIT(kern, ls, sidx_);                                                                        \
        ++sidx_;                                                                                       \
      }                                                                                                \
    else                                                                                               \
      sidx_ += static_cast<int>(clamp_.size());                                                        \
    if (use(Terms::Connection))                                                                        \
      for (const ConnSt& s : conn_) {                                                                  \
        switch (s.k) {                                                                                 \
          case 2: visitConnection<D, TW, 2>(s, CTX, VISIT, sidx_); break;                              \
          case 3: visitConnection<D, TW, 3>(s, CTX, VISIT, sidx_); break;                              \
          case 4: visitConnection<D, TW, 4>(s, CTX, VISIT, sidx_); break;                              \
          case 5: visitConnection<D, TW, 5>(s, CTX, VISIT, sidx_); break;                              \
          case 6: visitConnection<D, TW, 6>(s, CTX, VISIT, sidx_); break;                              \
          default: break;                                                                              \
        }                                                                                              \
        ++sidx_;                                                                                       \
      }                                                                                                \
  } while (0)

namespace {
template <class K> struct KernelSize;
template <int D, bool TW> struct KernelSize<StretchK<D, TW>> { static constexpr int nx = D, np = 7; };
template <int D, bool TW> struct KernelSize<BendK<D, TW>> { static constexpr int nx = 2 * D + (TW ? 2 : 0), np = 8; };
template <int D, bool TW> struct KernelSize<ClampK<D, TW>> { static constexpr int nx = D + (TW ? 1 : 0), np = 5; };
template <int D, bool TW> struct KernelSize<GravityK<D, TW>> { static constexpr int nx = 2 * D, np = 7; };
template <int D, bool TW, int K>
struct KernelSize<ConnectionK<D, TW, K>> { static constexpr int nx = K * D + (TW ? K : 0), np = 5 * K + 2; };
}  // namespace

template <int D, bool TW, int K, class Ctx, class Visit>
void PoseSystem::visitConnection(const ConnSt& s, const Ctx& ctx, Visit& visit, int sidx) const {
  const auto& edges = net_.edges();
  LocalStencil ls;
  const int pc = addVertex(ls, ctx, s.vertex);
  int pfar[K];
  int far[K];
  for (int i = 0; i < K; ++i) {
    const Edge& e = edges[s.edges[i]];
    far[i] = e.a == s.vertex ? e.b : e.a;
    pfar[i] = addVertex(ls, ctx, far[i]);
  }
  ConnectionK<D, TW, K> kern;
  kern.k.youngModulus = scene_.material.youngModulus;
  kern.k.shearModulus = scene_.material.shearModulus();
  kern.k.bend = fx_.has(Effect::Bend);
  kern.k.twist = TW;
  kern.B = ctx.B;
  for (int i = 0; i < K; ++i) {
    const Edge& e = edges[s.edges[i]];
    kern.k.n[i] = net_.edgeNormals()[s.edges[i]];
    kern.k.chartT[i] = chartT_[s.edges[i]];
    kern.k.chartD[i] = chartD_[s.edges[i]];
    const bool out = e.a == s.vertex;
    kern.off[i] = addEdgeVars(ls, ctx, e.a, e.b, out ? pc : pfar[i], out ? pfar[i] : pc);
  }
  if constexpr (TW)
    for (int i = 0; i < K; ++i) addThetaVar(ls, ctx, s.edges[i], addTheta(ls, ctx, s.edges[i]));
  for (int i = 0; i < K; ++i) addRestEdge(ls, ctx, edges[s.edges[i]].a, edges[s.edges[i]].b);
  addRadii(ls, ctx, s.vertex);
  for (int i = 0; i < K; ++i) addRadii(ls, ctx, far[i]);
  visit(kern, ls, sidx);
}

// Gravity and point forces are linear in the positions: they add to the
// gradient only (no Hessian) in simulation.
template <int D, bool TW, class Out>
void PoseSystem::runSim(const Eigen::VectorXd& u, const Design& d, Out& out) const {
  const std::vector<Vec3> x = positions(u);
  const Eigen::VectorXd theta = twists(u);
  const Mat32 B = fx_.planeBasis;
  BuildCtx ctx{&x, &theta, &d, &vertexDof_, &B, fx_.planeOrigin, D, TW, nVertexDofs_};
  double* hv = out.hessian ? out.hessian->valuePtr() : nullptr;
  auto visit = [&](const auto& kern, const LocalStencil& ls, int sidx) {
    using K = std::decay_t<decltype(kern)>;
    constexpr int NX = KernelSize<K>::nx;
    if (!out.gradient && !hv) {
      double xs[kMaxLocal], ps[kMaxLocal];
      std::copy(ls.xv, ls.xv + ls.nx, xs);
      std::copy(ls.pv, ls.pv + ls.np, ps);
      out.energy += kern(xs, ps);
      return;
    }
    if (!hv) {
      // Forces only: first-order AD.
      using G = ad::Grad<NX, double>;
      G x[NX];
      for (int i = 0; i < ls.nx; ++i) x[i] = G::variable(ls.xv[i], i);
      const G r = kern(x, ls.pv);
      out.energy += r.v;
      for (int k = 0; k < ls.nx; ++k)
        for (int a = 0; a < 2; ++a) {
          const int pos = ls.xmap[k].idx[a];
          if (pos < 0) continue;
          const int I = ls.sdofs[pos];
          if (I >= 0) (*out.gradient)[I] += ls.xmap[k].coef[a] * r.g[k];
        }
      return;
    }
    const ad::Hess<NX, double> r = evalLocal<NX, double, false>(kern, ls, nullptr);
    out.energy += r.v;
    scatterSim<NX>(r, ls, stencilSlots_.data() + stencils_[sidx].offset, out.gradient, hv);
  };
  RODMESH_FOR_EACH_STENCIL(D, TW, ctx, visit);

  // External loads: gravity (lumped edge masses) and point forces, scaled by
  // the load factor.
  const auto& edges = net_.edges();
  auto addLoad = [&](int v, const Vec3& f) {
    out.energy -= f.dot(x[v]);
    const int k = vertexDof_[v];
    if (k < 0 || !out.gradient) return;
    if constexpr (D == 3) out.gradient->template segment<3>(k) -= f;
    else out.gradient->template segment<2>(k) -= B.transpose() * f;
  };
  if (fx_.has(Effect::Gravity) && use(Terms::Gravity)) {
    const Vec3 g = loadFactor_ * *scene_.gravity;
    const double rho = scene_.material.density;
    for (const Edge& e : edges) {
      const double L = (d.restPositions[e.b] - d.restPositions[e.a]).norm();
      const double m = 0.5 * L *
                       (stiffness::massPerLength(rho, d.radii[e.a][0], d.radii[e.a][1]) +
                        stiffness::massPerLength(rho, d.radii[e.b][0], d.radii[e.b][1]));
      addLoad(e.a, 0.5 * m * g);
      addLoad(e.b, 0.5 * m * g);
    }
  }
  if (use(Terms::Forces)) {
    for (std::size_t v = 0; v < pointForce_.size(); ++v)
      if (pointForce_[v].squaredNorm() > 0) addLoad(static_cast<int>(v), loadFactor_ * pointForce_[v]);
    if constexpr (TW)
      for (const auto& [e, m] : edgeMoment_) {
        out.energy -= loadFactor_ * m * theta[e];
        if (out.gradient) (*out.gradient)[thetaDof(e)] -= loadFactor_ * m;
      }
  }
}

namespace {
struct SimOut {
  double energy = 0.0;
  Eigen::VectorXd* gradient = nullptr;
  Eigen::SparseMatrix<double>* hessian = nullptr;
};
}  // namespace

#define RODMESH_DISPATCH(FN, ...)                    \
  do {                                               \
    if (D_ == 3 && twist_) FN<3, true>(__VA_ARGS__);  \
    else if (D_ == 3) FN<3, false>(__VA_ARGS__);      \
    else if (twist_) FN<2, true>(__VA_ARGS__);        \
    else FN<2, false>(__VA_ARGS__);                   \
  } while (0)

double PoseSystem::energy(const Eigen::VectorXd& u, const Design& d) const {
  SimOut out;
  RODMESH_DISPATCH(runSim, u, d, out);
  return out.energy;
}

void PoseSystem::evaluate(const Eigen::VectorXd& u, const Design& d, double& e, Eigen::VectorXd& g,
                          bool wantHessian) {
  g.setZero(nDofs_);
  SimOut out;
  out.gradient = &g;
  if (wantHessian) {
    std::fill(hessian_.valuePtr(), hessian_.valuePtr() + hessian_.nonZeros(), 0.0);
    out.hessian = &hessian_;
  }
  RODMESH_DISPATCH(runSim, u, d, out);
  e = out.energy;
}

template <int D, bool TW, class T>
void PoseSystem::runJoint(const Eigen::VectorXd& u, const Design& d, const Eigen::VectorXd* v,
                          JointDerivatives& out) const {
  const std::vector<Vec3> x = positions(u);
  const Eigen::VectorXd theta = twists(u);
  const Mat32 B = fx_.planeBasis;
  BuildCtx ctx{&x, &theta, &d, &vertexDof_, &B, fx_.planeOrigin, D, TW, nVertexDofs_};
  const bool derivative = v != nullptr;
  auto localDir = [&](const LocalStencil& ls, double* dir) {
    for (int k = 0; k < ls.nx; ++k) {
      dir[k] = 0.0;
      for (int a = 0; a < 2; ++a) {
        const int pos = ls.xmap[k].idx[a];
        if (pos >= 0 && ls.sdofs[pos] >= 0) dir[k] += ls.xmap[k].coef[a] * (*v)[ls.sdofs[pos]];
      }
    }
  };
  auto visit = [&](const auto& kern, const LocalStencil& ls, int) {
    using K = std::decay_t<decltype(kern)>;
    constexpr int N = KernelSize<K>::nx + KernelSize<K>::np;
    double dir[kMaxLocal];
    if (derivative) localDir(ls, dir);
    const ad::Hess<N, T> r = evalLocal<N, T, true>(kern, ls, derivative ? dir : nullptr);
    scatterJoint<N, T>(r, ls, derivative, out);
  };
  RODMESH_FOR_EACH_STENCIL(D, TW, ctx, visit);

  if (fx_.has(Effect::Gravity) && use(Terms::Gravity)) {
    GravityK<D, TW> kern;
    kern.k.g = loadFactor_ * *scene_.gravity;
    kern.k.density = scene_.material.density;
    kern.B = &B;
    for (const Edge& e : net_.edges()) {
      LocalStencil ls;
      const int pa = addVertex(ls, ctx, e.a), pb = addVertex(ls, ctx, e.b);
      kern.offA = addPointVars(ls, ctx, e.a, pa);
      kern.offB = addPointVars(ls, ctx, e.b, pb);
      addRestEdge(ls, ctx, e.a, e.b);
      addRadii(ls, ctx, e.a);
      addRadii(ls, ctx, e.b);
      visit(kern, ls, -1);
    }
  }
  if (use(Terms::Forces))
    for (std::size_t vi = 0; vi < pointForce_.size(); ++vi) {
      const Vec3 f = loadFactor_ * pointForce_[vi];
      if (f.squaredNorm() == 0) continue;
      const int k = vertexDof_[vi];
      if (derivative) {
        // D_v of the value -f.x; gradient and Hessian of a linear term have
        // zero directional derivative.
        if (k >= 0) {
          Eigen::Vector3d dx = D == 3 ? Eigen::Vector3d(v->segment<3>(k)) : Eigen::Vector3d(B * v->segment<2>(k));
          out.energy -= f.dot(dx);
        }
        continue;
      }
      out.energy -= f.dot(x[vi]);
      if (k < 0) continue;
      if constexpr (D == 3) out.gu.template segment<3>(k) -= f;
      else out.gu.template segment<2>(k) -= B.transpose() * f;
    }
  if (use(Terms::Forces) && TW)
    for (const auto& [e, m] : edgeMoment_) {
      if (derivative) {
        out.energy -= loadFactor_ * m * (*v)[thetaDof(e)];
      } else {
        out.energy -= loadFactor_ * m * theta[e];
        out.gu[thetaDof(e)] -= loadFactor_ * m;
      }
    }
}

namespace {
// Joint derivatives of large stencils (a six-valent connection has 56 local
// variables: a Hessian scalar of 26 kB, and the kernel keeps hundreds of
// them) need more stack than a default thread has: run on a thread with a
// 1 GiB stack reservation (virtual; only what is touched is committed).
void runWithLargeStack(const std::function<void()>& fn) {
  pthread_attr_t attr;
  pthread_attr_init(&attr);
  pthread_attr_setstacksize(&attr, std::size_t(1) << 30);
  struct Payload {
    const std::function<void()>* fn;
    std::exception_ptr error;
  } payload{&fn, nullptr};
  auto trampoline = [](void* arg) -> void* {
    auto* p = static_cast<Payload*>(arg);
    try {
      (*p->fn)();
    } catch (...) {
      p->error = std::current_exception();
    }
    return nullptr;
  };
  pthread_t thread;
  if (pthread_create(&thread, &attr, trampoline, &payload) != 0) {
    pthread_attr_destroy(&attr);
    fn();  // fall back to the current thread
    return;
  }
  pthread_join(thread, nullptr);
  pthread_attr_destroy(&attr);
  if (payload.error) std::rethrow_exception(payload.error);
}
}  // namespace

JointDerivatives PoseSystem::joint(const Eigen::VectorXd& u, const Design& d) const {
  JointDerivatives out;
  out.gu.setZero(nDofs_);
  out.gp.setZero(d.numParameters());
  runWithLargeStack([&] { jointImpl(u, d, nullptr, out); });
  return out;
}

void PoseSystem::jointImpl(const Eigen::VectorXd& u, const Design& d, const Eigen::VectorXd* v,
                           JointDerivatives& out) const {
  if (v) {
    if (D_ == 3 && twist_) runJoint<3, true, ad::Dual>(u, d, v, out);
    else if (D_ == 3) runJoint<3, false, ad::Dual>(u, d, v, out);
    else if (twist_) runJoint<2, true, ad::Dual>(u, d, v, out);
    else runJoint<2, false, ad::Dual>(u, d, v, out);
    return;
  }
  if (D_ == 3 && twist_) runJoint<3, true, double>(u, d, nullptr, out);
  else if (D_ == 3) runJoint<3, false, double>(u, d, nullptr, out);
  else if (twist_) runJoint<2, true, double>(u, d, nullptr, out);
  else runJoint<2, false, double>(u, d, nullptr, out);
}

JointDerivatives PoseSystem::jointDirectional(const Eigen::VectorXd& u, const Design& d,
                                              const Eigen::VectorXd& v) const {
  JointDerivatives out;
  out.gu.setZero(nDofs_);
  out.gp.setZero(d.numParameters());
  runWithLargeStack([&] { jointImpl(u, d, &v, out); });
  return out;
}

}  // namespace rodmesh
