// Internal to model/pose_system*.cc: evaluation of the term blocks' kernels
// (model/terms/term_list.hh) in simulation and joint modes, and the stencil
// iteration shared by the simulation path (pose_system.cc) and the
// joint-derivative path (pose_system_joint.cc). Not part of the API.
#pragma once

#include "model/pose_system.hh"
#include "model/terms/term_list.hh"

#include <algorithm>
#include <type_traits>

namespace rodmesh::detail {

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
    x[i].makeVariable(val, i);
  }
  if constexpr (!Joint) {
    // Simulation: design data are constants, evaluated in double.
    return k(x, ls.pv);
  } else {
    for (int i = 0; i < ls.np; ++i) x[nx + i].makeVariable(T(ls.pv[i]), nx + i);
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

// What a simulation evaluation fills (PoseSystem::runSim).
struct SimOut {
  double energy = 0.0;
  Eigen::VectorXd* gradient = nullptr;
  Eigen::SparseMatrix<double>* hessian = nullptr;
};

// Joint value slots are stored as block << kSlotShift | index (block 0: Huu,
// 1: Hup, 2: Hpp).
constexpr int kSlotShift = 28;

// ------------------------------------------------------------------------
// Joint (u, p) derivatives of one kernel over all its local variables (the x
// part first, then the p part): evalJoint. The reference is evalLocal with
// every local variable seeded in one Hess<N> (generic, used for the small
// kernels). Bend-twist and connections, which dominate, instead differentiate
// each piece over the few variables it depends on (an edge's state over that
// edge's D (+1) locals, the rest quantities over the p locals, in double: a
// direction only enters through x) and combine the pieces exactly by the
// chain rule (ad::lift, ad::compose). tests/model/joint_kernel_test.cc checks
// every such kernel against the reference.

// A kernel's local variable i as a T: value x, directional part dir[i].
template <class T>
T seedValue(double x, const double* dir, int i) {
  if constexpr (std::is_same_v<T, ad::Dual>) return ad::Dual(x, dir ? dir[i] : 0.0);
  else return x;
}

template <int N>
struct Iota {
  int s[N];
  constexpr Iota(int first) : s() {
    for (int i = 0; i < N; ++i) s[i] = first + i;
  }
};

// The state of one edge from its D position locals (at x[first]) and its
// twist local (x[theta], or none), differentiated over those M = D (+1)
// locals and lifted into a Hess<N, T> whose variable slots[a] is local a.
template <int N, int D, bool TW, class T>
EdgeState<ad::Hess<N, T>> edgeStateJoint(const LocalStencil& ls, const double* xdir, int first, int theta,
                                                   const Vec3& off, const Mat32& B, const Vec3& chartT,
                                                   const Vec3& chartD, const int* slots) {
  constexpr int M = D + (TW ? 1 : 0);
  using Hm = ad::Hess<M, T>;
  Hm w[3];
  for (int i = 0; i < D; ++i) w[i].makeVariable(seedValue<T>(ls.xv[first + i], xdir, first + i), i);
  Hm th(0.0);
  if constexpr (TW) th.makeVariable(seedValue<T>(ls.xv[theta], xdir, theta), D);
  const EdgeState<Hm> st = edgeState(embed<D>(w, off, B), th, chartT, chartD);
  auto liftV = [&](const V3<Hm>& v) {
    using S = ad::Hess<N, T>;
    return V3<S>(ad::lift<N, M>(v.x, slots), ad::lift<N, M>(v.y, slots), ad::lift<N, M>(v.z, slots));
  };
  return {liftV(st.t), liftV(st.u), liftV(st.m1), liftV(st.m2)};
}

template <int N, class T, class Kern>
ad::Hess<N, T> evalJoint(const Kern& k, const LocalStencil& ls, const double* xdir) {
  return evalLocal<N, T, true>(k, ls, xdir);
}

// Stretch: the current edge length (over the x locals) and the rest length
// and stiffness (over the p locals) meet in stretchEnergyOfLength.
template <int N, class T, int D, bool TW>
ad::Hess<N, T> evalJoint(const StretchK<D, TW>& k, const LocalStencil& ls, const double* xdir) {
  constexpr int NX = KernelSize<StretchK<D, TW>>::nx, NP = KernelSize<StretchK<D, TW>>::np;
  static_assert(N == NX + NP && NP == 7, "stretch: x and p locals");
  using HX = ad::Hess<NX, T>;
  HX w[3];
  for (int i = 0; i < D; ++i) w[i].makeVariable(seedValue<T>(ls.xv[i], xdir, i), i);
  const HX len = norm(embed<D>(w, k.off, *k.B));
  using HP = ad::Hess<NP, double>;
  HP p[NP];
  for (int i = 0; i < NP; ++i) p[i].makeVariable(ls.pv[i], i);
  const energies::StretchRest<HP> rest = energies::stretchRest(V3<HP>(p[0], p[1], p[2]), p[3], p[4], p[5], p[6], k.k);
  static constexpr Iota<NP> id(0);
  const ad::Hess<NP, T> L = ad::liftAs<NP, NP, T>(rest.length, id.s), c = ad::liftAs<NP, NP, T>(rest.halfKOverL, id.s);
  using HO = ad::Hess<3, T>;
  const HO y0 = HO::variable(len.v, 0);
  const energies::StretchRest<HO> r{HO::variable(L.v, 1), HO::variable(c.v, 2)};
  const HO f = energies::stretchEnergyOfLength(y0, r);
  const ad::Inner<T> in[3] = {ad::inner(len, 0), ad::inner(L, NX), ad::inner(c, NX)};
  return ad::compose<N, 3, T>(f, in);
}

// Gravity: linear in the positions; the mass over the p locals.
template <int N, class T, int D, bool TW>
ad::Hess<N, T> evalJoint(const GravityK<D, TW>& k, const LocalStencil& ls, const double* xdir) {
  constexpr int NX = KernelSize<GravityK<D, TW>>::nx, NP = KernelSize<GravityK<D, TW>>::np;
  static_assert(N == NX + NP && NP == 7, "gravity: x and p locals");
  using HX = ad::Hess<NX, T>;
  HX w[2 * D];
  for (int i = 0; i < 2 * D; ++i) w[i].makeVariable(seedValue<T>(ls.xv[i], xdir, i), i);
  const HX height = energies::gravityHeight(embed<D>(w, k.offA, *k.B), embed<D>(w + D, k.offB, *k.B), k.k);
  using HP = ad::Hess<NP, double>;
  HP p[NP];
  for (int i = 0; i < NP; ++i) p[i].makeVariable(ls.pv[i], i);
  static constexpr Iota<NP> id(0);
  const ad::Hess<NP, T> m =
      ad::liftAs<NP, NP, T>(energies::gravityMass(V3<HP>(p[0], p[1], p[2]), p[3], p[4], p[5], p[6], k.k), id.s);
  using HO = ad::Hess<2, T>;
  const HO f = energies::gravityOf(HO::variable(m.v, 0), HO::variable(height.v, 1));
  const ad::Inner<T> in[2] = {ad::inner(m, NX), ad::inner(height, 0)};
  return ad::compose<N, 2, T>(f, in);
}

// Bend-twist: the current side (bendTwistCurrent: 5 scalars over the x
// locals, from the edge states) and the rest side (bendTwistRestShape: 5
// scalars over the rest edges E0, E1, from their frames; the stiffness
// coefficients over E0, E1 and the radii) meet only in bendTwistCombine,
// evaluated over their differences, the twist difference and the
// stiffnesses (9 scalars), then composed.
template <int N, class T, int D, bool TW>
ad::Hess<N, T> evalJoint(const BendK<D, TW>& k, const LocalStencil& ls, const double* xdir) {
  constexpr int NX = KernelSize<BendK<D, TW>>::nx, NP = KernelSize<BendK<D, TW>>::np;
  static_assert(N == NX + NP && NP == 8, "bend-twist: x and p locals");
  using HX = ad::Hess<NX, T>;
  const int slots0[4] = {0, 1, D == 3 ? 2 : 2 * D, 2 * D};
  const int slots1[4] = {D, D + 1, D == 3 ? D + 2 : 2 * D + 1, 2 * D + 1};
  const EdgeState<HX> a =
      edgeStateJoint<NX, D, TW, T>(ls, xdir, 0, 2 * D, k.off0, *k.B, k.k.chartT0, k.k.chartD0, slots0);
  const EdgeState<HX> b =
      edgeStateJoint<NX, D, TW, T>(ls, xdir, D, 2 * D + 1, k.off1, *k.B, k.k.chartT1, k.k.chartD1, slots1);
  const energies::BendTwistCurrent<HX> cur = energies::bendTwistCurrent(a, b, k.k);

  // Rest side, in double (a direction never enters the design): each rest
  // frame over its own edge (p locals 0..2, 3..5), lifted to both edges.
  using H3 = ad::Hess<3, double>;
  using H6 = ad::Hess<6, double>;
  using H8 = ad::Hess<8, double>;
  FrameT<H6> F[2];
  H6 len[2];
  for (int e = 0; e < 2; ++e) {
    const V3<H3> E(H3::variable(ls.pv[3 * e], 0), H3::variable(ls.pv[3 * e + 1], 1), H3::variable(ls.pv[3 * e + 2], 2));
    const FrameT<H3> f = restFrameOf(E, e == 0 ? k.k.n0 : k.k.n1);
    const int sl[3] = {3 * e, 3 * e + 1, 3 * e + 2};
    auto liftV = [&](const V3<H3>& v) {
      return V3<H6>(ad::lift<6, 3>(v.x, sl), ad::lift<6, 3>(v.y, sl), ad::lift<6, 3>(v.z, sl));
    };
    F[e] = {liftV(f.t), liftV(f.d1), liftV(f.d2)};
    len[e] = ad::lift<6, 3>(norm(E), sl);
  }
  energies::BendTwistRest<H6> shape;
  energies::bendTwistRestShape(F[0], F[1], shape);
  // Stiffness coefficients over (l, r_t, r_n), composed into the p locals.
  const H6 l = energies::bendTwistRestLength(len[0], len[1]);
  energies::BendTwistRest<H3> st;
  energies::bendTwistRestStiffness(H3::variable(l.v, 0), H3::variable(ls.pv[6], 1), H3::variable(ls.pv[7], 2), k.k,
                                   st);
  static const double oneD = 1.0;
  const ad::Inner<double> lr[3] = {ad::inner(l, 0), {&oneD, nullptr, 1, 6}, {&oneD, nullptr, 1, 7}};
  const H8 kc[3] = {ad::compose<8, 3, double>(st.kIn, lr), ad::compose<8, 3, double>(st.kOut, lr),
                    ad::compose<8, 3, double>(st.kTwist, lr)};
  // As T (a no-op for double); the shape terms negated.
  static constexpr Iota<6> id6(0);
  static constexpr Iota<8> id8(0);
  const H6* sh[5] = {&shape.wa1, &shape.wa2, &shape.wb1, &shape.wb2, &shape.psiRest};
  ad::Hess<6, T> negShape[5];
  ad::Hess<8, T> kT[3];
  for (int j = 0; j < 5; ++j) negShape[j] = -ad::liftAs<6, 6, T>(*sh[j], id6.s);
  for (int j = 0; j < 3; ++j) kT[j] = ad::liftAs<8, 8, T>(kc[j], id8.s);

  // Outer variables: the differences current - rest of the four curvature
  // components and of the reference twist (each a function of the x locals
  // plus one of the p locals), theta1 - theta0, and the three stiffnesses;
  // bendTwistCombine with zero rest curvature and twist is the energy.
  constexpr int M = 9;
  using HO = ad::Hess<M, T>;
  const HX* cs[5] = {&cur.wa1, &cur.wa2, &cur.wb1, &cur.wb2, &cur.psi};
  HO y[M];
  for (int j = 0; j < 5; ++j) y[j].makeVariable(cs[j]->v + negShape[j].v, j);
  const T th0 = TW ? seedValue<T>(ls.xv[2 * D], xdir, 2 * D) : T(0.0);
  const T th1 = TW ? seedValue<T>(ls.xv[2 * D + 1], xdir, 2 * D + 1) : T(0.0);
  y[5].makeVariable(th1 - th0, 5);
  for (int j = 0; j < 3; ++j) y[6 + j].makeVariable(kT[j].v, 6 + j);
  const energies::BendTwistCurrent<HO> cw{y[0], y[1], y[2], y[3], y[4]};
  const energies::BendTwistRest<HO> rw{HO(0.0), HO(0.0), HO(0.0), HO(0.0), y[6], y[7], y[8], HO(0.0)};
  const HO f = energies::bendTwistCombine(cw, HO(0.0), y[5], rw, k.k);

  static const T dth[2] = {T(-1.0), T(1.0)};
  ad::Inner<T> in[M];
  for (int j = 0; j < 5; ++j) in[j] = {ad::innerPart(*cs[j], 0), ad::innerPart(negShape[j], NX)};
  in[5] = {dth, nullptr, TW ? 2 : 0, 2 * D};
  for (int j = 0; j < 3; ++j) in[6 + j] = ad::inner(kT[j], NX);
  return ad::compose<N, M, T>(f, in);
}

// The design side of a connection's fit A = B Minv (connectionFitWeights):
// M = sum_i wT_i T_i T_i^T + wN_i (D1_i D1_i^T + D2_i D2_i^T) with wT_i =
// trB_i / sum trB and wN_i = beta_i / sum beta, over the NP p locals, as
// MA = Minv / sum trB and MB = Minv / sum beta, so that the fit's factor of a
// tangent is MA^T (trB_i T_i) and that of a director MB^T (beta_i D_i), with
// (trB_i T_i) etc. over edge i's own 7 p locals. F3: the rest frames over
// their rest edges; ks: the stiffnesses over pslots[i].
template <int NP, int K>
struct ConnectionFitDesign {
  energies::M3<ad::Hess<NP, double>> MA, MB;
};
// Minv and the inverses of sum trB and sum beta (a frame of its own: its
// temporaries are gone when connectionFitDesign forms MA and MB).
template <int NP, int K>
[[gnu::noinline]] void connectionFitInverse(const FrameT<ad::Hess<3, double>>* F3,
                                            const energies::ConnectionEdgeStiffness<ad::Hess<7, double>>* ks,
                                            const int (*pslots)[7], energies::M3<ad::Hess<NP, double>>& Minv,
                                            ad::Hess<NP, double>& invA, ad::Hess<NP, double>& invB) {
  using HP = ad::Hess<NP, double>;
  using H7 = ad::Hess<7, double>;
  static constexpr Iota<3> e7(0);
  {
    HP sumA, sumB;
    for (int i = 0; i < K; ++i) {
      ad::addLifted(sumA, ks[i].trB, pslots[i]);
      ad::addLifted(sumB, ks[i].beta, pslots[i]);
    }
    invA = ad::inverse(sumA);
    invB = ad::inverse(sumB);
  }
  energies::M3<HP> M;  // zero; the lower triangle accumulated
  for (int i = 0; i < K; ++i) {
    const V3<ad::Hess<3, double>>* fs[3] = {&F3[i].t, &F3[i].d1, &F3[i].d2};
    H7 f[3][3];
    for (int q = 0; q < 3; ++q)
      for (int c = 0; c < 3; ++c) f[q][c] = ad::lift<7, 3>((*fs[q])[c], e7.s);
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b <= a; ++b) {
        ad::addProductLifted(M.a[a][b], invA, f[0][a] * f[0][b] * ks[i].trB, pslots[i]);
        ad::addProductLifted(M.a[a][b], invB, (f[1][a] * f[1][b] + f[2][a] * f[2][b]) * ks[i].beta, pslots[i]);
      }
  }
  for (int a = 0; a < 3; ++a)
    for (int b = a + 1; b < 3; ++b) M.a[a][b] = M.a[b][a];
  Minv = energies::inverse3(M);
}
template <int NP, int K>
[[gnu::noinline]] void connectionFitDesign(const FrameT<ad::Hess<3, double>>* F3,
                                           const energies::ConnectionEdgeStiffness<ad::Hess<7, double>>* ks,
                                           const int (*pslots)[7], ConnectionFitDesign<NP, K>& r) {
  using HP = ad::Hess<NP, double>;
  energies::M3<HP> Minv;
  HP invA, invB;
  connectionFitInverse<NP, K>(F3, ks, pslots, Minv, invA, invB);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      r.MA.a[a][b] = Minv.a[a][b] * invA;
      r.MB.a[a][b] = Minv.a[a][b] * invB;
    }
}

