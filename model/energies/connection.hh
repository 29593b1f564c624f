// Coupling of the rods that meet at a connection (Pérez et al. 2015, §3.2).
//
// The connection's rotation R is the rotation of the polar decomposition
// A = R S of the best-fit linear map A from the incident edges' rest material
// frames to their current ones (paper eq. 4):
//
//   A = argmin sum_i  a_i |t_i - A T_i|^2 + b_i (|n_i - A N_i|^2 + |m_i - A D_i|^2),
//   a_i = tr(B_i) / sum_j tr(B_j),   b_i = beta_i / sum_j beta_j,
//
// with t the tangent, n the material normal (the r_n axis) and m the other
// material director (the r_t axis). The paper fits tangents and normals only;
// we add the third director with the normals' (twist) weight, which makes the
// fit well posed for collinear edges (two rods meeting straight), where the
// paper's system is singular; R is unchanged where both are defined and the
// frames agree. Each incident edge i then couples, through bending and twist,
// to a connection edge with frame R (T_i, D1_i, D2_i) over half its length:
// the clamp energy (clamp.hh) with the held frame rotated by R. Summed over
// the incident edges this reproduces an interior rod vertex exactly when two
// rods meet straight.
//
// R is differentiated exactly to third order: R0 = polar(A) is computed in
// double (SVD), then R = R0 Q(w) with Q the Cayley rotation, where w solves
// axial(skew(Q(w)^T R0^T A)) = 0 (R^T A symmetric) by chord-Newton steps
// from w = 0 in the AD scalar. Each step multiplies the error by O(|dA|), so
// after k steps the result agrees with the true polar factor to
// O(|dA|^(k+1)): its derivatives up to order k are exact. The scalar's order
// of derivatives picks k (ad::Order: 2 for Hess<N>, 3 for Hess<N, Dual>).
//
// Local variables: x = e_i (3 each), theta_i (each, with twist); p = E_i (3
// each), radii of the connection vertex (2), radii of each far vertex (2 each).
#pragma once

#include "model/energies/rod_math.hh"
#include "model/stiffness.hh"

#include <Eigen/Dense>

namespace rodmesh::energies {

constexpr int kMaxConnectionValence = 6;
// polarRotationAD composes through A's entries above this many variables.
constexpr int kPolarComposeMin = 12;

template <class S>
struct M3 {
  S a[3][3];
  V3<S> col(int j) const { return {a[0][j], a[1][j], a[2][j]}; }
};

template <int K>
struct ConnectionConst {
  Eigen::Vector3d n[K];                   // reference normals of the incident edges
  Eigen::Vector3d chartT[K], chartD[K];   // reference-frame charts of the incident edges
  double youngModulus = 0.0, shearModulus = 0.0;
  bool bend = true, twist = true;
};

template <class P, int K>
struct ConnectionRest {
  FrameT<P> F[K];                 // rest frames of the incident edges
  P kIn[K], kOut[K], kTwist[K];   // coupling stiffnesses over half an edge
  P wT[K], wN[K];                 // fit weights of tangents and of the two directors
  M3<P> Minv;                     // (sum w Q Q^T)^-1
};

// The inverse by cofactors: entry (i, j) is a[i1][j1] a[i2][j2] -
// a[i1][j2] a[i2][j1] with i1, i2 the rows other than j and j1, j2 the
// columns other than i, taken cyclically, over det. One cofactor at a time,
// so that a large scalar's temporaries are not multiplied by nine.
template <class P>
M3<P> inverse3(const M3<P>& m) {
  const auto& a = m.a;
  M3<P> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const int i1 = (j + 1) % 3, i2 = (j + 2) % 3, j1 = (i + 1) % 3, j2 = (i + 2) % 3;
      r.a[i][j] = a[i1][j1] * a[i2][j2] - a[i1][j2] * a[i2][j1];
    }
  const P det = a[0][0] * r.a[0][0] + a[0][1] * r.a[1][0] + a[0][2] * r.a[2][0];
  const P inv = P(1.0) / det;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.a[i][j] = r.a[i][j] * inv;
  return r;
}

// The coupling stiffness of one incident edge, over half the edge (len =
// |E_i|), with the mean of the connection vertex's radii (rtC, rnC) and the
// far vertex's (rtF, rnF); trB and beta weigh the edge in the fit.
template <class P>
struct ConnectionEdgeStiffness {
  P kIn, kOut, kTwist, trB, beta;
};

