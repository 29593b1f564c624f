// Gravity on one edge's mass, lumped half to each endpoint:
//   E_g = - m g . (x_a + x_b) / 2,   m = rho pi |E| (r_tA r_nA + r_tB r_nB) / 2.
// Local variables: x = x_a (3), x_b (3); p = E (3), radii at both ends (4).
#pragma once

#include "model/energies/rod_math.hh"
#include "model/stiffness.hh"

namespace rodmesh::energies {

struct GravityConst {
  Eigen::Vector3d g = Eigen::Vector3d::Zero();
  double density = 0.0;
};

template <class S>
S gravityEnergy(const V3<S>& xa, const V3<S>& xb, const V3<S>& E, const S& rtA, const S& rnA, const S& rtB,
                const S& rnB, const GravityConst& c) {
  const S m = S(0.5) * norm(E) *
              (stiffness::massPerLength(c.density, rtA, rnA) + stiffness::massPerLength(c.density, rtB, rnB));
  return -(S(0.5) * m) * (dot(c.g, xa) + dot(c.g, xb));
}

}  // namespace rodmesh::energies