// The design factor of edge i's state component q (0: tangent, 1, 2: the
// directors) in the fit: A = sum_i,q X_iq H_iq^T with X_iq the state
// component (over the edge's x locals) and H_iq[c] = sum_c' Mq[c'][c] w F[c']
// over the p locals (w F: trB_i T_i or beta_i D_i, over pslots[i]).
template <int NP>
void connectionFitFactor(const energies::M3<ad::Hess<NP, double>>& Mq, const V3<ad::Hess<3, double>>& F,
                         const ad::Hess<7, double>& w, const int* pslots, ad::Hess<NP, double>* H) {
  static constexpr Iota<3> e7(0);
  ad::Hess<7, double> wF[3];
  for (int c = 0; c < 3; ++c) wF[c] = ad::lift<7, 3>(F[c], e7.s) * w;
  for (int c = 0; c < 3; ++c) {
    H[c] = ad::Hess<NP, double>();
    for (int cc = 0; cc < 3; ++cc) ad::addProductLifted(H[c], Mq.a[cc][c], wF[cc], pslots);
  }
}

// Calls f(X_iq, H_iq, i) for every incident edge i and state component q
// (0: tangent, 1, 2: directors) of a connection's fit (see evalJoint below),
// the design factors H_iq formed on the way.
template <int NP, int MX, class T, int K, class F>
void forEachFitProduct(const ConnectionFitDesign<NP, K>& fit, const EdgeState<ad::Hess<MX, T>>* st,
                       const FrameT<ad::Hess<3, double>>* F3,
                       const energies::ConnectionEdgeStiffness<ad::Hess<7, double>>* ks, const int (*pslots)[7],
                       F&& f) {
  using HP = ad::Hess<NP, double>;
  for (int i = 0; i < K; ++i) {
    const V3<ad::Hess<MX, T>>* xs[3] = {&st[i].t, &st[i].m1, &st[i].m2};
    const V3<ad::Hess<3, double>>* fs[3] = {&F3[i].t, &F3[i].d1, &F3[i].d2};
    for (int q = 0; q < 3; ++q) {
      HP H[3];
      connectionFitFactor<NP>(q == 0 ? fit.MA : fit.MB, *fs[q], q == 0 ? ks[i].trB : ks[i].beta, pslots[i], H);
      f(*xs[q], H, i);
    }
  }
}

