// Stretching of one edge (Bergou 2008 §4.1, axial strain form):
//   E_s = 1/2 k |E| (|e| / |E| - 1)^2,   k = E pi r_t r_n (mean of the endpoints).
// Local variables: x = current edge vector e (3); p = rest edge vector E (3),
// radii [r_t, r_n] at the two endpoints (4).
#pragma once

#include "model/energies/rod_math.hh"
#include "model/stiffness.hh"

namespace rodmesh::energies {

struct StretchConst {
  double youngModulus = 0.0;
};

template <class S>
S stretchEnergy(const V3<S>& e, const V3<S>& E, const S& rtA, const S& rnA, const S& rtB, const S& rnB,
                const StretchConst& c) {
  const S k = S(0.5) * (stiffness::stretching(c.youngModulus, rtA, rnA) + stiffness::stretching(c.youngModulus, rtB, rnB));
  const S L = norm(E);
  const S strain = norm(e) / L - S(1.0);
  return S(0.5) * k * L * strain * strain;
}

}  // namespace rodmesh::energies
