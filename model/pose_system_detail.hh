// Internal to model/pose_system*.cc: local stencils, kernel callables and the
// stencil iteration shared by the simulation path (pose_system.cc) and the
// joint-derivative path (pose_system_joint.cc). Not part of the API.
#pragma once

#include "model/energies/bend_twist.hh"
#include "model/energies/clamp.hh"
#include "model/energies/connection.hh"
#include "model/energies/gravity.hh"
#include "model/energies/stretch.hh"
#include "model/pose_system.hh"

#include <type_traits>

namespace rodmesh::detail {

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

inline double partOf(double x, bool) { return x; }
inline double partOf(const ad::Dual& x, bool derivative) { return derivative ? x.d : x.v; }

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

// ------------------------------------------------------------------------
// Local stencil builders: values and maps of each kernel's local variables.

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
inline int addVertex(LocalStencil& ls, const BuildCtx& c, int v) {
  const int pos = ls.ns;
  const int k = (*c.vdof)[v];
  for (int i = 0; i < c.D; ++i) ls.sdofs[ls.ns++] = k < 0 ? -1 : k + i;
  return pos;
}
inline int addTheta(LocalStencil& ls, const BuildCtx& c, int e) {
  const int pos = ls.ns;
  ls.sdofs[ls.ns++] = c.nThetaBase + e;
  return pos;
}

// Local x variables for an edge vector from vertex a (stencil position pa) to
// b (pb): D scalars w with e = off + B w; returns the offset.
inline Vec3 addEdgeVars(LocalStencil& ls, const BuildCtx& c, int a, int b, int pa, int pb) {
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
inline Vec3 addPointVars(LocalStencil& ls, const BuildCtx& c, int v, int pv) {
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

inline void addThetaVar(LocalStencil& ls, const BuildCtx& c, int e, int pos) {
  ls.xv[ls.nx] = (*c.theta)[e];
  ls.xmap[ls.nx].set(pos, 1.0);
  ls.nx++;
}

// Design variables: rest edge vector (a -> b), then radii of listed vertices.
inline void addRestEdge(LocalStencil& ls, const BuildCtx& c, int a, int b) {
  const Vec3 E = c.d->restPositions[b] - c.d->restPositions[a];
  for (int i = 0; i < 3; ++i) {
    ls.pv[ls.np] = E[i];
    ls.pmap[ls.np].set(Design::restIndex(b, i), 1.0, Design::restIndex(a, i), -1.0);
    ls.np++;
  }
}
inline void addRadii(LocalStencil& ls, const BuildCtx& c, int v) {
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

template <class K> struct KernelSize;
template <int D, bool TW> struct KernelSize<StretchK<D, TW>> { static constexpr int nx = D, np = 7; };
template <int D, bool TW> struct KernelSize<BendK<D, TW>> { static constexpr int nx = 2 * D + (TW ? 2 : 0), np = 8; };
template <int D, bool TW> struct KernelSize<ClampK<D, TW>> { static constexpr int nx = D + (TW ? 1 : 0), np = 5; };
template <int D, bool TW> struct KernelSize<GravityK<D, TW>> { static constexpr int nx = 2 * D, np = 7; };
template <int D, bool TW, int K>
struct KernelSize<ConnectionK<D, TW, K>> { static constexpr int nx = K * D + (TW ? K : 0), np = 5 * K + 2; };

}  // namespace rodmesh::detail

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

namespace rodmesh {
using namespace detail;

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
}  // namespace rodmesh