// Layer 3 of a connection's evalJoint for incident edge i, in a frame of its
// own (reused edge after edge): in the space (edge locals x_i | A | E_i | radii
// of the two ends), the connection edge's frame R F over (A, E_i), the energy
// over (R F, x_i, stiffnesses), composed into that space and added into acc
// over (A, the N locals).
template <int N, class T, int D, bool TW, int K>
[[gnu::noinline]] void connectionEdgeJoint(const ConnectionK<D, TW, K>& k, const LocalStencil& ls,
                                           const double* xdir, int i, const energies::M3<ad::Hess<9, T>>& R9,
                                           const EdgeState<ad::Hess<D + (TW ? 1 : 0), T>>& st,
                                           const FrameT<ad::Hess<3, double>>& F3,
                                           const energies::ConnectionEdgeStiffness<ad::Hess<7, double>>& ks,
                                           const int* xslots, const int* pslots, ad::Hess<9 + N, T>& acc) {
  constexpr int NX = KernelSize<ConnectionK<D, TW, K>>::nx;
  constexpr int MX = D + (TW ? 1 : 0);
  using HM = ad::Hess<MX, T>;
  using H3 = ad::Hess<3, double>;
  constexpr int ME = MX + 9 + 7;
  constexpr int MF = 9 + MX + 3;  // outer: R F, x_i, kIn, kOut, kTwist
  using H12 = ad::Hess<12, T>;
  using HF = ad::Hess<MF, T>;
  static const T one(1.0);
  static constexpr Iota<9> a12(0);
  static constexpr Iota<3> e12(9);
  static constexpr Iota<7> id7(0);
  // R F over (A, E_i).
  energies::M3<H12> R;
  for (int m = 0; m < 9; ++m) R.a[m / 3][m % 3] = ad::lift<12, 9>(R9.a[m / 3][m % 3], a12.s);
  auto liftF = [&](const V3<H3>& v) {
    return V3<H12>(ad::liftAs<12, 3, T>(v.x, e12.s), ad::liftAs<12, 3, T>(v.y, e12.s),
                   ad::liftAs<12, 3, T>(v.z, e12.s));
  };
  const FrameT<H12> F{liftF(F3.t), liftF(F3.d1), liftF(F3.d2)};
  const FrameT<H12> RF = energies::rotatedFrame(R, F);
  const H12* rf[9] = {&RF.t.x, &RF.t.y, &RF.t.z, &RF.d1.x, &RF.d1.y, &RF.d1.z, &RF.d2.x, &RF.d2.y, &RF.d2.z};
  // The outer function.
  FrameT<HF> Fb;
  HF* fb[9] = {&Fb.t.x, &Fb.t.y, &Fb.t.z, &Fb.d1.x, &Fb.d1.y, &Fb.d1.z, &Fb.d2.x, &Fb.d2.y, &Fb.d2.z};
  for (int m = 0; m < 9; ++m) fb[m]->makeVariable(rf[m]->v, m);
  int es[MX];
  for (int j = 0; j < MX; ++j) es[j] = 9 + j;
  auto liftX = [&](const V3<HM>& v) {
    return V3<HF>(ad::lift<MF, MX>(v.x, es), ad::lift<MF, MX>(v.y, es), ad::lift<MF, MX>(v.z, es));
  };
  const EdgeState<HF> sti{liftX(st.t), liftX(st.u), liftX(st.m1), liftX(st.m2)};
  HF th(0.0);
  if constexpr (TW) th.makeVariable(seedValue<T>(ls.xv[D * K + i], xdir, D * K + i), 9 + D);
  const ad::Hess<7, T> kT[3] = {ad::liftAs<7, 7, T>(ks.kIn, id7.s), ad::liftAs<7, 7, T>(ks.kOut, id7.s),
                                ad::liftAs<7, 7, T>(ks.kTwist, id7.s)};
  HF kv[3];
  for (int j = 0; j < 3; ++j) kv[j].makeVariable(kT[j].v, 9 + MX + j);
  const HF e = energies::connectionEdgeEnergyOfFrame(Fb, sti, th, kv[0], kv[1], kv[2], k.k.bend, k.k.twist);
  // Into (x_i | A | E_i | radii).
  ad::Inner<T> in[MF];
  for (int m = 0; m < 9; ++m) in[m] = ad::inner(*rf[m], MX);
  for (int j = 0; j < MX; ++j) in[9 + j] = {&one, nullptr, 1, j};
  for (int j = 0; j < 3; ++j) in[9 + MX + j] = ad::inner(kT[j], MX + 9);
  const ad::Hess<ME, T> eA = ad::compose<ME, MF, T>(e, in);
  int ys[ME];
  for (int j = 0; j < MX; ++j) ys[j] = 9 + xslots[j];
  for (int m = 0; m < 9; ++m) ys[MX + m] = m;
  for (int j = 0; j < 7; ++j) ys[MX + 9 + j] = 9 + NX + pslots[j];
  ad::addLifted(acc, eA, ys);
}

