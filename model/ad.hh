// Forward-mode automatic differentiation for energy kernels.
//
// Every energy kernel is a function template on its scalar type S. Evaluated
// with
//   - double:                 the value;
//   - Hess<N>:                value, gradient and dense Hessian w.r.t. N seeded
//                             local variables (exact, no truncation error);
//   - Hess<N, Dual>:          the same, plus the directional derivative of all
//                             three along a seeded direction v (Dual carries
//                             d/de at e = 0 of x + e v): third derivatives of
//                             the energy contracted with v, as the Hessian of
//                             the Lagrangian of the equilibrium constraints needs.
// The Hessian is stored packed (lower triangle, row-major: entry (i, j), i >= j,
// at i (i + 1) / 2 + j).
#pragma once

#include <array>
#include <cmath>
#include <type_traits>

namespace rodmesh::ad {

// ---------------------------------------------------------------- Dual ----
// First-order dual number v + d e, e^2 = 0.
struct Dual {
  double v = 0.0, d = 0.0;
  Dual() = default;
  Dual(double value) : v(value), d(0.0) {}  // NOLINT: implicit by design
  Dual(double value, double der) : v(value), d(der) {}
};
inline Dual operator+(Dual a, Dual b) { return {a.v + b.v, a.d + b.d}; }
inline Dual operator-(Dual a, Dual b) { return {a.v - b.v, a.d - b.d}; }
inline Dual operator-(Dual a) { return {-a.v, -a.d}; }
inline Dual operator*(Dual a, Dual b) { return {a.v * b.v, a.d * b.v + a.v * b.d}; }
inline Dual operator/(Dual a, Dual b) { return {a.v / b.v, (a.d * b.v - a.v * b.d) / (b.v * b.v)}; }
inline Dual& operator+=(Dual& a, Dual b) { return a = a + b; }
inline Dual& operator-=(Dual& a, Dual b) { return a = a - b; }
inline Dual& operator*=(Dual& a, Dual b) { return a = a * b; }
inline Dual sqrt(Dual a) { double s = std::sqrt(a.v); return {s, a.d / (2.0 * s)}; }
inline Dual sin(Dual a) { return {std::sin(a.v), std::cos(a.v) * a.d}; }
inline Dual cos(Dual a) { return {std::cos(a.v), -std::sin(a.v) * a.d}; }
inline Dual atan2(Dual y, Dual x) {
  double r2 = x.v * x.v + y.v * y.v;
  return {std::atan2(y.v, x.v), (x.v * y.d - y.v * x.d) / r2};
}
inline bool operator<(Dual a, Dual b) { return a.v < b.v; }
inline bool operator>(Dual a, Dual b) { return a.v > b.v; }
inline double value(Dual a) { return a.v; }
inline double value(double a) { return a; }

// ---------------------------------------------------------------- Hess ----
template <int N, class T = double>
struct Hess {
  static constexpr int kN = N;
  static constexpr int kNH = N * (N + 1) / 2;
  T v{};
  std::array<T, N> g{};
  std::array<T, kNH> h{};