template <class P>
ConnectionEdgeStiffness<P> connectionEdgeStiffness(const P& len, const P& rtC, const P& rnC, const P& rtF,
                                                   const P& rnF, double youngModulus, double shearModulus) {
  const P rt = P(0.5) * (rtC + rtF);
  const P rn = P(0.5) * (rnC + rnF);
  const P bin = stiffness::bendingIn(youngModulus, rt, rn), bout = stiffness::bendingOut(youngModulus, rt, rn);
  const P tw = stiffness::twisting(shearModulus, rt, rn);
  const P l = P(0.5) * len;
  return {bin / (P(4.0) * l), bout / (P(4.0) * l), tw / (P(2.0) * l), bin + bout, tw};
}

// The fit's weights and Minv (into r) from the rest frames r.F and each
// edge's trB and beta (ConnectionEdgeStiffness).
template <class P, int K>
void connectionFitWeights(const P* trB, const P* beta, ConnectionRest<P, K>& r) {
  P sumA(0.0), sumB(0.0);
  for (int i = 0; i < K; ++i) {
    sumA = sumA + trB[i];
    sumB = sumB + beta[i];
  }
  M3<P> M;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) M.a[a][b] = P(0.0);
  for (int i = 0; i < K; ++i) {
    r.wT[i] = trB[i] / sumA;
    r.wN[i] = beta[i] / sumB;
    const FrameT<P>& F = r.F[i];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b <= a; ++b)
        M.a[a][b] = M.a[a][b] + r.wT[i] * F.t[a] * F.t[b] + r.wN[i] * (F.d1[a] * F.d1[b] + F.d2[a] * F.d2[b]);
  }
  for (int a = 0; a < 3; ++a)
    for (int b = a + 1; b < 3; ++b) M.a[a][b] = M.a[b][a];  // symmetric
  r.Minv = inverse3(M);
}

// radii: [connection vertex, far vertex of edge 0, ..., far vertex of edge K-1],
// each [r_t, r_n]; the coupling of edge i uses the mean of its two ends.
template <class P, int K>
ConnectionRest<P, K> connectionRest(const V3<P>* E, const P* radii, const ConnectionConst<K>& c) {
  ConnectionRest<P, K> r;
  P trB[K], beta[K];
  for (int i = 0; i < K; ++i) {
    r.F[i] = restFrameOf(E[i], c.n[i]);
    const ConnectionEdgeStiffness<P> k = connectionEdgeStiffness(norm(E[i]), radii[0], radii[1], radii[2 + 2 * i],
                                                                 radii[3 + 2 * i], c.youngModulus, c.shearModulus);
    r.kIn[i] = k.kIn;
    r.kOut[i] = k.kOut;
    r.kTwist[i] = k.kTwist;
    trB[i] = k.trB;
    beta[i] = k.beta;
  }
  connectionFitWeights(trB, beta, r);
  return r;
}

// Rotation of the polar decomposition of a 3x3 matrix (det > 0 assumed; a
// reflection is turned into the nearest rotation).
inline Eigen::Matrix3d polarRotation(const Eigen::Matrix3d& A) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU(), V = svd.matrixV();
  if ((U * V.transpose()).determinant() < 0) U.col(2) = -U.col(2);
  return U * V.transpose();
}

