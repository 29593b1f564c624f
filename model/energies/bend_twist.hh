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
// two consecutive edges are antiparallel, or where psi - psī reaches +-pi (see
// docs/model.md).
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
  FrameT<P> F0, F1;              // rest frames of e0, e1
  P wa1, wa2, wb1, wb2;          // rest curvature: Kb.D2_0, Kb.D1_0, Kb.D2_1, Kb.D1_1
  P kIn, kOut, kTwist;           // B_in / (4 l), B_out / (4 l), beta / (2 l)
  P psiRest;                     // rest reference twist
};

template <class P>
BendTwistRest<P> bendTwistRest(const V3<P>& E0, const V3<P>& E1, const P& rt, const P& rn, const BendTwistConst& c) {
  BendTwistRest<P> r;
  const P l = P(0.5) * (norm(E0) + norm(E1));
  r.F0 = restFrameOf(E0, c.n0);
  r.F1 = restFrameOf(E1, c.n1);
  const V3<P> Kb = curvatureBinormal(r.F0.t, r.F1.t);
  r.wa1 = dot(Kb, r.F0.d2);
  r.wa2 = dot(Kb, r.F0.d1);
  r.wb1 = dot(Kb, r.F1.d2);
  r.wb2 = dot(Kb, r.F1.d1);
  r.kIn = stiffness::bendingIn(c.youngModulus, rt, rn) / (P(4.0) * l);
  r.kOut = stiffness::bendingOut(c.youngModulus, rt, rn) / (P(4.0) * l);
  r.kTwist = stiffness::twisting(c.shearModulus, rt, rn) / (P(2.0) * l);
  r.psiRest = signedAngle(parallelTransport(r.F0.t, r.F1.t, r.F0.d1), r.F1.d1, r.F1.t);
  return r;
}

// The current frame of one edge: tangent, reference director, material
// directors. Depends on that edge's vector and twist only, so simulation can
// differentiate it over those 4 variables and lift the result (see
// PoseSystem), which is much cheaper than differentiating over the stencil's 8.
template <class S>
struct EdgeState {
  V3<S> t, u, m1, m2;
};

template <class S>
EdgeState<S> edgeState(const V3<S>& e, const S& th, const Eigen::Vector3d& chartT, const Eigen::Vector3d& chartD) {
  EdgeState<S> f;
  f.t = normalized(e);
  f.u = transportFromRest(V3<double>(chartT), f.t, V3<double>(chartD));
  materialDirectors(f.t, f.u, th, f.m1, f.m2);
  return f;
}

template <class S, class P>
S bendTwistFromStates(const EdgeState<S>& a, const EdgeState<S>& b, const S& th0, const S& th1,
                      const BendTwistRest<P>& r, const BendTwistConst& c) {
  S energy(0.0);
  if (c.bend) {
    const V3<S> kb = curvatureBinormal(a.t, b.t);
    const S wa1 = dot(kb, a.m2) - r.wa1, wa2 = dot(kb, a.m1) - r.wa2;
    const S wb1 = dot(kb, b.m2) - r.wb1, wb2 = dot(kb, b.m1) - r.wb2;
    energy = (wa1 * wa1 + wb1 * wb1) * r.kIn + (wa2 * wa2 + wb2 * wb2) * r.kOut;
  }
  if (c.twist) {
    const S psi = signedAngle(parallelTransport(a.t, b.t, a.u), b.u, b.t);
    const S tau = th1 - th0 + wrapAngle(psi - r.psiRest);
    energy = energy + tau * tau * r.kTwist;
  }
  return energy;
}

template <class S, class P>
S bendTwistEnergy(const V3<S>& e0, const V3<S>& e1, const S& th0, const S& th1, const BendTwistRest<P>& r,
                  const BendTwistConst& c) {
  return bendTwistFromStates(edgeState(e0, th0, c.chartT0, c.chartD0), edgeState(e1, th1, c.chartT1, c.chartD1), th0,
                             th1, r, c);
}

}  // namespace rodmesh::energies
