// The energy terms rodmesh is built with, as term blocks (see
// model/terms/term_list.hh for what a block is and the list that registers
// them): stretch per edge, bend-twist per interior vertex, clamp coupling per
// (clamped vertex, incident edge), connection coupling per connection,
// gravity per edge, point forces per loaded vertex, twisting moments per
// loaded free end. The kernels (callables on the x locals of scalar S and the
// p locals of scalar P) wrap the energies of model/energies/*.hh. Internal to
// model/; not part of the API.
#pragma once

#include "model/energies/bend_twist.hh"
#include "model/energies/clamp.hh"
#include "model/energies/connection.hh"
#include "model/energies/gravity.hh"
#include "model/energies/stretch.hh"
#include "model/terms/stencil.hh"

#include <stdexcept>
#include <string>
#include <vector>

namespace rodmesh::detail {

// What a block's elements are built from, once per pose model.
struct TermSetup {
  const Scene& scene;
  const RodNetwork& net;
  const EffectSet& fx;
  const Pose& pose;
  std::vector<bool> clamped;  // per vertex
  bool twist;                 // twist unknowns are simulated
  bool bendOrTwist() const { return fx.has(Effect::Bend) || twist; }
};

// Kernels as callables on (x locals of scalar S, p locals of scalar P).
template <int D, bool TW>
struct StretchK {
  static constexpr int kNx = D, kNp = 7;
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
  static constexpr int kNx = 2 * D + (TW ? 2 : 0), kNp = 8;
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
      const EdgeState<S> a = edgeStateLifted<S, M>(x, 0, TW ? 2 * D : -1, off0, k.chartT0, k.chartD0, slots0);
      const EdgeState<S> b = edgeStateLifted<S, M>(x, D, TW ? 2 * D + 1 : -1, off1, k.chartT1, k.chartD1, slots1);
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
  EdgeState<S> edgeStateLifted(const S* x, int first, int theta, const Vec3& off, const Vec3& chartT,
                                         const Vec3& chartD, const int* slots) const {
    using Hm = ad::Hess<M, double>;
    constexpr int N = ad::IsHessDouble<S>::n;
    Hm w[3];
    for (int i = 0; i < D; ++i) w[i].makeVariable(x[first + i].v, i);
    const Hm th = theta >= 0 ? Hm::variable(x[theta].v, D) : Hm(0.0);
    const EdgeState<Hm> st = edgeState(embed<D>(w, off, *B), th, chartT, chartD);
    auto liftV = [&](const V3<Hm>& v) {
      return V3<S>(ad::lift<N, M>(v.x, slots), ad::lift<N, M>(v.y, slots), ad::lift<N, M>(v.z, slots));
    };
    return {liftV(st.t), liftV(st.u), liftV(st.m1), liftV(st.m2)};
  }
};
template <int D, bool TW>
struct ClampK {
  static constexpr int kNx = D + (TW ? 1 : 0), kNp = 5;
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
  static constexpr int kNx = K * D + (TW ? K : 0), kNp = 5 * K + 2;
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

// Gravity on one edge: linear in the positions, its mass a function of the
// design (evaluated in the scalar of the p locals: double in simulation).
template <int D, bool TW>
struct GravityK {
  static constexpr int kNx = 2 * D, kNp = 7;
  static constexpr bool kLinear = true;
  energies::GravityConst k;
  Vec3 offA, offB;
  const Mat32* B;
  template <class S, class P>
  S operator()(const S* x, const P* p) const {
    const P m = energies::gravityMass(V3<P>(p[0], p[1], p[2]), p[3], p[4], p[5], p[6], k);
    const S h = energies::gravityHeight(embed<D>(x, offA, *B), embed<D>(x + D, offB, *B), k);
    return h * (-0.5 * m);
  }
};

// A point force f on one vertex: E = -f . x.
template <int D, bool TW>
struct PointForceK {
  static constexpr int kNx = D, kNp = 0;
  static constexpr bool kLinear = true;
  Vec3 f, off;
  const Mat32* B;
  template <class S, class P>
  S operator()(const S* x, const P*) const {
    return dot(f, embed<D>(x, off, *B)) * -1.0;
  }
};

// A twisting moment m on one edge's twist: E = -m theta.
struct MomentK {
  static constexpr int kNx = 1, kNp = 0;
  static constexpr bool kLinear = true;
  double m;
  template <class S, class P>
  S operator()(const S* x, const P*) const {
    return x[0] * -m;
  }
};

// Local variable counts of a kernel, and whether it is linear in its x
// locals (then simulation needs no Hessian of it).
template <class K>
struct KernelSize {
  static constexpr int nx = K::kNx, np = K::kNp;
};
template <class K, class = void>
struct KernelLinear : std::false_type {};
template <class K>
struct KernelLinear<K, std::void_t<decltype(K::kLinear)>> : std::bool_constant<K::kLinear> {};

// ------------------------------------------------------------------------
// The blocks.

struct StretchTerm {
  static constexpr const char* kName = "stretch";
  static constexpr bool kLinear = false, kLoad = false, kDesign = true;
  struct Element {
    int edge;
  };
  static void collect(const TermSetup& s, std::vector<Element>& out) {
    if (!s.fx.has(Effect::Stretch)) return;
    for (int e = 0; e < s.net.numEdges(); ++e) out.push_back({e});
  }
  template <int D, bool TW, class Visit>
  static void visit(const Element& el, const BuildCtx& c, Visit&& visit) {
    LocalStencil ls;
    const Edge& ed = c.net->edges()[el.edge];
    const int pa = addVertex(ls, c, ed.a), pb = addVertex(ls, c, ed.b);
    StretchK<D, TW> kern{{c.scene->material.youngModulus}, addEdgeVars(ls, c, ed.a, ed.b, pa, pb), c.B};
    addRestEdge(ls, c, ed.a, ed.b);
    addRadii(ls, c, ed.a);
    addRadii(ls, c, ed.b);
    visit(kern, ls);
  }
};

struct BendTwistTerm {
  static constexpr const char* kName = "bend_twist";
  static constexpr bool kLinear = false, kLoad = false, kDesign = true;
  struct Element {
    int vertex, e0, e1;
  };
  static void collect(const TermSetup& s, std::vector<Element>& out) {
    if (!s.bendOrTwist()) return;
    for (const InteriorVertex& iv : s.net.interiorVertices())
      if (!s.clamped[iv.vertex]) out.push_back({iv.vertex, iv.edgeIn, iv.edgeOut});
  }
  template <int D, bool TW, class Visit>
  static void visit(const Element& el, const BuildCtx& c, Visit&& visit) {
    const auto& edges = c.net->edges();
    LocalStencil ls;
    const int a = edges[el.e0].a, v = el.vertex, b = edges[el.e1].b;
    const int pa = addVertex(ls, c, a), pv = addVertex(ls, c, v), pb = addVertex(ls, c, b);
    BendK<D, TW> kern;
    kern.k.n0 = c.net->edgeNormals()[el.e0];
    kern.k.n1 = c.net->edgeNormals()[el.e1];
    kern.k.chartT0 = c.charts->tangent[el.e0];
    kern.k.chartD0 = c.charts->director[el.e0];
    kern.k.chartT1 = c.charts->tangent[el.e1];
    kern.k.chartD1 = c.charts->director[el.e1];
    kern.k.youngModulus = c.scene->material.youngModulus;
    kern.k.shearModulus = c.scene->material.shearModulus();
    kern.k.bend = c.fx->has(Effect::Bend);
    kern.k.twist = TW;
    kern.B = c.B;
    kern.off0 = addEdgeVars(ls, c, a, v, pa, pv);
    kern.off1 = addEdgeVars(ls, c, v, b, pv, pb);
    if constexpr (TW) {
      const int t0 = addTheta(ls, c, el.e0), t1 = addTheta(ls, c, el.e1);
      addThetaVar(ls, c, el.e0, t0);
      addThetaVar(ls, c, el.e1, t1);
    }
    addRestEdge(ls, c, a, v);
    addRestEdge(ls, c, v, b);
    addRadii(ls, c, v);
    visit(kern, ls);
  }
};

struct ClampTerm {
  static constexpr const char* kName = "clamp";
  static constexpr bool kLinear = false, kLoad = false, kDesign = true;
  struct Element {
    int vertex, edge;
  };
  static void collect(const TermSetup& s, std::vector<Element>& out) {
    if (!s.bendOrTwist()) return;
    for (int v = 0; v < s.net.numVertices(); ++v)
      if (s.clamped[v])
        for (int e : s.net.vertexEdges()[v]) out.push_back({v, e});
  }
  template <int D, bool TW, class Visit>
  static void visit(const Element& el, const BuildCtx& c, Visit&& visit) {
    LocalStencil ls;
    const Edge& ed = c.net->edges()[el.edge];
    const int pa = addVertex(ls, c, ed.a), pb = addVertex(ls, c, ed.b);
    ClampK<D, TW> kern;
    kern.k.n = c.net->edgeNormals()[el.edge];
    kern.k.chartT = c.charts->tangent[el.edge];
    kern.k.chartD = c.charts->director[el.edge];
    kern.k.youngModulus = c.scene->material.youngModulus;
    kern.k.shearModulus = c.scene->material.shearModulus();
    kern.k.bend = c.fx->has(Effect::Bend);
    kern.k.twist = TW;
    kern.B = c.B;
    kern.off = addEdgeVars(ls, c, ed.a, ed.b, pa, pb);
    if constexpr (TW) addThetaVar(ls, c, el.edge, addTheta(ls, c, el.edge));
    addRestEdge(ls, c, ed.a, ed.b);
    addRadii(ls, c, el.vertex);
    visit(kern, ls);
  }
};

struct ConnectionTerm {
  static constexpr const char* kName = "connection";
  static constexpr bool kLinear = false, kLoad = false, kDesign = true;
  struct Element {
    int vertex;
    int k;
    int edges[energies::kMaxConnectionValence];
  };
  static void collect(const TermSetup& s, std::vector<Element>& out) {
    if (!s.fx.has(Effect::Connections) || !s.bendOrTwist()) return;
    for (const Connection& cn : s.net.connections()) {
      if (s.clamped[cn.vertex]) continue;  // the clamp holds every incident edge
      const int k = static_cast<int>(cn.edges.size());
      if (k > energies::kMaxConnectionValence)
        throw std::invalid_argument("connection at vertex " + std::to_string(cn.vertex) + " joins " +
                                    std::to_string(k) + " edges; at most " +
                                    std::to_string(energies::kMaxConnectionValence) + " are supported");
      Element el{cn.vertex, k, {}};
      for (int i = 0; i < k; ++i) el.edges[i] = cn.edges[i];
      out.push_back(el);
    }
  }
  template <int D, bool TW, class Visit>
  static void visit(const Element& el, const BuildCtx& c, Visit&& visit) {
    switch (el.k) {
      case 2: visitK<D, TW, 2>(el, c, visit); break;
      case 3: visitK<D, TW, 3>(el, c, visit); break;
      case 4: visitK<D, TW, 4>(el, c, visit); break;
      case 5: visitK<D, TW, 5>(el, c, visit); break;
      default: visitK<D, TW, 6>(el, c, visit); break;
    }
  }
  template <int D, bool TW, int K, class Visit>
  static void visitK(const Element& el, const BuildCtx& c, Visit& visit) {
    static_assert(K <= energies::kMaxConnectionValence, "connection valence");
    const auto& edges = c.net->edges();
    LocalStencil ls;
    const int pc = addVertex(ls, c, el.vertex);
    int pfar[K];
    int far[K];
    for (int i = 0; i < K; ++i) {
      const Edge& e = edges[el.edges[i]];
      far[i] = e.a == el.vertex ? e.b : e.a;
      pfar[i] = addVertex(ls, c, far[i]);
    }
    ConnectionK<D, TW, K> kern;
    kern.k.youngModulus = c.scene->material.youngModulus;
    kern.k.shearModulus = c.scene->material.shearModulus();
    kern.k.bend = c.fx->has(Effect::Bend);
    kern.k.twist = TW;
    kern.B = c.B;
    for (int i = 0; i < K; ++i) {
      const Edge& e = edges[el.edges[i]];
      kern.k.n[i] = c.net->edgeNormals()[el.edges[i]];
      kern.k.chartT[i] = c.charts->tangent[el.edges[i]];
      kern.k.chartD[i] = c.charts->director[el.edges[i]];
      const bool out = e.a == el.vertex;
      kern.off[i] = addEdgeVars(ls, c, e.a, e.b, out ? pc : pfar[i], out ? pfar[i] : pc);
    }
    if constexpr (TW)
      for (int i = 0; i < K; ++i) addThetaVar(ls, c, el.edges[i], addTheta(ls, c, el.edges[i]));
    for (int i = 0; i < K; ++i) addRestEdge(ls, c, edges[el.edges[i]].a, edges[el.edges[i]].b);
    addRadii(ls, c, el.vertex);
    for (int i = 0; i < K; ++i) addRadii(ls, c, far[i]);
    visit(kern, ls);
  }
};

// Gravity (scaled by the load factor) on each edge's mass, lumped half to
// each end: the one implementation, for simulation and design derivatives.
struct GravityTerm {
  static constexpr const char* kName = "gravity";
  static constexpr bool kLinear = true, kLoad = true, kDesign = true;
  struct Element {
    int edge;
  };
  static void collect(const TermSetup& s, std::vector<Element>& out) {
    if (!s.fx.has(Effect::Gravity) || !s.scene.gravity) return;
    for (int e = 0; e < s.net.numEdges(); ++e) out.push_back({e});
  }
  template <int D, bool TW, class Visit>
  static void visit(const Element& el, const BuildCtx& c, Visit&& visit) {
    LocalStencil ls;
    const Edge& e = c.net->edges()[el.edge];
    GravityK<D, TW> kern;
    kern.k.g = c.loadFactor * *c.scene->gravity;
    kern.k.density = c.scene->material.density;
    kern.B = c.B;
    const int pa = addVertex(ls, c, e.a), pb = addVertex(ls, c, e.b);
    kern.offA = addPointVars(ls, c, e.a, pa);
    kern.offB = addPointVars(ls, c, e.b, pb);
    addRestEdge(ls, c, e.a, e.b);
    addRadii(ls, c, e.a);
    addRadii(ls, c, e.b);
    visit(kern, ls);
  }
};

// Point forces (scaled by the load factor), summed per vertex. A force on a
// held vertex does no work on the unknowns but depends on the design through
// the vertex's rest position.
struct PointForceTerm {
  static constexpr const char* kName = "point_force";
  static constexpr bool kLinear = true, kLoad = true, kDesign = false;
  struct Element {
    int vertex;
    Vec3 force;
  };
  static void collect(const TermSetup& s, std::vector<Element>& out) {
    std::vector<Vec3> f(s.net.numVertices(), Vec3::Zero());
    for (const PointForce& pf : s.pose.forces) f[pf.vertex] += pf.force;
    for (int v = 0; v < s.net.numVertices(); ++v)
      if (f[v].squaredNorm() > 0) out.push_back({v, f[v]});
  }
  template <int D, bool TW, class Visit>
  static void visit(const Element& el, const BuildCtx& c, Visit&& visit) {
    LocalStencil ls;
    PointForceK<D, TW> kern;
    kern.f = c.loadFactor * el.force;
    kern.B = c.B;
    kern.off = addPointVars(ls, c, el.vertex, addVertex(ls, c, el.vertex));
    visit(kern, ls);
  }
};

// Twisting moments (scaled by the load factor) on the end edge at a free
// rod end, about the direction out of the rod; only where twist is simulated.
struct MomentTerm {
  static constexpr const char* kName = "moment";
  static constexpr bool kLinear = true, kLoad = true, kDesign = false;
  struct Element {
    int edge;
    double moment;  // about the edge direction a -> b
  };
  static void collect(const TermSetup& s, std::vector<Element>& out) {
    if (!s.twist) return;
    for (const TwistingMoment& m : s.pose.twistingMoments) {
      // theta turns the frame about the edge direction a -> b; the moment
      // is about the outward direction.
      const int e = s.net.vertexEdges()[m.vertex].front();
      const double sign = s.net.edges()[e].b == m.vertex ? 1.0 : -1.0;
      out.push_back({e, sign * m.moment});
    }
  }
  template <int D, bool TW, class Visit>
  static void visit(const Element& el, const BuildCtx& c, Visit&& visit) {
    // Elements exist only with twist unknowns (collect).
    if constexpr (TW) {
      LocalStencil ls;
      addThetaVar(ls, c, el.edge, addTheta(ls, c, el.edge));
      visit(MomentK{c.loadFactor * el.moment}, ls);
    }
  }
};

}  // namespace rodmesh::detail