// The exact rotation R(A) in the AD scalar (see the header comment),
// differentiated through every operation in S.
template <class S>
M3<S> polarRotationDirect(const M3<S>& A) {
  Eigen::Matrix3d A0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) A0(i, j) = ad::value(A.a[i][j]);
  const Eigen::Matrix3d R0 = polarRotation(A0);
  if constexpr (ad::Order<S>::value == 0) {  // a value: R0 itself
    M3<S> R;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) R.a[i][j] = S(R0(i, j));
    return R;
  }
  // M = R0^T A.
  M3<S> M;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) M.a[i][j] = A.a[0][j] * R0(0, i) + A.a[1][j] * R0(1, i) + A.a[2][j] * R0(2, i);
  // J = dG/dw at w = 0: -1/2 (tr(Sym) I - Sym - [k]), Sym, [k] the symmetric
  // and skew parts of M; its inverse is reused by the chord steps.
  M3<S> J;
  const S tr = M.a[0][0] + M.a[1][1] + M.a[2][2];
  const S k0 = S(0.5) * (M.a[2][1] - M.a[1][2]), k1 = S(0.5) * (M.a[0][2] - M.a[2][0]), k2 = S(0.5) * (M.a[1][0] - M.a[0][1]);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) J.a[i][j] = S(0.25) * (M.a[i][j] + M.a[j][i]) - (i == j ? S(0.5) * tr : S(0.0));
  // + 1/2 [k]
  J.a[0][1] = J.a[0][1] - S(0.5) * k2;
  J.a[0][2] = J.a[0][2] + S(0.5) * k1;
  J.a[1][0] = J.a[1][0] + S(0.5) * k2;
  J.a[1][2] = J.a[1][2] - S(0.5) * k0;
  J.a[2][0] = J.a[2][0] - S(0.5) * k1;
  J.a[2][1] = J.a[2][1] + S(0.5) * k0;
  const M3<S> Jinv = inverse3(J);
  // Cayley rotation with first-order term [w]: c = w / 2,
  // Q = ((1 - c.c) I + 2 c c^T + 2 [c]) / (1 + c.c).
  auto cayley = [](const V3<S>& w) {
    M3<S> Q;
    const V3<S> c = S(0.5) * w;
    const S cc = dot(c, c);
    const S inv = S(1.0) / (S(1.0) + cc);
    const S diag = (S(1.0) - cc);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) Q.a[i][j] = (S(2.0) * c[i] * c[j] + (i == j ? diag : S(0.0)));
    Q.a[0][1] = Q.a[0][1] - S(2.0) * c.z;
    Q.a[0][2] = Q.a[0][2] + S(2.0) * c.y;
    Q.a[1][0] = Q.a[1][0] + S(2.0) * c.z;
    Q.a[1][2] = Q.a[1][2] - S(2.0) * c.x;
    Q.a[2][0] = Q.a[2][0] - S(2.0) * c.y;
    Q.a[2][1] = Q.a[2][1] + S(2.0) * c.x;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) Q.a[i][j] = Q.a[i][j] * inv;
    return Q;
  };
  // One chord step per order of derivatives S carries (the first from
  // w = 0, where Q = I).
  constexpr int kSteps = ad::Order<S>::value;
  V3<S> w(S(0.0), S(0.0), S(0.0));
  for (int step = 0; step < kSteps; ++step) {
    // G = axial(skew(Q^T M)).
    M3<S> QM;
    if (step == 0) {
      QM = M;
    } else {
      const M3<S> Q = cayley(w);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) QM.a[i][j] = Q.a[0][i] * M.a[0][j] + Q.a[1][i] * M.a[1][j] + Q.a[2][i] * M.a[2][j];
    }
    const V3<S> G(S(0.5) * (QM.a[2][1] - QM.a[1][2]), S(0.5) * (QM.a[0][2] - QM.a[2][0]),
                  S(0.5) * (QM.a[1][0] - QM.a[0][1]));
    for (int i = 0; i < 3; ++i) w[i] = w[i] - (Jinv.a[i][0] * G.x + Jinv.a[i][1] * G.y + Jinv.a[i][2] * G.z);
  }
  const M3<S> Q = cayley(w);
  M3<S> R;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R.a[i][j] = Q.a[0][j] * R0(i, 0) + Q.a[1][j] * R0(i, 1) + Q.a[2][j] * R0(i, 2);
  return R;
}

// R(A) in the AD scalar. Over many variables (a joint stencil's N > 9), R is
// differentiated over A's 9 entries and composed with A's derivatives
// (ad::compose, exact): far fewer operations on the large scalar.
template <class S>
M3<S> polarRotationAD(const M3<S>& A) {
  if constexpr (!ad::IsHess<S>::value) {
    return polarRotationDirect(A);
  } else if constexpr (S::kN <= kPolarComposeMin) {
    return polarRotationDirect(A);
  } else {
    using T = typename ad::IsHess<S>::scalar;
    using H9 = ad::Hess<9, T>;
    constexpr int N = S::kN;
    M3<H9> a9;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) a9.a[i][j] = H9::variable(A.a[i][j].v, 3 * i + j);
    const M3<H9> R9 = polarRotationDirect(a9);
    ad::Inner<T> in[9];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) in[3 * i + j] = ad::inner(A.a[i][j], 0);
    M3<S> R;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) R.a[i][j] = ad::compose<N, 9, T>(R9.a[i][j], in);
    return R;
  }
}

