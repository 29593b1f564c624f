// Shared by tests/model/joint_*kernel_test.cc: comparing a kernel's composed
// joint evaluation (evalJoint) with the reference that seeds every local
// variable in one Hess<N> (evalLocal), at random stencils.
#pragma once

#include "model/pose_system_detail.hh"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <pthread.h>
#include <random>
#include <string>

namespace rodmesh::detail::testing_joint {

using ad::Dual;

inline double part(double x, bool) { return x; }
inline double part(const Dual& x, bool derivative) { return derivative ? x.d : x.v; }

// Largest difference between two results relative to the largest entry of the
// reference, with where it is.
template <int N, class T>
testing::AssertionResult sameResult(const ad::Hess<N, T>& ref, const ad::Hess<N, T>& got, double tol) {
  for (int pass = 0; pass < (std::is_same_v<T, Dual> ? 2 : 1); ++pass) {
    const bool der = pass == 1;
    double scaleG = 0.0, scaleH = 0.0;
    for (int i = 0; i < N; ++i) scaleG = std::max(scaleG, std::abs(part(ref.g[i], der)));
    for (int k = 0; k < ad::Hess<N, T>::kNH; ++k) scaleH = std::max(scaleH, std::abs(part(ref.h[k], der)));
    if (scaleG == 0.0 || scaleH == 0.0)
      return testing::AssertionFailure() << "vacuous reference (" << (der ? "direction" : "value") << " part zero)";
    const double ev = std::abs(part(ref.v, der) - part(got.v, der));
    if (ev > tol * (std::abs(part(ref.v, der)) + scaleG))
      return testing::AssertionFailure() << (der ? "D_v " : "") << "value " << part(got.v, der) << " vs "
                                         << part(ref.v, der);
    for (int i = 0; i < N; ++i)
      if (std::abs(part(ref.g[i], der) - part(got.g[i], der)) > tol * scaleG)
        return testing::AssertionFailure() << (der ? "D_v " : "") << "gradient " << i << ": " << part(got.g[i], der)
                                           << " vs " << part(ref.g[i], der);
    for (int i = 0; i < N; ++i)
      for (int j = 0; j <= i; ++j) {
        const int k = ad::Hess<N, T>::hidx(i, j);
        if (std::abs(part(ref.h[k], der) - part(got.h[k], der)) > tol * scaleH)
          return testing::AssertionFailure() << (der ? "D_v " : "") << "Hessian (" << i << ", " << j
                                             << "): " << part(got.h[k], der) << " vs " << part(ref.h[k], der);
      }
  }
  return testing::AssertionSuccess();
}

inline constexpr double kTol = 1e-11;

// The reference over all of a large connection's locals needs far more stack
// than a default thread has (about 2 MB for a six-valent one with a
// direction); the composed evaluation (evalJoint) runs on any thread's stack
// (tests/model/stack_use_test.cc).
inline void onLargeStack(const std::function<void()>& fn) {
  pthread_attr_t attr;
  pthread_attr_init(&attr);
  pthread_attr_setstacksize(&attr, std::size_t(1) << 30);
  pthread_t thread;
  auto trampoline = [](void* arg) -> void* {
    (*static_cast<const std::function<void()>*>(arg))();
    return nullptr;
  };
  ASSERT_EQ(pthread_create(&thread, &attr, trampoline, const_cast<std::function<void()>*>(&fn)), 0);
  pthread_join(thread, nullptr);
  pthread_attr_destroy(&attr);
}

struct Rng {
  std::mt19937 gen;
  std::uniform_real_distribution<double> u{-1.0, 1.0};
  explicit Rng(unsigned seed) : gen(seed) {}
  double operator()() { return u(gen); }
  Vec3 vec() { return Vec3((*this)(), (*this)(), (*this)()); }
};

// The plane z = 0 for planar layouts.
inline Mat32 planeBasis() {
  Mat32 B = Mat32::Zero();
  B(0, 0) = 1.0;
  B(1, 1) = 1.0;
  return B;
}

// A rest edge of about 1 cm in direction angle a (in the plane for D = 2,
// lifted out of it for D = 3), its current version perturbed, chart (rest
// tangent and a director perpendicular to it) and reference normal.
struct EdgeSample {
  Vec3 rest, current, chartT, chartD, normal;
};
inline EdgeSample sampleEdge(Rng& rng, double angle, int D) {
  EdgeSample s;
  const Vec3 dir(std::cos(angle), std::sin(angle), D == 3 ? 0.3 * rng() : 0.0);
  s.rest = 0.01 * dir + 0.002 * Vec3(rng(), rng(), D == 3 ? rng() : 0.0);
  s.current = s.rest + 0.003 * Vec3(rng(), rng(), D == 3 ? rng() : 0.0);
  s.chartT = s.rest.normalized();
  s.chartD = s.chartT.cross(Vec3::UnitZ()).normalized();
  s.normal = (Vec3::UnitZ() + (D == 3 ? 0.2 : 0.0) * Vec3(rng(), rng(), 0.0)).normalized();
  return s;
}

// Sets the local x variables of an edge vector: e itself (D = 3) or its
// in-plane coordinates (D = 2, offset zero: the edge lies in the plane).
inline void putEdge(LocalStencil& ls, const Vec3& e, int D) {
  for (int i = 0; i < D; ++i) ls.xv[ls.nx++] = e[i];
}

template <class T, int N, class Kern>
void expectSame(const Kern& kern, const LocalStencil& ls, Rng& rng, const std::string& what) {
  double dir[kMaxLocal] = {};
  for (int i = 0; i < ls.nx; ++i) dir[i] = rng();
  const double* d = std::is_same_v<T, Dual> ? dir : nullptr;
  const ad::Hess<N, T> ref = evalLocal<N, T, true>(kern, ls, d);
  const ad::Hess<N, T> got = evalJoint<N, T>(kern, ls, d);
  EXPECT_TRUE(sameResult(ref, got, kTol)) << what << (std::is_same_v<T, Dual> ? " (with direction)" : "");
}

}  // namespace rodmesh::detail::testing_joint