// Layer 4 of a connection's evalJoint, in a frame of its own: the fit A
// composed out of Phi (acc, over (A, the N locals z)). With J = dA/dz,
// P = Phi_AA and C = Phi_Az: g = Phi_z + J^T Phi_A and H = Phi_zz +
// J^T (P J + C) + C^T J, then + sum_k Phi_A_k A_k'', the Hessian of
// sum_i,q,c (sum_r Phi_A_rc X_iq[r]) H_iq[c].
template <int N, class T, int D, bool TW, int K>
[[gnu::noinline]] void connectionComposeFit(
    const ad::Hess<9 + N, T>& acc, const T (*J)[N],
    const ConnectionFitDesign<KernelSize<ConnectionK<D, TW, K>>::np, K>& fit,
    const EdgeState<ad::Hess<D + (TW ? 1 : 0), T>>* st, const FrameT<ad::Hess<3, double>>* F3,
    const energies::ConnectionEdgeStiffness<ad::Hess<7, double>>* ks, const int (*xslots)[4],
    const int (*pslots)[7], ad::Hess<N, T>& out) {
  constexpr int NX = KernelSize<ConnectionK<D, TW, K>>::nx, NP = KernelSize<ConnectionK<D, TW, K>>::np;
  constexpr int MX = D + (TW ? 1 : 0);
  using HM = ad::Hess<MX, T>;
  using HP = ad::Hess<NP, double>;
  using HY = ad::Hess<9 + N, T>;
  out.v = acc.v;
  for (int j = 0; j < N; ++j) {
    T gj = acc.g[9 + j];
    for (int m = 0; m < 9; ++m) gj += acc.g[m] * J[m][j];
    out.g[j] = gj;
  }
  T W[9][N];
  for (int m = 0; m < 9; ++m)
    for (int t = 0; t < N; ++t) {
      T w = acc.h[HY::hidx(m, 9 + t)];
      for (int l = 0; l < 9; ++l) w += acc.h[HY::hidx(m, l)] * J[l][t];
      W[m][t] = w;
    }
  for (int s = 0; s < N; ++s) {
    const T* zz = acc.h.data() + (9 + s) * (10 + s) / 2 + 9;  // Phi_zz row s
    const T* cs = acc.h.data() + (9 + s) * (10 + s) / 2;      // C[.][s]
    T* hs = out.h.data() + s * (s + 1) / 2;
    for (int t = 0; t <= s; ++t) {
      T h = zz[t];
      for (int m = 0; m < 9; ++m) h += J[m][s] * W[m][t] + cs[m] * J[m][t];
      hs[t] = h;
    }
  }
  forEachFitProduct<NP, MX, T, K>(fit, st, F3, ks, pslots, [&](const V3<HM>& X, const HP* H, int i) {
    for (int c = 0; c < 3; ++c) {
      HM y = ad::scale(X[0], acc.g[c]);
      for (int r = 1; r < 3; ++r) y += ad::scale(X[r], acc.g[3 * r + c]);
      ad::addProductHessian<N, MX, NP, T>(out, y, xslots[i], H[c], NX);
    }
  });
}

