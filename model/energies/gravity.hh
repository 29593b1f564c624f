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

// The edge's mass (design only).
template <class S>
S gravityMass(const V3<S>& E, const S& rtA, const S& rnA, const S& rtB, const S& rnB, const GravityConst& c) {
  return stiffness::edgeMass(c.density, norm(E), rtA, rnA, rtB, rnB);
}

// g . (x_a + x_b) (current positions only).
template <class S>
S gravityHeight(const V3<S>& xa, const V3<S>& xb, const GravityConst& c) {
  return dot(c.g, xa) + dot(c.g, xb);
}

template <class S>
S gravityOf(const S& mass, const S& height) {
  return -(S(0.5) * mass) * height;
}

template <class S>
S gravityEnergy(const V3<S>& xa, const V3<S>& xb, const V3<S>& E, const S& rtA, const S& rnA, const S& rtB,
                const S& rnB, const GravityConst& c) {
  return gravityOf(gravityMass(E, rtA, rnA, rtB, rnB, c), gravityHeight(xa, xb, c));
}

}  // namespace rodmesh::energies
