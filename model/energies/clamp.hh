// A clamp at a vertex: bending and twist between an incident edge and the
// vertex's held orientation, which is the edge's rest frame (contract §1: the
// rod leaves the vertex along its rest tangent with its rest twist). It acts at
// the vertex itself, over the half edge next to it (l = |E| / 2), so a clamped
// cantilever of length L behaves as length L:
//
//   E = 1/(2 l) * 1/2 [ w_F^T B w_F + w_e^T B w_e ] + 1/(2 l) beta theta^2,
//   kb = 2 T x t / (1 + T . t),  w_F = (kb . D2, -kb . D1),  w_e = (kb . m2, -kb . m1).
//
// The edge's reference director is the transport of D1 from T to t, so the
// twist relative to the held frame is theta itself. The same structure, with a
// rotated frame, couples rods at connections.
//
// Local variables: x = e (3), theta; p = E (3), r_t, r_n at the clamped vertex.
#pragma once

#include "model/energies/rod_math.hh"
#include "model/stiffness.hh"

namespace rodmesh::energies {

struct ClampConst {
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();  // reference normal of the edge
  double youngModulus = 0.0, shearModulus = 0.0;
  bool bend = true, twist = true;
};

template <class S>
S clampEnergy(const V3<S>& e, const S& th, const V3<S>& E, const S& rt, const S& rn, const ClampConst& c) {
  const S l = S(0.5) * norm(E);
  const FrameT<S> F = restFrameOf(E, c.n);
  const V3<S> t = normalized(e);
  S energy(0.0);
  if (c.bend) {
    const V3<S> u = parallelTransport(F.t, t, F.d1);
    V3<S> m1, m2;
    materialDirectors(t, u, th, m1, m2);
    const V3<S> kb = curvatureBinormal(F.t, t);
    const S wf1 = dot(kb, F.d2), wf2 = dot(kb, F.d1);
    const S we1 = dot(kb, m2), we2 = dot(kb, m1);
    const S Bin = stiffness::bendingIn(c.youngModulus, rt, rn);
    const S Bout = stiffness::bendingOut(c.youngModulus, rt, rn);
    energy = energy + (S(0.25) / l) * (Bin * (wf1 * wf1 + we1 * we1) + Bout * (wf2 * wf2 + we2 * we2));
  }
  if (c.twist) energy = energy + (S(0.5) / l) * stiffness::twisting(c.shearModulus, rt, rn) * th * th;
  return energy;
}

}  // namespace rodmesh::energies
