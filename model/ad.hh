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
//
// A default-constructed Hess or Grad is zero; results of the operations below
// are built without zero-filling first (every entry is written), which matters
// for the large joint (u, p) stencils where a Hess is kilobytes. compose()
// applies the second-order chain rule to an outer function of intermediate
// scalars, so kernels can differentiate pieces over the few variables each
// depends on and combine them exactly (see model/pose_system_detail.hh).
#pragma once

#include <array>
#include <cmath>
#include <type_traits>

namespace rodmesh::ad {

// ---------------------------------------------------------------- Dual ----
// First-order dual number v + d e, e^2 = 0. Like a double, a default-
// initialised Dual (`Dual x;`) is indeterminate and a value-initialised one
// (`Dual x{};`, `Dual()`) is zero: arrays of Duals inside Hess/Grad results
// are then not zero-filled before being written.
struct Dual {
  double v, d;
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
// Tag: construct without zero-filling (every entry is written afterwards).
struct NoInit {};

template <int N, class T = double>
struct Hess {
  static constexpr int kN = N;
  static constexpr int kNH = N * (N + 1) / 2;
  T v;
  std::array<T, N> g;
  std::array<T, kNH> h;

  Hess() : v(), g(), h() {}
  Hess(double c) : v(c), g(), h() {}  // NOLINT: constants promote implicitly
  Hess(const T& c, int) : v(c), g(), h() {}
  explicit Hess(NoInit) {}
  // An independent variable: value x, derivative 1 in slot i.
  static Hess variable(const T& x, int i) {
    Hess r;
    r.v = x;
    r.g[i] = T(1.0);
    return r;
  }
  // The same in place, on a zero Hess (no copy of the arrays).
  void makeVariable(const T& x, int i) {
    v = x;
    g[i] = T(1.0);
  }
  static constexpr int hidx(int i, int j) { return i >= j ? i * (i + 1) / 2 + j : j * (j + 1) / 2 + i; }
  const T& hess(int i, int j) const { return h[hidx(i, j)]; }
};

// Composition with a scalar function f, given f(a), f'(a), f''(a).
template <int N, class T>
inline Hess<N, T> chain(const Hess<N, T>& a, const T& f, const T& df, const T& d2f) {
  Hess<N, T> r{NoInit{}};
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
  Hess<N, T> r{NoInit{}};
  r.v = a.v + b.v;
  for (int i = 0; i < N; ++i) r.g[i] = a.g[i] + b.g[i];
  for (int k = 0; k < Hess<N, T>::kNH; ++k) r.h[k] = a.h[k] + b.h[k];
  return r;
}
template <int N, class T>
inline Hess<N, T> operator-(const Hess<N, T>& a, const Hess<N, T>& b) {
  Hess<N, T> r{NoInit{}};
  r.v = a.v - b.v;
  for (int i = 0; i < N; ++i) r.g[i] = a.g[i] - b.g[i];
  for (int k = 0; k < Hess<N, T>::kNH; ++k) r.h[k] = a.h[k] - b.h[k];
  return r;
}
template <int N, class T>
inline Hess<N, T> operator-(const Hess<N, T>& a) {
  Hess<N, T> r{NoInit{}};
  r.v = -a.v;
  for (int i = 0; i < N; ++i) r.g[i] = -a.g[i];
  for (int k = 0; k < Hess<N, T>::kNH; ++k) r.h[k] = -a.h[k];
  return r;
}
template <int N, class T>
inline Hess<N, T> operator*(const Hess<N, T>& a, const Hess<N, T>& b) {
  Hess<N, T> r{NoInit{}};
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
  Hess<N, T> r{NoInit{}};
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
inline Hess<N, T>& operator+=(Hess<N, T>& a, const Hess<N, T>& b) {
  a.v = a.v + b.v;
  for (int i = 0; i < N; ++i) a.g[i] = a.g[i] + b.g[i];
  for (int k = 0; k < Hess<N, T>::kNH; ++k) a.h[k] = a.h[k] + b.h[k];
  return a;
}
template <int N, class T>
inline Hess<N, T>& operator-=(Hess<N, T>& a, const Hess<N, T>& b) {
  a.v = a.v - b.v;
  for (int i = 0; i < N; ++i) a.g[i] = a.g[i] - b.g[i];
  for (int k = 0; k < Hess<N, T>::kNH; ++k) a.h[k] = a.h[k] - b.h[k];
  return a;
}
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
  Hess<N, T> r{NoInit{}};
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

// Sums of signed products, a0 b0 ± a1 b1 [± a2 b2], in one pass over the
// result: the dot products and cross-product components of the frame
// operations (model/energies/rod_math.hh) otherwise build K products and
// K − 1 sums as whole temporaries, kilobytes each for the larger stencils.
// Each entry is formed in the order the separate operators use (each product
// as in operator*, then the products summed left to right).
template <int N, class T>
inline Hess<N, T> productSum(const Hess<N, T>& a0, const Hess<N, T>& b0, const Hess<N, T>& a1,
                             const Hess<N, T>& b1, const Hess<N, T>& a2, const Hess<N, T>& b2) {
  Hess<N, T> r{NoInit{}};
  r.v = a0.v * b0.v + a1.v * b1.v + a2.v * b2.v;
  for (int i = 0; i < N; ++i)
    r.g[i] = (a0.v * b0.g[i] + b0.v * a0.g[i]) + (a1.v * b1.g[i] + b1.v * a1.g[i]) +
             (a2.v * b2.g[i] + b2.v * a2.g[i]);
  int k = 0;
  for (int i = 0; i < N; ++i)
    for (int j = 0; j <= i; ++j, ++k)
      r.h[k] = (a0.v * b0.h[k] + b0.v * a0.h[k] + a0.g[i] * b0.g[j] + a0.g[j] * b0.g[i]) +
               (a1.v * b1.h[k] + b1.v * a1.h[k] + a1.g[i] * b1.g[j] + a1.g[j] * b1.g[i]) +
               (a2.v * b2.h[k] + b2.v * a2.h[k] + a2.g[i] * b2.g[j] + a2.g[j] * b2.g[i]);
  return r;
}
// a0 b0 − a1 b1.
template <int N, class T>
inline Hess<N, T> productDifference(const Hess<N, T>& a0, const Hess<N, T>& b0, const Hess<N, T>& a1,
                                    const Hess<N, T>& b1) {
  Hess<N, T> r{NoInit{}};
  r.v = a0.v * b0.v - a1.v * b1.v;
  for (int i = 0; i < N; ++i) r.g[i] = (a0.v * b0.g[i] + b0.v * a0.g[i]) - (a1.v * b1.g[i] + b1.v * a1.g[i]);
  int k = 0;
  for (int i = 0; i < N; ++i)
    for (int j = 0; j <= i; ++j, ++k)
      r.h[k] = (a0.v * b0.h[k] + b0.v * a0.h[k] + a0.g[i] * b0.g[j] + a0.g[j] * b0.g[i]) -
               (a1.v * b1.h[k] + b1.v * a1.h[k] + a1.g[i] * b1.g[j] + a1.g[j] * b1.g[i]);
  return r;
}

// ---------------------------------------------------------------- Grad ----
// Value and gradient only: for evaluations that need forces but no Hessian
// (dynamic relaxation, residual checks), several times cheaper than Hess.
template <int N, class T = double>
struct Grad {
  T v;
  std::array<T, N> g;
  Grad() : v(), g() {}
  Grad(double c) : v(c), g() {}  // NOLINT: constants promote implicitly
  Grad(const T& c, int) : v(c), g() {}
  explicit Grad(NoInit) {}
  static Grad variable(const T& x, int i) {
    Grad r;
    r.v = x;
    r.g[i] = T(1.0);
    return r;
  }
};
template <int N, class T>
inline Grad<N, T> chain(const Grad<N, T>& a, const T& f, const T& df) {
  Grad<N, T> r{NoInit{}};
  r.v = f;
  for (int i = 0; i < N; ++i) r.g[i] = df * a.g[i];
  return r;
}
template <int N, class T>
inline Grad<N, T> operator+(const Grad<N, T>& a, const Grad<N, T>& b) {
  Grad<N, T> r{NoInit{}};
  r.v = a.v + b.v;
  for (int i = 0; i < N; ++i) r.g[i] = a.g[i] + b.g[i];
  return r;
}
template <int N, class T>
inline Grad<N, T> operator-(const Grad<N, T>& a, const Grad<N, T>& b) {
  Grad<N, T> r{NoInit{}};
  r.v = a.v - b.v;
  for (int i = 0; i < N; ++i) r.g[i] = a.g[i] - b.g[i];
  return r;
}
template <int N, class T>
inline Grad<N, T> operator-(const Grad<N, T>& a) {
  Grad<N, T> r{NoInit{}};
  r.v = -a.v;
  for (int i = 0; i < N; ++i) r.g[i] = -a.g[i];
  return r;
}
template <int N, class T>
inline Grad<N, T> operator*(const Grad<N, T>& a, const Grad<N, T>& b) {
  Grad<N, T> r{NoInit{}};
  r.v = a.v * b.v;
  for (int i = 0; i < N; ++i) r.g[i] = a.v * b.g[i] + b.v * a.g[i];
  return r;
}
template <int N, class T>
inline Grad<N, T> operator*(const Grad<N, T>& a, double s) {
  Grad<N, T> r{NoInit{}};
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
  Grad<N, T> r{NoInit{}};
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

// The same with a change of scalar: a Hess over double (a piece that does not
// depend on a direction, e.g. one of the design only) as one over T.
template <int N, int M, class T>
inline Hess<N, T> liftAs(const Hess<M, double>& a, const int* slots) {
  static_assert(M <= N, "lift to a smaller variable set");
  Hess<N, T> r;
  r.v = T(a.v);
  for (int i = 0; i < M; ++i) {
    r.g[slots[i]] = T(a.g[i]);
    for (int j = 0; j <= i; ++j) r.h[Hess<N, T>::hidx(slots[i], slots[j])] = T(a.h[Hess<M, double>::hidx(i, j)]);
  }
  return r;
}

// acc += a lifted by slots (as lift(), accumulating).
template <int N, int M, class T>
inline void addLifted(Hess<N, T>& acc, const Hess<M, T>& a, const int* slots) {
  acc.v += a.v;
  for (int i = 0; i < M; ++i) {
    acc.g[slots[i]] += a.g[i];
    for (int j = 0; j <= i; ++j) acc.h[Hess<N, T>::hidx(slots[i], slots[j])] += a.h[Hess<M, T>::hidx(i, j)];
  }
}

// acc += a * b, b over M of a's N variables (variable i of b is variable
// slots[i] of a; distinct slots), both without a direction: a product of a
// scalar over many variables and one over a few, at the cost of a's Hessian.
template <int N, int M>
inline void addProductLifted(Hess<N, double>& acc, const Hess<N, double>& a, const Hess<M, double>& b,
                             const int* slots) {
  using H = Hess<N, double>;
  acc.v += a.v * b.v;
  for (int j = 0; j < N; ++j) acc.g[j] += a.g[j] * b.v;
  for (int i = 0; i < M; ++i) acc.g[slots[i]] += a.v * b.g[i];
  for (int k = 0; k < H::kNH; ++k) acc.h[k] += a.h[k] * b.v;
  // a_j b_l + a_l b_j: each ordered (j, slots[i]) once, the diagonal twice.
  for (int i = 0; i < M; ++i) {
    const int s = slots[i];
    // A slot is one of a's variables. Said to the compiler, which cannot see
    // it and otherwise warns (-Warray-bounds) about the negative slots it
    // must assume possible.
    if (s < 0 || s >= N) __builtin_unreachable();
    const double bi = b.g[i];
    for (int j = 0; j < N; ++j) acc.h[H::hidx(j, s)] += (j == s ? 2.0 : 1.0) * a.g[j] * bi;
    for (int l = 0; l <= i; ++l) acc.h[H::hidx(s, slots[l])] += a.v * b.h[Hess<M, double>::hidx(i, l)];
  }
}

// acc.h += the Hessian of x * q for two scalars on disjoint variables: x over
// M variables (variable a is target variable xslots[a]), q over the P
// consecutive target variables qfirst, ..., all after every xslots[a]; q
// without a direction. The value and gradient of acc are left alone.
template <int N, int M, int P, class T>
inline void addProductHessian(Hess<N, T>& acc, const Hess<M, T>& x, const int* xslots, const Hess<P, double>& q,
                              int qfirst) {
  using H = Hess<N, T>;
  for (int a = 0; a < M; ++a)
    for (int c = 0; c <= a; ++c) acc.h[H::hidx(xslots[a], xslots[c])] += x.h[Hess<M, T>::hidx(a, c)] * q.v;
  const double* qh = q.h.data();
  for (int b = 0; b < P; ++b) {
    const int s = qfirst + b;
    T* row = acc.h.data() + s * (s + 1) / 2;
    for (int a = 0; a < M; ++a) row[xslots[a]] += x.g[a] * q.g[b];
    T* rq = row + qfirst;
    for (int d = 0; d <= b; ++d) rq[d] += x.v * qh[d];
    qh += b + 1;
  }
}

// ------------------------------------------------------------- compose ----
// An intermediate scalar y for compose(), given over target variables in up
// to two parts, each over consecutive variables first, ..., first + m - 1
// with its gradient g and packed lower Hessian h (null: zero, e.g. a
// variable itself); y's Hessian has no entries between the two parts (a sum
// of a function of some variables and a function of others).
template <class T>
struct Inner {
  struct Part {
    const T* g = nullptr;
    const T* h = nullptr;
    int m = 0;
    int first = 0;
  };
  Part part[2];
  Inner() = default;
  Inner(const T* g, const T* h, int m, int first) : part{{g, h, m, first}, {}} {}
  Inner(const Part& a, const Part& b) : part{a, b} {}
};
template <int M, class T>
inline typename Inner<T>::Part innerPart(const Hess<M, T>& y, int first) {
  return {y.g.data(), y.h.data(), M, first};
}
template <int M, class T>
inline Inner<T> inner(const Hess<M, T>& y, int first) {
  return {y.g.data(), y.h.data(), M, first};
}

inline bool isZero(double a) { return a == 0.0; }
inline bool isZero(const Dual& a) { return a.v == 0.0 && a.d == 0.0; }

// The second-order chain rule, exact: f holds an outer function's value,
// gradient and Hessian w.r.t. M intermediate scalars y_k (as Hess<M> over
// them); y[k] gives y_k over the N target variables. The result is f as a
// function of the target variables:
//   g = sum_k f_k g_k,   H = sum_k f_k H_k + sum_kl f_kl g_k g_l^T.
template <int N, int M, class T>
Hess<N, T> compose(const Hess<M, T>& f, const Inner<T>* y) {
  using H = Hess<N, T>;
  H r;
  r.v = f.v;
  for (int k = 0; k < M; ++k) {
    const T fk = f.g[k];
    if (isZero(fk)) continue;
    for (const auto& yk : y[k].part) {
      T* rg = r.g.data() + yk.first;
      for (int a = 0; a < yk.m; ++a) rg[a] += fk * yk.g[a];
      if (!yk.h) continue;
      const T* hk = yk.h;
      for (int a = 0; a < yk.m; ++a) {
        const int s = yk.first + a;
        T* rh = r.h.data() + s * (s + 1) / 2 + yk.first;
        for (int b = 0; b <= a; ++b) rh[b] += fk * hk[b];
        hk += a + 1;
      }
    }
  }
  // W = f'' J (J: rows g_k over the targets), then H += J^T W (lower part).
  T W[M][N] = {};
  bool row[M] = {};
  for (int k = 0; k < M; ++k)
    for (int l = 0; l < M; ++l) {
      const T fkl = f.h[Hess<M, T>::hidx(k, l)];
      if (isZero(fkl)) continue;
      for (const auto& yl : y[l].part) {
        if (yl.m == 0) continue;
        row[k] = true;
        T* w = W[k] + yl.first;
        for (int a = 0; a < yl.m; ++a) w[a] += fkl * yl.g[a];
      }
    }
  for (int k = 0; k < M; ++k) {
    if (!row[k]) continue;
    for (const auto& yk : y[k].part)
      for (int a = 0; a < yk.m; ++a) {
        const int s = yk.first + a;
        const T ga = yk.g[a];
        T* hs = r.h.data() + s * (s + 1) / 2;
        for (int t = 0; t <= s; ++t) hs[t] += ga * W[k][t];
      }
  }
  return r;
}

// The order of derivatives a scalar type carries: 0 for double, 1 for Dual
// and Grad<N>, 2 for Hess<N>, one more with Dual entries.
template <class S>
struct Order : std::integral_constant<int, 0> {};
template <>
struct Order<Dual> : std::integral_constant<int, 1> {};
template <int N, class T>
struct Order<Grad<N, T>> : std::integral_constant<int, 1 + Order<T>::value> {};
template <int N, class T>
struct Order<Hess<N, T>> : std::integral_constant<int, 2 + Order<T>::value> {};

template <class S>
struct IsHess : std::false_type {};
template <int N, class T>
struct IsHess<Hess<N, T>> : std::true_type {
  using scalar = T;
};

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
