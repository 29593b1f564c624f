// Stretching of one edge (Bergou 2008 §4.1, axial strain form):
//   E_s = 1/2 k |E| (|e| / |E| - 1)^2 = k / (2 |E|) (|e| - |E|)^2,
//   k = E pi r_t r_n (mean of the two endpoints).
// Local variables: x = current edge vector e (3); p = rest edge vector E (3),
// radii [r_t, r_n] at the two endpoints (4).
//
// Kernels are split into a rest part (scalar P: design data, double in
// simulation) and a current part (scalar S), so that simulation does not pay
// for differentiating constants.
#pragma once

#include "model/energies/rod_math.hh"
#include "model/stiffness.hh"

namespace rodmesh::energies {

struct StretchConst {
  double youngModulus = 0.0;
};

template <class P>
struct StretchRest {
  P length;      // |E|
  P halfKOverL;  // k / (2 |E|)
};

template <class P>
StretchRest<P> stretchRest(const V3<P>& E, const P& rtA, const P& rnA, const P& rtB, const P& rnB,
                           const StretchConst& c) {
  const P k = P(0.5) * (stiffness::stretching(c.youngModulus, rtA, rnA) + stiffness::stretching(c.youngModulus, rtB, rnB));
  const P L = norm(E);
  return {L, P(0.5) * k / L};
}

// From the current edge length |e|.
template <class S, class P>
S stretchEnergyOfLength(const S& len, const StretchRest<P>& r) {
  const S d = len - r.length;
  return d * d * r.halfKOverL;
}

template <class S, class P>
S stretchEnergy(const V3<S>& e, const StretchRest<P>& r) {
  return stretchEnergyOfLength(norm(e), r);
}

}  // namespace rodmesh::energies