// Connection (K incident edges): differentiated in layers and composed; no
// scalar carries more than the stencil's N locals, and only the result and
// the energy over (A, the N locals) are that large.
//  1. The fit A = B Minv (connectionFit) is a sum of products X_iq H_iq^T of
//     an edge-state component (over that edge's D (+1) locals) and a design
//     factor (over the p locals; connectionFitDesign, connectionFitFactor).
//     A's values and gradients (9 x N) are accumulated from them.
//  2. R = polar(A) over A's 9 entries.
//  3. Each edge's coupling energy (connectionEdgeEnergyOfFrame) over the
//     connection edge's frame R F (itself over A and the rest edge), the
//     edge's own x locals and its stiffnesses (16 variables in 3D with
//     twist), composed and summed over the edges as a function Phi of (A, the
//     N locals).
//  4. A composed out by the chain rule (connectionComposeFit): through A's
//     gradients, plus sum_k dPhi/dA_k times A_k's Hessian, which is the
//     Hessian of sum_i,q,c (sum_r dPhi/dA_rc X_iq[r]) H_iq[c]: products of a
//     scalar over one edge's locals and one over the p locals
//     (ad::addProductHessian), the design factors formed again.
// The pieces run in frames of their own, so that the stack a call needs stays
// a few hundred kB for a six-valent connection (tests/model/stack_use_test.cc).
template <int N, class T, int D, bool TW, int K>
ad::Hess<N, T> evalJoint(const ConnectionK<D, TW, K>& k, const LocalStencil& ls, const double* xdir) {
  constexpr int NX = KernelSize<ConnectionK<D, TW, K>>::nx, NP = KernelSize<ConnectionK<D, TW, K>>::np;
  static_assert(N == NX + NP, "connection: x and p locals");
  constexpr int MX = D + (TW ? 1 : 0);  // locals of one edge
  // Edge states, each over its own locals (slots: x locals of edge i).
  using HM = ad::Hess<MX, T>;
  EdgeState<HM> st[K];
  int xslots[K][4];
  for (int i = 0; i < K; ++i) {
    const int theta = D * K + i;
    const int sl[4] = {D * i, D * i + 1, D == 3 ? D * i + 2 : theta, theta};
    for (int j = 0; j < 4; ++j) xslots[i][j] = sl[j];
    HM w[3];
    for (int j = 0; j < D; ++j) w[j].makeVariable(seedValue<T>(ls.xv[D * i + j], xdir, D * i + j), j);
    HM th(0.0);
    if constexpr (TW) th.makeVariable(seedValue<T>(ls.xv[theta], xdir, theta), D);
    st[i] = edgeState(embed<D>(w, k.off[i], *k.B), th, k.k.chartT[i], k.k.chartD[i]);
  }
  // Rest frames over each rest edge E_i; stiffnesses over (E_i, radii of the
  // connection vertex, radii of the far vertex): p locals pslots[i].
  using H3 = ad::Hess<3, double>;
  using H7 = ad::Hess<7, double>;
  FrameT<H3> F3[K];
  energies::ConnectionEdgeStiffness<H7> ks[K];
  int pslots[K][7];
  for (int i = 0; i < K; ++i) {
    const V3<H3> Ei(H3::variable(ls.pv[3 * i], 0), H3::variable(ls.pv[3 * i + 1], 1),
                    H3::variable(ls.pv[3 * i + 2], 2));
    F3[i] = restFrameOf(Ei, k.k.n[i]);
    const int sl[7] = {3 * i, 3 * i + 1, 3 * i + 2, 3 * K, 3 * K + 1, 3 * K + 2 + 2 * i, 3 * K + 3 + 2 * i};
    H7 q[7];
    for (int j = 0; j < 7; ++j) {
      pslots[i][j] = sl[j];
      q[j].makeVariable(ls.pv[sl[j]], j);
    }
    ks[i] = energies::connectionEdgeStiffness(norm(V3<H7>(q[0], q[1], q[2])), q[3], q[4], q[5], q[6],
                                              k.k.youngModulus, k.k.shearModulus);
  }

  // 1. A's values and gradients J (rows: A's entries, row-major).
  using HP = ad::Hess<NP, double>;
  ConnectionFitDesign<NP, K> fit;
  connectionFitDesign<NP, K>(F3, ks, pslots, fit);
  auto forEachProduct = [&](auto&& f) { forEachFitProduct<NP, MX, T, K>(fit, st, F3, ks, pslots, f); };
  T Av[3][3] = {};
  T J[9][N] = {};
  forEachProduct([&](const V3<HM>& X, const HP* H, int i) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        const HM& x = X[r];
        const HP& h = H[c];
        T* Jrc = J[3 * r + c];
        Av[r][c] += x.v * h.v;
        for (int a = 0; a < MX; ++a) Jrc[xslots[i][a]] += x.g[a] * h.v;
        for (int b = 0; b < NP; ++b) Jrc[NX + b] += x.v * h.g[b];
      }
  });

  // 2. R over A.
  using H9 = ad::Hess<9, T>;
  energies::M3<H9> a9;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) a9.a[r][c].makeVariable(Av[r][c], 3 * r + c);
  const energies::M3<H9> R9 = energies::polarRotationDirect(a9);

  // 3. Edge energies, summed as a function Phi of (A, the N locals).
  constexpr int NY = 9 + N;
  ad::Hess<NY, T> acc;
  for (int i = 0; i < K; ++i)
    connectionEdgeJoint<N, T, D, TW, K>(k, ls, xdir, i, R9, st[i], F3[i], ks[i], xslots[i], pslots[i], acc);

  // 4. A composed out.
  ad::Hess<N, T> out{ad::NoInit{}};
  connectionComposeFit<N, T, D, TW, K>(acc, J, fit, st, F3, ks, xslots, pslots, out);
  return out;
}

