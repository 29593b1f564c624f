// A clamp at a vertex: bending and twist between an incident edge and the
// vertex's held orientation, which is the edge's rest frame (contract §1: the
// rod leaves the vertex along its rest tangent with its rest twist). It acts at
// the vertex itself, over the half edge next to it (l = |E| / 2), so a clamped
// cantilever of length L behaves as length L:
//
//   E = 1/(2 l) * 1/2 [ w_F^T B w_F + w_e^T B w_e ] + 1/(2 l) beta theta^2,
//   kb = 2 T x t / (1 + T . t),  w_F = (kb . D2, -kb . D1),  w_e = (kb . m2, -kb . m1).
//
// With the rest chart the edge's reference director is the transport of D1
// from T to t, so the twist relative to the held frame is theta itself. The same structure, with a
// rotated frame, couples rods at connections.
//
// Local variables: x = e (3), theta; p = E (3), r_t, r_n at the clamped vertex.
#pragma once

#include "model/energies/rod_math.hh"
#include "model/stiffness.hh"

namespace rodmesh::energies {

struct ClampConst {
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();  // reference normal of the edge
  Eigen::Vector3d chartT, chartD;                // reference-frame chart of the edge
  double youngModulus = 0.0, shearModulus = 0.0;
  bool bend = true, twist = true;
};

template <class P>
struct ClampRest {
  FrameT<P> F;               // held frame (T, D1, D2)
  P kIn, kOut, kTwist;       // B_in / (4 l), B_out / (4 l), beta / (2 l), l = |E| / 2
};

template <class P>
ClampRest<P> clampRest(const V3<P>& E, const P& rt, const P& rn, const ClampConst& c) {
  ClampRest<P> r;
  const P l = P(0.5) * norm(E);
  r.F = restFrameOf(E, c.n);
  r.kIn = stiffness::bendingIn(c.youngModulus, rt, rn) / (P(4.0) * l);
  r.kOut = stiffness::bendingOut(c.youngModulus, rt, rn) / (P(4.0) * l);
  r.kTwist = stiffness::twisting(c.shearModulus, rt, rn) / (P(2.0) * l);
  return r;
}

template <class S, class P>
S clampEnergy(const V3<S>& e, const S& th, const ClampRest<P>& r, const ClampConst& c) {
  const V3<S> t = normalized(e);
  const V3<S> u = transportFromRest(V3<double>(c.chartT), t, V3<double>(c.chartD));
  S energy(0.0);
  if (c.bend) {
    V3<S> m1, m2;
    materialDirectors(t, u, th, m1, m2);
    const V3<S> kb = (S(2.0) / (S(1.0) + dotm(r.F.t, t))) * crossm(r.F.t, t);
    const S wf1 = dotm(r.F.d2, kb), wf2 = dotm(r.F.d1, kb);
    const S we1 = dot(kb, m2), we2 = dot(kb, m1);
    energy = (wf1 * wf1 + we1 * we1) * r.kIn + (wf2 * wf2 + we2 * we2) * r.kOut;
  }
  if (c.twist) {
    // Twist relative to the held frame: theta plus the angle from the held
    // director transported to t to the reference director (zero for the rest
    // chart), modulo 2 pi as a whole: with a re-anchored chart each part can
    // pass +-pi while their sum stays small (bend_twist.hh).
    const S tau = wrapAngle(th + signedAngle(transportFromRest(r.F.t, t, r.F.d1), u, t));
    energy = energy + tau * tau * r.kTwist;
  }
  return energy;
}

}  // namespace rodmesh::energies
