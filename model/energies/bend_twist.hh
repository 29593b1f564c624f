// Bending and twisting at an interior vertex of a rod, between its incoming
// edge e0 and outgoing edge e1 (Bergou 2008 §4.2 and §4.2.2; Bergou 2010 §5).
//
//   E_b = 1/(2 l) * 1/2 sum_{j=0,1} (w_j - w̄_j)^T B (w_j - w̄_j),
//   w_j = (kb . m2_j, -kb . m1_j),    kb = 2 t0 x t1 / (1 + t0 . t1),
//   B = diag(E pi r_t^3 r_n / 4, E pi r_t r_n^3 / 4)   (in-plane, out-of-plane),
//   E_t = 1/(2 l) * beta * (theta1 - theta0 + psi - psī)^2,
//   beta = G pi r_t^3 r_n^3 / (r_t^2 + r_n^2),   l = (|E0| + |E1|) / 2.
//
// Reference directors u_j are fixed chart directors parallel-transported from
// the chart tangent to the current tangent (by default the rest frames; no state
// carried between evaluations); psi is the reference twist, the signed angle about t1 from the
// transport of u0 along t0 -> t1 to u1. Barred quantities are rest values
// computed from the rest edges E0, E1 and the reference normals (theta = 0 at
// rest). Non-smooth only where an edge is antiparallel to its chart tangent, where
// two consecutive edges are antiparallel, or where the twist
// theta1 - theta0 + psi - psī reaches +-pi (a full half turn between two
// edges; see docs/model.md).
//
// Local variables: x = e0 (3), e1 (3), theta0, theta1; p = E0 (3), E1 (3),
// r_t, r_n at the vertex.
#pragma once

#include "model/energies/rod_math.hh"
#include "model/stiffness.hh"

namespace rodmesh::energies {

struct BendTwistConst {
  Eigen::Vector3d n0 = Eigen::Vector3d::UnitZ(), n1 = Eigen::Vector3d::UnitZ();  // reference normals of e0, e1
  // Reference-frame charts of e0, e1: the reference director of an edge is
  // chartD transported from chartT to the current tangent (see PoseSystem).
  Eigen::Vector3d chartT0, chartD0, chartT1, chartD1;
  double youngModulus = 0.0, shearModulus = 0.0;
  bool bend = true, twist = true;
};

// Everything that depends on the design only.
template <class P>
struct BendTwistRest {
  P wa1, wa2, wb1, wb2;          // rest curvature: Kb.D2_0, Kb.D1_0, Kb.D2_1, Kb.D1_1
  P kIn, kOut, kTwist;           // B_in / (4 l), B_out / (4 l), beta / (2 l)
  P psiRest;                     // rest reference twist
};

// The rest quantities of the shape: rest curvature and reference twist, from
// the rest frames of e0 and e1.
template <class P>
void bendTwistRestShape(const FrameT<P>& F0, const FrameT<P>& F1, BendTwistRest<P>& r) {
  const V3<P> Kb = curvatureBinormal(F0.t, F1.t);
  r.wa1 = dot(Kb, F0.d2);
  r.wa2 = dot(Kb, F0.d1);
  r.wb1 = dot(Kb, F1.d2);
  r.wb2 = dot(Kb, F1.d1);
  r.psiRest = signedAngle(parallelTransport(F0.t, F1.t, F0.d1), F1.d1, F1.t);
}

// The stiffness coefficients from the vertex's rest length l and radii.
template <class P>
void bendTwistRestStiffness(const P& l, const P& rt, const P& rn, const BendTwistConst& c, BendTwistRest<P>& r) {
  r.kIn = stiffness::bendingIn(c.youngModulus, rt, rn) / (P(4.0) * l);
  r.kOut = stiffness::bendingOut(c.youngModulus, rt, rn) / (P(4.0) * l);
  r.kTwist = stiffness::twisting(c.shearModulus, rt, rn) / (P(2.0) * l);
}

// Rest length of the vertex (half the two rest edges).
template <class P>
P bendTwistRestLength(const P& len0, const P& len1) {
  return P(0.5) * (len0 + len1);
}

template <class P>
BendTwistRest<P> bendTwistRest(const V3<P>& E0, const V3<P>& E1, const P& rt, const P& rn, const BendTwistConst& c) {
  BendTwistRest<P> r;
  bendTwistRestShape(restFrameOf(E0, c.n0), restFrameOf(E1, c.n1), r);
  bendTwistRestStiffness(bendTwistRestLength(norm(E0), norm(E1)), rt, rn, c, r);
  return r;
}

// Everything that depends on the current edges only (through their states,
// see EdgeState in rod_math.hh): the curvature binormal's components along
// the material directors, kb.m2_0, kb.m1_0, kb.m2_1, kb.m1_1, and the
// reference twist psi (zero when bending / twist is off).
template <class S>
struct BendTwistCurrent {
  S wa1, wa2, wb1, wb2, psi;
};

template <class S>
BendTwistCurrent<S> bendTwistCurrent(const EdgeState<S>& a, const EdgeState<S>& b, const BendTwistConst& c) {
  BendTwistCurrent<S> w{S(0.0), S(0.0), S(0.0), S(0.0), S(0.0)};
  if (c.bend) {
    const V3<S> kb = curvatureBinormal(a.t, b.t);
    w.wa1 = dot(kb, a.m2);
    w.wa2 = dot(kb, a.m1);
    w.wb1 = dot(kb, b.m2);
    w.wb2 = dot(kb, b.m1);
  }
  if (c.twist) w.psi = signedAngle(parallelTransport(a.t, b.t, a.u), b.u, b.t);
  return w;
}

// The energy from the current and rest quantities: the only place the two meet
// (joint design derivatives differentiate the two sides separately and
// combine them here, see model/pose_system_detail.hh).
template <class S, class P>
S bendTwistCombine(const BendTwistCurrent<S>& w, const S& th0, const S& th1, const BendTwistRest<P>& r,
                   const BendTwistConst& c) {
  S energy(0.0);
  if (c.bend) {
    const S wa1 = w.wa1 - r.wa1, wa2 = w.wa2 - r.wa2;
    const S wb1 = w.wb1 - r.wb1, wb2 = w.wb2 - r.wb2;
    energy = (wa1 * wa1 + wb1 * wb1) * r.kIn + (wa2 * wa2 + wb2 * wb2) * r.kOut;
  }
  if (c.twist) {
    // The pair's twist modulo 2 pi as a whole (the least angle carrying one
    // material frame into the other): its two parts, the twist unknowns'
    // difference and the reference twist, can each pass +-pi on a path along
    // which their sum stays small (charts re-anchored on a sheet folded
    // over), and wrapping one part alone made the energy jump there.
    const S tau = wrapAngle(th1 - th0 + (w.psi - r.psiRest));
    energy = energy + tau * tau * r.kTwist;
  }
  return energy;
}

template <class S, class P>
S bendTwistFromStates(const EdgeState<S>& a, const EdgeState<S>& b, const S& th0, const S& th1,
                      const BendTwistRest<P>& r, const BendTwistConst& c) {
  return bendTwistCombine(bendTwistCurrent(a, b, c), th0, th1, r, c);
}

template <class S, class P>
S bendTwistEnergy(const V3<S>& e0, const V3<S>& e1, const S& th0, const S& th1, const BendTwistRest<P>& r,
                  const BendTwistConst& c) {
  return bendTwistFromStates(edgeState(e0, th0, c.chartT0, c.chartD0), edgeState(e1, th1, c.chartT1, c.chartD1), th0,
                             th1, r, c);
}

}  // namespace rodmesh::energies
