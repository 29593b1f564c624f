// Cross-section stiffnesses of an elliptic section with semi-axes r_t (in the
// surface's tangent plane) and r_n (along the reference normal), as fixed by
// docs/formats.md §1. Templated on the scalar so that design
// derivatives (w.r.t. the radii) come out of the same code.
#pragma once

namespace rodmesh::stiffness {

constexpr double kPi = 3.14159265358979323846;

// Axial stiffness E A.
template <class S> inline S stretching(double E, const S& rt, const S& rn) { return (E * kPi) * rt * rn; }
// Bending toward the normal (out of the surface): curvature about the d1 axis.
template <class S> inline S bendingOut(double E, const S& rt, const S& rn) { return (E * kPi / 4.0) * rt * rn * rn * rn; }
// Bending within the tangent plane: curvature about the d2 (normal) axis.
template <class S> inline S bendingIn(double E, const S& rt, const S& rn) { return (E * kPi / 4.0) * rt * rt * rt * rn; }
// Torsional stiffness G J of the ellipse.
template <class S> inline S twisting(double G, const S& rt, const S& rn) {
  const S rt2 = rt * rt, rn2 = rn * rn;
  return (G * kPi) * (rt2 * rt * rn2 * rn) / (rt2 + rn2);
}
// Mass per unit length.
template <class S> inline S massPerLength(double rho, const S& rt, const S& rn) { return (rho * kPi) * rt * rn; }
// Mass of an edge of rest length L between ends of radii (rtA, rnA) and
// (rtB, rnB): L times the mean of the ends' masses per length. Lumped half to
// each end, it is the mass of the dynamics and the weight under gravity.
template <class S>
inline S edgeMass(double rho, const S& L, const S& rtA, const S& rnA, const S& rtB, const S& rnB) {
  return S(0.5) * L * (massPerLength(rho, rtA, rnA) + massPerLength(rho, rtB, rnB));
}

}  // namespace rodmesh::stiffness