  Hess() = default;
  Hess(double c) : v(c) {}  // NOLINT: constants promote implicitly
  Hess(const T& c, int) : v(c) {}
  // An independent variable: value x, derivative 1 in slot i.
  static Hess variable(const T& x, int i) {
    Hess r;
    r.v = x;
    r.g[i] = T(1.0);
    return r;
  }
  static constexpr int hidx(int i, int j) { return i >= j ? i * (i + 1) / 2 + j : j * (j + 1) / 2 + i; }
  const T& hess(int i, int j) const { return h[hidx(i, j)]; }
};

// Composition with a scalar function f, given f(a), f'(a), f''(a).
template <int N, class T>
inline Hess<N, T> chain(const Hess<N, T>& a, const T& f, const T& df, const T& d2f) {
  Hess<N, T> r;
  r.v = f;
  for (int i = 0; i < N; ++i) r.g[i] = df * a.g[i];
  int k = 0;
  for (int i = 0; i < N; ++i) {
    const T ci = d2f * a.g[i];
    for (int j = 0; j <= i; ++j, ++k) r.h[k] = df * a.h[k] + ci * a.g[j];
  }
  return r;
}

template <int N, class T>
inline Hess<N, T> operator+(const Hess<N, T>& a, const Hess<N, T>& b) {
  Hess<N, T> r;
  r.v = a.v + b.v;
  for (int i = 0; i < N; ++i) r.g[i] = a.g[i] + b.g[i];
  for (int k = 0; k < Hess<N, T>::kNH; ++k) r.h[k] = a.h[k] + b.h[k];
  return r;
}
template <int N, class T>
inline Hess<N, T> operator-(const Hess<N, T>& a, const Hess<N, T>& b) {
  Hess<N, T> r;
  r.v = a.v - b.v;
  for (int i = 0; i < N; ++i) r.g[i] = a.g[i] - b.g[i];
  for (int k = 0; k < Hess<N, T>::kNH; ++k) r.h[k] = a.h[k] - b.h[k];
  return r;
}
template <int N, class T>
inline Hess<N, T> operator-(const Hess<N, T>& a) {
  Hess<N, T> r;
  r.v = -a.v;
  for (int i = 0; i < N; ++i) r.g[i] = -a.g[i];
  for (int k = 0; k < Hess<N, T>::kNH; ++k) r.h[k] = -a.h[k];
  return r;
}
template <int N, class T>
inline Hess<N, T> operator*(const Hess<N, T>& a, const Hess<N, T>& b) {
  Hess<N, T> r;
  r.v = a.v * b.v;
  for (int i = 0; i < N; ++i) r.g[i] = a.v * b.g[i] + b.v * a.g[i];
  int k = 0;
  for (int i = 0; i < N; ++i)
    for (int j = 0; j <= i; ++j, ++k) r.h[k] = a.v * b.h[k] + b.v * a.h[k] + a.g[i] * b.g[j] + a.g[j] * b.g[i];
  return r;
}
// Scalar (constant) operands.
template <int N, class T>
inline Hess<N, T> scale(const Hess<N, T>& a, const T& s) {
  Hess<N, T> r;
  r.v = a.v * s;
  for (int i = 0; i < N; ++i) r.g[i] = a.g[i] * s;
  for (int k = 0; k < Hess<N, T>::kNH; ++k) r.h[k] = a.h[k] * s;
  return r;
}
template <int N, class T>
inline Hess<N, T> operator*(const Hess<N, T>& a, double s) { return scale(a, T(s)); }
template <int N, class T>
inline Hess<N, T> operator*(double s, const Hess<N, T>& a) { return scale(a, T(s)); }
template <int N, class T>
inline Hess<N, T> operator+(const Hess<N, T>& a, double s) { Hess<N, T> r = a; r.v = r.v + T(s); return r; }
template <int N, class T>
inline Hess<N, T> operator+(double s, const Hess<N, T>& a) { return a + s; }
template <int N, class T>
inline Hess<N, T> operator-(const Hess<N, T>& a, double s) { Hess<N, T> r = a; r.v = r.v - T(s); return r; }
template <int N, class T>
inline Hess<N, T> operator-(double s, const Hess<N, T>& a) { return -a + s; }

template <int N, class T>
inline Hess<N, T> inverse(const Hess<N, T>& a) {
  const T i = T(1.0) / a.v;
  return chain(a, i, -(i * i), T(2.0) * i * i * i);
}
template <int N, class T>
inline Hess<N, T> operator/(const Hess<N, T>& a, const Hess<N, T>& b) { return a * inverse(b); }
template <int N, class T>
inline Hess<N, T> operator/(const Hess<N, T>& a, double s) { return scale(a, T(1.0 / s)); }
template <int N, class T>
inline Hess<N, T> operator/(double s, const Hess<N, T>& b) { return scale(inverse(b), T(s)); }

template <int N, class T>
inline Hess<N, T>& operator+=(Hess<N, T>& a, const Hess<N, T>& b) { return a = a + b; }
template <int N, class T>
inline Hess<N, T>& operator-=(Hess<N, T>& a, const Hess<N, T>& b) { return a = a - b; }
template <int N, class T>
inline Hess<N, T>& operator*=(Hess<N, T>& a, const Hess<N, T>& b) { return a = a * b; }

template <int N, class T>
inline Hess<N, T> sqrt(const Hess<N, T>& a) {
  using std::sqrt;
  const T s = sqrt(a.v);
  const T d = T(0.5) / s;
  return chain(a, s, d, -(d / (T(2.0) * a.v)));
}
template <int N, class T>
inline Hess<N, T> sin(const Hess<N, T>& a) {
  using std::cos;
  using std::sin;
  const T s = sin(a.v);
  return chain(a, s, cos(a.v), -s);
}
template <int N, class T>
inline Hess<N, T> cos(const Hess<N, T>& a) {
  using std::cos;
  using std::sin;
  const T c = cos(a.v);
  return chain(a, c, -sin(a.v), -c);
}
// atan2(y, x) with the exact second derivatives of the angle.
template <int N, class T>
inline Hess<N, T> atan2(const Hess<N, T>& y, const Hess<N, T>& x) {
  using std::atan2;
  Hess<N, T> r;
  const T r2 = x.v * x.v + y.v * y.v;
  const T fy = x.v / r2, fx = -(y.v / r2);
  const T r4 = r2 * r2;
  const T fyy = T(-2.0) * x.v * y.v / r4;
  const T fxx = T(2.0) * x.v * y.v / r4;
  const T fxy = (y.v * y.v - x.v * x.v) / r4;
  r.v = atan2(y.v, x.v);
  for (int i = 0; i < N; ++i) r.g[i] = fy * y.g[i] + fx * x.g[i];
  int k = 0;
  for (int i = 0; i < N; ++i)
    for (int j = 0; j <= i; ++j, ++k)
      r.h[k] = fy * y.h[k] + fx * x.h[k] + fyy * y.g[i] * y.g[j] + fxx * x.g[i] * x.g[j] +
               fxy * (y.g[i] * x.g[j] + x.g[i] * y.g[j]);
  return r;
}

template <int N, class T>
inline double value(const Hess<N, T>& a) { return value(a.v); }

// ---------------------------------------------------------------- Grad ----
// Value and gradient only: for evaluations that need forces but no Hessian
// (dynamic relaxation, residual checks), several times cheaper than Hess.
template <int N, class T = double>
struct Grad {
  T v{};
  std::array<T, N> g{};
  Grad() = default;
  Grad(double c) : v(c) {}  // NOLINT: constants promote implicitly
  Grad(const T& c, int) : v(c) {}
  static Grad variable(const T& x, int i) {
    Grad r;
    r.v = x;
    r.g[i] = T(1.0);
    return r;
  }
};
template <int N, class T>
inline Grad<N, T> chain(const Grad<N, T>& a, const T& f, const T& df) {
  Grad<N, T> r;
  r.v = f;
  for (int i = 0; i < N; ++i) r.g[i] = df * a.g[i];
  return r;
}
template <int N, class T>
inline Grad<N, T> operator+(const Grad<N, T>& a, const Grad<N, T>& b) {
  Grad<N, T> r;
  r.v = a.v + b.v;
  for (int i = 0; i < N; ++i) r.g[i] = a.g[i] + b.g[i];
  return r;
}
template <int N, class T>
inline Grad<N, T> operator-(const Grad<N, T>& a, const Grad<N, T>& b) {
  Grad<N, T> r;
  r.v = a.v - b.v;
  for (int i = 0; i < N; ++i) r.g[i] = a.g[i] - b.g[i];
  return r;
}
template <int N, class T>
inline Grad<N, T> operator-(const Grad<N, T>& a) {
  Grad<N, T> r;
  r.v = -a.v;
  for (int i = 0; i < N; ++i) r.g[i] = -a.g[i];
  return r;
}
template <int N, class T>
inline Grad<N, T> operator*(const Grad<N, T>& a, const Grad<N, T>& b) {
  Grad<N, T> r;
  r.v = a.v * b.v;
  for (int i = 0; i < N; ++i) r.g[i] = a.v * b.g[i] + b.v * a.g[i];
  return r;
}
template <int N, class T>
inline Grad<N, T> operator*(const Grad<N, T>& a, double s) {
  Grad<N, T> r;
  r.v = a.v * s;
  for (int i = 0; i < N; ++i) r.g[i] = a.g[i] * s;
  return r;
}
template <int N, class T>
inline Grad<N, T> operator*(double s, const Grad<N, T>& a) { return a * s; }
template <int N, class T>
inline Grad<N, T> operator+(const Grad<N, T>& a, double s) { Grad<N, T> r = a; r.v = r.v + T(s); return r; }
template <int N, class T>
inline Grad<N, T> operator+(double s, const Grad<N, T>& a) { return a + s; }
template <int N, class T>
inline Grad<N, T> operator-(const Grad<N, T>& a, double s) { Grad<N, T> r = a; r.v = r.v - T(s); return r; }
template <int N, class T>
inline Grad<N, T> operator-(double s, const Grad<N, T>& a) { return -a + s; }
template <int N, class T>
inline Grad<N, T> inverse(const Grad<N, T>& a) {
  const T i = T(1.0) / a.v;
  return chain(a, i, -(i * i));
}
template <int N, class T>
inline Grad<N, T> operator/(const Grad<N, T>& a, const Grad<N, T>& b) { return a * inverse(b); }
template <int N, class T>
inline Grad<N, T> operator/(const Grad<N, T>& a, double s) { return a * (1.0 / s); }
template <int N, class T>
inline Grad<N, T> operator/(double s, const Grad<N, T>& b) { return inverse(b) * s; }
template <int N, class T>
inline Grad<N, T> sqrt(const Grad<N, T>& a) {
  using std::sqrt;
  const T s = sqrt(a.v);
  return chain(a, s, T(0.5) / s);
}
template <int N, class T>
inline Grad<N, T> sin(const Grad<N, T>& a) {
  using std::cos;
  using std::sin;
  return chain(a, sin(a.v), cos(a.v));
}
template <int N, class T>
inline Grad<N, T> cos(const Grad<N, T>& a) {
  using std::cos;
  using std::sin;
  return chain(a, cos(a.v), -sin(a.v));
}
template <int N, class T>
inline Grad<N, T> atan2(const Grad<N, T>& y, const Grad<N, T>& x) {
  using std::atan2;
  Grad<N, T> r;
  const T r2 = x.v * x.v + y.v * y.v;
  const T fy = x.v / r2, fx = -(y.v / r2);
  r.v = atan2(y.v, x.v);
  for (int i = 0; i < N; ++i) r.g[i] = fy * y.g[i] + fx * x.g[i];
  return r;
}
template <int N, class T>
inline double value(const Grad<N, T>& a) { return value(a.v); }

// Embeds a scalar differentiated over M variables into one over N >= M
// variables: variable i becomes variable slots[i].
template <int N, int M, class T>
inline Hess<N, T> lift(const Hess<M, T>& a, const int* slots) {
  static_assert(M <= N, "lift to a smaller variable set");
  Hess<N, T> r;
  r.v = a.v;
  for (int i = 0; i < M; ++i) {
    r.g[slots[i]] = a.g[i];
    for (int j = 0; j <= i; ++j) r.h[Hess<N, T>::hidx(slots[i], slots[j])] = a.h[Hess<M, T>::hidx(i, j)];
  }
  return r;
}

template <class S>
struct IsHessDouble : std::false_type {};
template <int N>
struct IsHessDouble<Hess<N, double>> : std::true_type {
  static constexpr int n = N;
};

// Comparisons look at values only (branches must not depend on derivatives).
template <int N, class T>
inline bool operator<(const Hess<N, T>& a, double b) { return value(a) < b; }
template <int N, class T>
inline bool operator>(const Hess<N, T>& a, double b) { return value(a) > b; }

}  // namespace rodmesh::ad