template <class S, class P>
V3<S> rotate(const M3<S>& R, const V3<P>& v) {
  return {R.a[0][0] * v.x + R.a[0][1] * v.y + R.a[0][2] * v.z, R.a[1][0] * v.x + R.a[1][1] * v.y + R.a[1][2] * v.z,
          R.a[2][0] * v.x + R.a[2][1] * v.y + R.a[2][2] * v.z};
}

// The best-fit linear map A = B Minv from the incident edges' current states
// (EdgeState: tangent, reference and material directors; depend on one edge
// each), B = sum_i wT t T^T + wN (m1 D1^T + m2 D2^T).
template <class S, class P, int K>
M3<S> connectionFit(const EdgeState<S>* st, const ConnectionRest<P, K>& r) {
  M3<S> A;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) A.a[a][b] = S(0.0);
  M3<S> B = A;
  for (int i = 0; i < K; ++i) {
    const V3<S>& t = st[i].t;
    const V3<S>& m1 = st[i].m1;
    const V3<S>& m2 = st[i].m2;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        B.a[a][b] = B.a[a][b] + (t[a] * r.F[i].t[b]) * r.wT[i] +
                    (m1[a] * r.F[i].d1[b] + m2[a] * r.F[i].d2[b]) * r.wN[i];
  }
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      A.a[a][b] = B.a[a][0] * r.Minv.a[0][b] + B.a[a][1] * r.Minv.a[1][b] + B.a[a][2] * r.Minv.a[2][b];
  return A;
}

// The coupling energy of one incident edge (state st, twist th, stiffnesses)
// with the connection edge of frame Fb = R F (F: the edge's rest frame).
template <class S, class Q>
S connectionEdgeEnergyOfFrame(const FrameT<S>& Fb, const EdgeState<S>& st, const S& th, const Q& kIn,
                              const Q& kOut, const Q& kTwist, bool bend, bool twist) {
  S energy(0.0);
  if (bend) {
    const V3<S> kb = curvatureBinormal(Fb.t, st.t);
    const S wf1 = dot(kb, Fb.d2), wf2 = dot(kb, Fb.d1);
    const S we1 = dot(kb, st.m2), we2 = dot(kb, st.m1);
    energy = (wf1 * wf1 + we1 * we1) * kIn + (wf2 * wf2 + we2 * we2) * kOut;
  }
  if (twist) {
    // Modulo 2 pi as a whole, as at a clamp (clamp.hh, bend_twist.hh).
    const S tau = wrapAngle(th + signedAngle(parallelTransport(Fb.t, st.t, Fb.d1), st.u, st.t));
    energy = energy + tau * tau * kTwist;
  }
  return energy;
}

// The connection edge's frame R F.
template <class S, class Q>
FrameT<S> rotatedFrame(const M3<S>& R, const FrameT<Q>& F) {
  return {rotate(R, F.t), rotate(R, F.d1), rotate(R, F.d2)};
}

// The same with the connection's rotation R and the edge's rest frame F.
template <class S, class Q>
S connectionEdgeEnergy(const M3<S>& R, const EdgeState<S>& st, const S& th, const FrameT<Q>& F, const Q& kIn,
                       const Q& kOut, const Q& kTwist, bool bend, bool twist) {
  return connectionEdgeEnergyOfFrame(rotatedFrame(R, F), st, th, kIn, kOut, kTwist, bend, twist);
}

// The energy from the incident edges' current states and twists.
template <class S, class P, int K>
S connectionEnergyFromStates(const EdgeState<S>* st, const S* th, const ConnectionRest<P, K>& r,
                             const ConnectionConst<K>& c) {
  const M3<S> R = polarRotationAD(connectionFit(st, r));
  S energy(0.0);
  for (int i = 0; i < K; ++i)
    energy = energy + connectionEdgeEnergy(R, st[i], th[i], r.F[i], r.kIn[i], r.kOut[i], r.kTwist[i], c.bend, c.twist);
  return energy;
}

template <class S, class P, int K>
S connectionEnergy(const V3<S>* e, const S* th, const ConnectionRest<P, K>& r, const ConnectionConst<K>& c) {
  EdgeState<S> st[K];
  for (int i = 0; i < K; ++i) st[i] = edgeState(e[i], th[i], c.chartT[i], c.chartD[i]);
  return connectionEnergyFromStates(st, th, r, c);
}

}  // namespace rodmesh::energies