// ------------------------------------------------------------------------
// Joint (u, p) view of a stencil: the global variables it touches (unknowns
// u and design parameters p, in a fixed order given by the stencil's
// structure only) and every local variable as a linear combination of them.
// The positions of held vertices depend on the design (contract §4: a vertex
// held without an explicit position sits at its rest position under the
// current design), so their local coordinates map to rest-position
// parameters. Terms with a zero coefficient are kept: the structure never
// depends on values.

constexpr int kMaxGlobal = 64;  // globals per stencil (a six-valent connection with twist needs 62)
constexpr int kMaxTerms = 6;    // globals per local variable

struct JointMap {
  int ng = 0;
  bool isP[kMaxGlobal];  // false: unknown u, true: design parameter p
  int index[kMaxGlobal];
  int nterms[2 * kMaxLocal];
  int tg[2 * kMaxLocal][kMaxTerms];
  double tc[2 * kMaxLocal][kMaxTerms];

  int global(bool p, int idx) {
    for (int i = 0; i < ng; ++i)
      if (isP[i] == p && index[i] == idx) return i;
    isP[ng] = p;
    index[ng] = idx;
    return ng++;
  }
  void addTerm(int k, int g, double c) {
    for (int t = 0; t < nterms[k]; ++t)
      if (tg[k][t] == g) {
        tc[k][t] += c;
        return;
      }
    tg[k][nterms[k]] = g;
    tc[k][nterms[k]++] = c;
  }
};

