// The local stencil of one energy term element and the builders that fill it:
// the element's local variables (x: functions of the pose's unknowns; p:
// design parameters), their values at the evaluated state, and how each maps
// to unknowns and design parameters. Term blocks (model/terms/term_list.hh)
// build one LocalStencil per element with these and hand it, with the
// element's kernel, to the evaluation that walks the list. Internal to
// model/; not part of the API.
#pragma once

#include "model/ad.hh"
#include "model/energies/rod_math.hh"
#include "model/network.hh"
#include "model/pose_system.hh"

#include <algorithm>
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
  int sdofs[kMaxStencil];    // global unknown per stencil position, -1 if held
  int svertex[kMaxStencil];  // vertex whose coordinate a position is, -1 for a twist
  int scoord[kMaxStencil];   // which of the vertex's D coordinates
};

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
  // Per vertex, for held vertices: d(position)/d(rest position of the same
  // vertex) under the current load factor (1 when held at its rest position,
  // 1 - load factor when held at an explicit position); unused for free ones.
  const std::vector<double>* heldCoef = nullptr;
  // The evaluated state's charts and load factor, and the terms evaluated.
  const Charts* charts = nullptr;
  double loadFactor = 1.0;
  TermSet terms = TermSet::All;
  // The state's internal variables, every block's (PoseState::internal;
  // never null): forEachStencil hands each element its own segment.
  const double* internal = nullptr;
  // What the elements were built from (constants of the pose).
  const Scene* scene = nullptr;
  const RodNetwork* net = nullptr;
  const EffectSet* fx = nullptr;
};

// Appends vertex v's unknowns to the stencil; returns its first position.
inline int addVertex(LocalStencil& ls, const BuildCtx& c, int v) {
  const int pos = ls.ns;
  const int k = (*c.vdof)[v];
  for (int i = 0; i < c.D; ++i) {
    ls.svertex[ls.ns] = v;
    ls.scoord[ls.ns] = i;
    ls.sdofs[ls.ns++] = k < 0 ? -1 : k + i;
  }
  return pos;
}
inline int addTheta(LocalStencil& ls, const BuildCtx& c, int e) {
  const int pos = ls.ns;
  ls.svertex[ls.ns] = -1;
  ls.scoord[ls.ns] = 0;
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

}  // namespace rodmesh::detail
