// The one-pass sums of products (ad::productSum, ad::productDifference, and
// through them dot and cross on Hessian-carrying vectors) against the same
// expressions built from the separate operators: values, gradients and
// Hessians, with T = double and with T = Dual (the directional third-order
// evaluations). The two differ only in rounding.
#include "model/energies/rod_math.hh"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace rodmesh {
namespace {

using ad::Dual;
using ad::Hess;

double val(double x) { return x; }
double der(double) { return 0.0; }
double val(Dual x) { return x.v; }
double der(Dual x) { return x.d; }

template <class T>
T draw(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  if constexpr (std::is_same_v<T, Dual>)
    return Dual(u(rng), u(rng));
  else
    return u(rng);
}

template <int N, class T>
Hess<N, T> randomHess(std::mt19937& rng) {
  Hess<N, T> h;
  h.v = draw<T>(rng);
  for (auto& g : h.g) g = draw<T>(rng);
  for (auto& e : h.h) e = draw<T>(rng);
  return h;
}

template <int N, class T>
void expectClose(const Hess<N, T>& a, const Hess<N, T>& b, const char* what) {
  constexpr double kTol = 1e-13;  // entries are O(10): a few ulps of the sums
  auto close = [](T x, T y) { return std::abs(val(x) - val(y)) <= kTol && std::abs(der(x) - der(y)) <= kTol; };
  EXPECT_TRUE(close(a.v, b.v)) << what << " value";
  for (int i = 0; i < N; ++i) EXPECT_TRUE(close(a.g[i], b.g[i])) << what << " gradient " << i;
  for (int k = 0; k < Hess<N, T>::kNH; ++k) EXPECT_TRUE(close(a.h[k], b.h[k])) << what << " Hessian entry " << k;
}

template <int N, class T>
void checkProducts(unsigned seed) {
  std::mt19937 rng(seed);
  for (int trial = 0; trial < 20; ++trial) {
    V3<Hess<N, T>> a, b;
    for (int c = 0; c < 3; ++c) {
      a[c] = randomHess<N, T>(rng);
      b[c] = randomHess<N, T>(rng);
    }
    const Hess<N, T> d = a.x * b.x + a.y * b.y + a.z * b.z;
    expectClose(dot(a, b), d, "dot");
    const V3<Hess<N, T>> c = cross(a, b);
    expectClose(c.x, a.y * b.z - a.z * b.y, "cross x");
    expectClose(c.y, a.z * b.x - a.x * b.z, "cross y");
    expectClose(c.z, a.x * b.y - a.y * b.x, "cross z");
  }
}

TEST(AdProducts, OnePassDotAndCrossMatchTheSeparateOperators) {
  checkProducts<1, double>(1);
  checkProducts<5, double>(2);
  checkProducts<8, double>(3);
  checkProducts<3, Dual>(4);
  checkProducts<8, Dual>(5);
}

// The overloads are the ones chosen for Hess vectors: a mixed-up term (say,
// a sign or an index pair swapped) would make the cross product of a vector
// with itself nonzero or break anticommutativity.
TEST(AdProducts, CrossOfHessVectorsIsAnticommutative) {
  std::mt19937 rng(7);
  V3<Hess<6, double>> a, b;
  for (int c = 0; c < 3; ++c) {
    a[c] = randomHess<6, double>(rng);
    b[c] = randomHess<6, double>(rng);
  }
  const V3<Hess<6, double>> ab = cross(a, b), ba = cross(b, a), aa = cross(a, a);
  for (int c = 0; c < 3; ++c) {
    expectClose(ab[c], -ba[c], "a x b = -(b x a)");
    expectClose(aa[c], Hess<6, double>(0.0), "a x a = 0");
  }
}

}  // namespace
}  // namespace rodmesh