// Local variables 0..nx-1 are the x part, nx..nx+np-1 the p part.
inline void buildJointMap(const LocalStencil& ls, const BuildCtx& c, JointMap& m) {
  m.ng = 0;
  // Unknowns first, in stencil order, then design parameters.
  for (int i = 0; i < ls.ns; ++i)
    if (ls.sdofs[i] >= 0) m.global(false, ls.sdofs[i]);
  for (int k = 0; k < ls.nx; ++k) {
    m.nterms[k] = 0;
    for (int a = 0; a < 2; ++a) {
      const int pos = ls.xmap[k].idx[a];
      if (pos < 0) continue;
      const double coef = ls.xmap[k].coef[a];
      if (ls.sdofs[pos] >= 0) {
        m.addTerm(k, m.global(false, ls.sdofs[pos]), coef);
        continue;
      }
      const int v = ls.svertex[pos];
      if (v < 0) continue;
      // Held vertex: local coordinate i = (B^T x)_i (planar) or x_i (3D),
      // with x = heldCoef * rest + constant.
      const double hc = (*c.heldCoef)[v];
      const int i = ls.scoord[pos];
      for (int j = 0; j < 3; ++j) {
        const double b = c.D == 3 ? (i == j ? 1.0 : 0.0) : (*c.B)(j, i);
        if (c.D == 3 && i != j) continue;
        m.addTerm(k, m.global(true, Design::restIndex(v, j)), coef * hc * b);
      }
    }
  }
  for (int k = 0; k < ls.np; ++k) {
    const int kk = ls.nx + k;
    m.nterms[kk] = 0;
    for (int a = 0; a < 2; ++a)
      if (ls.pmap[k].idx[a] >= 0) m.addTerm(kk, m.global(true, ls.pmap[k].idx[a]), ls.pmap[k].coef[a]);
  }
}

