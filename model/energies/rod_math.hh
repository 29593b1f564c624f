// Small 3-vector algebra on a generic scalar (double, ad::Hess, ad::Dual) and
// the discrete-elastic-rod frame operations the kernels share.
//
// References: Bergou et al. 2008 "Discrete elastic rods" (§4: curvature
// binormal, parallel transport, material frame); Bergou et al. 2010 "Discrete
// viscous threads" (§5: reference twist).
#pragma once

#include "model/ad.hh"
#include "model/limits.hh"

#include <Eigen/Core>
#include <cmath>
#include <limits>

namespace rodmesh {

template <class S>
struct V3 {
  S x, y, z;
  V3() : x(0.0), y(0.0), z(0.0) {}
  V3(const S& a, const S& b, const S& c) : x(a), y(b), z(c) {}
  explicit V3(const Eigen::Vector3d& v) : x(v[0]), y(v[1]), z(v[2]) {}
  const S& operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  S& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
};

template <class S> inline V3<S> operator+(const V3<S>& a, const V3<S>& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
template <class S> inline V3<S> operator-(const V3<S>& a, const V3<S>& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
template <class S> inline V3<S> operator-(const V3<S>& a) { return {-a.x, -a.y, -a.z}; }
template <class S> inline V3<S> operator*(const S& s, const V3<S>& a) { return {s * a.x, s * a.y, s * a.z}; }
template <class S> inline S dot(const V3<S>& a, const V3<S>& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
template <class S> inline V3<S> cross(const V3<S>& a, const V3<S>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
// The same on Hessian-carrying scalars, each component formed in one pass
// (ad::productSum, ad::productDifference) instead of through temporaries.
template <int N, class T>
inline ad::Hess<N, T> dot(const V3<ad::Hess<N, T>>& a, const V3<ad::Hess<N, T>>& b) {
  return ad::productSum(a.x, b.x, a.y, b.y, a.z, b.z);
}
template <int N, class T>
inline V3<ad::Hess<N, T>> cross(const V3<ad::Hess<N, T>>& a, const V3<ad::Hess<N, T>>& b) {
  return {ad::productDifference(a.y, b.z, a.z, b.y), ad::productDifference(a.z, b.x, a.x, b.z),
          ad::productDifference(a.x, b.y, a.y, b.x)};
}
template <class S> inline S norm(const V3<S>& a) {
  using std::sqrt;
  return sqrt(dot(a, a));
}
template <class S> inline V3<S> normalized(const V3<S>& a) { return (S(1.0) / norm(a)) * a; }
// Mixed-type helpers: a constant (double) vector with a generic one.
template <class S> inline S dot(const Eigen::Vector3d& a, const V3<S>& b) { return a[0] * b.x + a[1] * b.y + a[2] * b.z; }

// Mixed-scalar helpers: a (rest) vector of scalar P with a (current) vector of
// scalar S; the result has scalar S. P is double in simulation (rest data are
// constants) and equal to S when design derivatives are wanted.
template <class P, class S> inline S dotm(const V3<P>& a, const V3<S>& b) { return b.x * a.x + b.y * a.y + b.z * a.z; }
template <class P, class S> inline V3<S> crossm(const V3<P>& a, const V3<S>& b) {
  return {b.z * a.y - b.y * a.z, b.x * a.z - b.z * a.x, b.y * a.x - b.x * a.y};
}

// Parallel transport of v by the rotation about a x b taking unit a to unit b
// (Bergou 2008 §4.2): P v = (a.b) v + (a x b) x v + ((a x b).v / (1 + a.b)) (a x b).
// Smooth except at a = -b.
template <class S>
inline V3<S> parallelTransport(const V3<S>& a, const V3<S>& b, const V3<S>& v) {
  const V3<S> c = cross(a, b);
  const S d = dot(a, b);
  return d * v + cross(c, v) + (dot(c, v) / (S(1.0) + d)) * c;
}

// Transport of the rest vector v from the rest tangent a to the current
// tangent b (same formula as parallelTransport, mixed scalars).
template <class P, class S>
inline V3<S> transportFromRest(const V3<P>& a, const V3<S>& b, const V3<P>& v) {
  const V3<S> c = crossm(a, b);
  const S d = dotm(a, b);
  const S k = dotm(v, c) / (S(1.0) + d);
  // d v + c x v + k c
  return {d * v.x + (c.y * v.z - c.z * v.y) + k * c.x, d * v.y + (c.z * v.x - c.x * v.z) + k * c.y,
          d * v.z + (c.x * v.y - c.y * v.x) + k * c.z};
}

// Signed angle from p to q about the unit axis t (p, q perpendicular to t).
template <class S>
inline S signedAngle(const V3<S>& p, const V3<S>& q, const V3<S>& t) {
  using std::atan2;
  return atan2(dot(cross(p, q), t), dot(p, q));
}

// Curvature binormal between consecutive unit tangents (Bergou 2008 eq. 1):
// kb = 2 t0 x t1 / (1 + t0 . t1), of length 2 tan(phi / 2).
template <class S>
inline V3<S> curvatureBinormal(const V3<S>& t0, const V3<S>& t1) {
  return (S(2.0) / (S(1.0) + dot(t0, t1))) * cross(t0, t1);
}

// Orthonormal frame of an edge: tangent t, d1 (tangent-plane director, r_t
// axis), d2 (normal director, r_n axis), with t x d1 = d2.
template <class S>
struct FrameT {
  V3<S> t, d1, d2;
};

// Rest frame of an edge vector E whose reference normal is the constant unit
// vector n: d2 = normalise(n - (n.t) t), d1 = d2 x t. A smooth function of E
// while n is not parallel to E (see docs/model.md). Within
// limits::kNormalAlongEdgeSine of parallel, where the scene reader refuses
// a normal, the frame is undefined and comes out NaN: a designed rest shape
// that turns an edge onto its normal is a failed evaluation, which the
// optimizers step back from, not a design `simulate` could not read.
template <class S>
inline FrameT<S> restFrameOf(const V3<S>& E, const Eigen::Vector3d& n) {
  FrameT<S> f;
  f.t = normalized(E);
  const S nt = dot(n, f.t);
  const V3<S> nn{S(n[0]), S(n[1]), S(n[2])};
  const V3<S> across = nn - nt * f.t;
  const double ax = ad::value(across.x), ay = ad::value(across.y), az = ad::value(across.z);
  if (!(std::sqrt(ax * ax + ay * ay + az * az) >= limits::kNormalAlongEdgeSine)) {
    const S nan(std::numeric_limits<double>::quiet_NaN());
    f.t = f.d1 = f.d2 = V3<S>{nan, nan, nan};
    return f;
  }
  f.d2 = normalized(across);
  f.d1 = cross(f.d2, f.t);
  return f;
}

// Material directors of an edge with current unit tangent t, reference
// director u (perpendicular to t) and twist angle theta:
// m1 = cos(theta) u + sin(theta) (t x u), m2 = t x m1.
template <class S>
inline void materialDirectors(const V3<S>& t, const V3<S>& u, const S& theta, V3<S>& m1, V3<S>& m2) {
  using std::cos;
  using std::sin;
  const S c = cos(theta), s = sin(theta);
  const V3<S> v = cross(t, u);
  m1 = c * u + s * v;
  m2 = c * v - s * u;
}

// The current frame of one edge: tangent, reference director (the chart
// director chartD transported from the chart tangent chartT to the current
// tangent), material directors. Depends on that edge's vector and twist
// only, so callers can differentiate it over those few variables and lift
// the result into a larger variable set (see PoseSystem), which is much
// cheaper than differentiating it over a whole stencil's variables.
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

// Wraps an angle difference into (-pi, pi]; a constant shift, so derivatives
// pass through unchanged. The shift is one multiple of 2 pi, whatever the
// angle: the twists it wraps contain twist unknowns, which a trial step of a
// solver can make arbitrarily large (stepping by 2 pi at a time would then
// take time in proportion to the angle, and never end for an infinite one or
// beyond 2^53 rad, where subtracting 2 pi leaves the value unchanged). A
// non-finite angle is returned as it is, so that the energy is not finite and
// the step is rejected. Beyond 2^52 rad a double has no fractional part, so
// no angle modulo 2 pi is left to keep: the result is 0.
template <class S>
inline S wrapAngle(S a) {
  constexpr double kPi = 3.14159265358979323846;
  constexpr double kTwoPi = 2.0 * kPi;
  constexpr double kWhole = 4503599627370496.0;  // 2^52
  const double v = ad::value(a);
  if (!std::isfinite(v) || (v <= kPi && v > -kPi)) return a;
  if (std::abs(v) >= kWhole) return a - v;
  // Below 2^52 the shift's rounding error is at most half a radian, so one
  // more step of 2 pi brings a result just outside back in.
  a = a - std::round(v / kTwoPi) * kTwoPi;
  if (ad::value(a) > kPi) a = a - kTwoPi;
  if (ad::value(a) <= -kPi) a = a + kTwoPi;
  return a;
}

}  // namespace rodmesh