// Gradient and lower-triangle Hessian (packed, row-major: (i, j), i >= j, at
// i (i + 1) / 2 + j) of one stencil over its globals.
struct RowOffsets {
  int s[kMaxGlobal];
  constexpr RowOffsets() : s() {
    for (int i = 0; i < kMaxGlobal; ++i) s[i] = i * (i + 1) / 2;
  }
};
inline constexpr RowOffsets kRowOffset{};
struct GlobalBlock {
  double g[kMaxGlobal];
  double L[kMaxGlobal * (kMaxGlobal + 1) / 2];
};

// Maps a kernel result over local variables onto the stencil's globals
// (part: value or directional derivative of each entry): g = T^T g_local,
// H = T^T H_local T with T the JointMap's local-to-global combinations;
// only H's lower triangle is formed (an ordered contribution to H(r, c)
// counts when r >= c).
template <int N, class T>
void toGlobals(const ad::Hess<N, T>& r, const JointMap& m, int nLocal, bool derivative, GlobalBlock& out) {
  std::fill(out.g, out.g + m.ng, 0.0);
  std::fill(out.L, out.L + m.ng * (m.ng + 1) / 2, 0.0);
  for (int k = 0; k < nLocal; ++k) {
    const double gk = partOf(r.g[k], derivative);
    if (gk == 0.0) continue;
    for (int t = 0; t < m.nterms[k]; ++t) out.g[m.tg[k][t]] += m.tc[k][t] * gk;
  }
  const int* row = kRowOffset.s;
  const auto* h = r.h.data();
  for (int k = 0; k < nLocal; ++k) {
    const int nk = m.nterms[k];
    const int* gk = m.tg[k];
    const double* ck = m.tc[k];
    for (int l = 0; l < k; ++l, ++h) {
      const double hkl = partOf(*h, derivative);
      if (hkl == 0.0) continue;
      const int nl = m.nterms[l];
      for (int a = 0; a < nk; ++a) {
        const int gr = gk[a];
        const double ch = ck[a] * hkl;
        for (int b = 0; b < nl; ++b) {
          const int gc = m.tg[l][b];
          const double v = ch * m.tc[l][b];
          // (k, l) and (l, k): the lower one of H(gr, gc), H(gc, gr) twice
          // on the diagonal, once otherwise.
          if (gr > gc) out.L[row[gr] + gc] += v;
          else if (gr < gc) out.L[row[gc] + gr] += v;
          else out.L[row[gr] + gr] += 2.0 * v;
        }
      }
    }
    // (k, k): (a, b) and (b, a) are both visited; keep the lower one.
    const double hkk = partOf(*h++, derivative);
    if (hkk == 0.0) continue;
    for (int a = 0; a < nk; ++a) {
      const double ch = ck[a] * hkk;
      for (int b = 0; b < nk; ++b)
        if (gk[a] >= gk[b]) out.L[row[gk[a]] + gk[b]] += ch * ck[b];
    }
  }
}

}  // namespace rodmesh::detail

namespace rodmesh {
using namespace detail;

// Every element of every included block of the term list, in order: builds
// the element's LocalStencil and kernel and hands them to visit(kernel,
// stencil, index). Pattern construction, simulation and joint derivatives
// all walk this list; a block left out still advances the index, so that
// stencil indices (and the pattern slots kept per stencil) never depend on
// the filter.
template <int D, bool TW, class Visit>
void PoseSystem::forEachStencil(const BuildCtx& ctx, Visit&& visit) const {
  int sidx = 0;
  TermBlocks::each([&](auto index) {
    constexpr int I = decltype(index)::value;
    using Block = TermBlocks::Block<I>;
    const auto& elements = std::get<I>(terms_->elements);
    if (!ctx.terms.has(I)) {
      sidx += static_cast<int>(elements.size());
      return;
    }
    auto each = [&](const auto& kern, const LocalStencil& ls) { visit(kern, ls, sidx); };
    if constexpr (InternalCount<Block>::value > 0) {
      const double* internal = ctx.internal + internalOffset_[I];
      for (const auto& el : elements) {
        Block::template visit<D, TW>(el, ctx, internal, each);
        internal += InternalCount<Block>::value;
        ++sidx;
      }
    } else {
      for (const auto& el : elements) {
        Block::template visit<D, TW>(el, ctx, each);
        ++sidx;
      }
    }
  });
}

// Calls f(std::integral_constant<int, D>, std::bool_constant<TW>) for the
// system's layout: the one place the run-time layout picks a kernel build.
template <class F>
void PoseSystem::withLayout(F&& f) const {
  if (D_ == 3 && twist_) f(std::integral_constant<int, 3>{}, std::true_type{});
  else if (D_ == 3) f(std::integral_constant<int, 3>{}, std::false_type{});
  else if (twist_) f(std::integral_constant<int, 2>{}, std::true_type{});
  else f(std::integral_constant<int, 2>{}, std::false_type{});
}

}  // namespace rodmesh
