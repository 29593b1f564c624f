// The joint (u, p) kernel evaluations that differentiate pieces separately and
// compose them (evalJoint for stretch, gravity and bend-twist, and the
// composed polar rotation) against the reference: the same kernel with every
// local variable seeded in one Hess<N> (evalLocal). Values, gradients and
// Hessians, and with a direction (T = Dual) their directional derivatives, at
// random bent and twisted stencils, for every unknowns layout (3D / planar,
// with and without twist). Connections: joint_connection_kernel_test.cc.
#include "tests/testutil/joint_kernels.hh"

#include <Eigen/Geometry>

namespace rodmesh::detail {
namespace {

using namespace testing_joint;
using ad::Dual;

template <int D, bool TW>
void checkStretchAndGravity(unsigned seed) {
  Rng rng(seed);
  const Mat32 B = planeBasis();
  const EdgeSample e = sampleEdge(rng, 0.4, D);
  auto radii = [&](LocalStencil& ls) {
    for (int v = 0; v < 2; ++v) {
      ls.pv[ls.np++] = 0.0012 * (1.0 + 0.3 * rng());
      ls.pv[ls.np++] = 0.0008 * (1.0 + 0.3 * rng());
    }
  };
  const std::string layout = " D=" + std::to_string(D) + (TW ? " twist" : "");
  {
    StretchK<D, TW> kern{{2e7}, Vec3::Zero(), &B};
    LocalStencil ls;
    putEdge(ls, e.current, D);
    for (int i = 0; i < 3; ++i) ls.pv[ls.np++] = e.rest[i];
    radii(ls);
    constexpr int N = KernelSize<StretchK<D, TW>>::nx + KernelSize<StretchK<D, TW>>::np;
    ASSERT_EQ(ls.nx + ls.np, N);
    expectSame<double, N>(kern, ls, rng, "stretch" + layout);
    expectSame<Dual, N>(kern, ls, rng, "stretch" + layout);
  }
  {
    GravityK<D, TW> kern;
    kern.k.g = D == 3 ? Vec3(0.5, -2.0, -9.81) : Vec3(0.3, -9.81, 0.0);
    kern.k.density = 1100.0;
    kern.offA = kern.offB = Vec3::Zero();
    kern.B = &B;
    LocalStencil ls;
    const Vec3 xa(0.02 * rng(), 0.02 * rng(), D == 3 ? 0.02 * rng() : 0.0);
    putEdge(ls, xa, D);
    putEdge(ls, xa + e.current, D);
    for (int i = 0; i < 3; ++i) ls.pv[ls.np++] = e.rest[i];
    radii(ls);
    constexpr int N = KernelSize<GravityK<D, TW>>::nx + KernelSize<GravityK<D, TW>>::np;
    ASSERT_EQ(ls.nx + ls.np, N);
    expectSame<double, N>(kern, ls, rng, "gravity" + layout);
    expectSame<Dual, N>(kern, ls, rng, "gravity" + layout);
  }
}

template <int D, bool TW>
void checkBend(unsigned seed) {
  Rng rng(seed);
  const Mat32 B = planeBasis();
  BendK<D, TW> kern;
  const EdgeSample e0 = sampleEdge(rng, 0.2, D), e1 = sampleEdge(rng, 0.2 + 0.5 * rng(), D);
  kern.k.n0 = e0.normal;
  kern.k.n1 = e1.normal;
  kern.k.chartT0 = e0.chartT;
  kern.k.chartD0 = e0.chartD;
  kern.k.chartT1 = e1.chartT;
  kern.k.chartD1 = e1.chartD;
  kern.k.youngModulus = 2e7;
  kern.k.shearModulus = 7e6;
  kern.k.bend = true;
  kern.k.twist = TW;
  kern.B = &B;
  kern.off0 = kern.off1 = Vec3::Zero();
  LocalStencil ls;
  putEdge(ls, e0.current, D);
  putEdge(ls, e1.current, D);
  if (TW) {
    ls.xv[ls.nx++] = 0.5 * rng();
    ls.xv[ls.nx++] = 0.5 * rng();
  }
  for (const Vec3& E : {e0.rest, e1.rest})
    for (int i = 0; i < 3; ++i) ls.pv[ls.np++] = E[i];
  ls.pv[ls.np++] = 0.0012 * (1.0 + 0.3 * rng());
  ls.pv[ls.np++] = 0.0008 * (1.0 + 0.3 * rng());
  constexpr int N = KernelSize<BendK<D, TW>>::nx + KernelSize<BendK<D, TW>>::np;
  ASSERT_EQ(ls.nx + ls.np, N);
  const std::string what = "bend-twist D=" + std::to_string(D) + (TW ? " twist" : "");
  expectSame<double, N>(kern, ls, rng, what);
  expectSame<Dual, N>(kern, ls, rng, what);
}

TEST(JointKernels, StretchAndGravityMatchReference) {
  for (unsigned seed : {9u, 10u}) {
    checkStretchAndGravity<3, true>(seed);
    checkStretchAndGravity<3, false>(seed);
    checkStretchAndGravity<2, true>(seed);
    checkStretchAndGravity<2, false>(seed);
  }
}

TEST(JointKernels, BendTwistMatchesReference) {
  for (unsigned seed : {1u, 2u, 3u}) {
    checkBend<3, true>(seed);
    checkBend<3, false>(seed);
    checkBend<2, true>(seed);
    checkBend<2, false>(seed);
  }
}

// The composed polar rotation against the one differentiated through every
// operation, on its own (a random near-rotation A over 12 variables).
TEST(JointKernels, ComposedPolarRotationMatchesDirect) {
  constexpr int N = 20;  // above kPolarComposeMin: composed
  static_assert(N > energies::kPolarComposeMin);
  using H = ad::Hess<N, Dual>;
  Rng rng(8);
  H x[N];
  for (int i = 0; i < N; ++i) x[i] = H::variable(Dual(0.3 * rng(), rng()), i);
  const Eigen::Matrix3d R0 = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  energies::M3<H> A;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      // A nonlinear function of every variable near R0 (scaled).
      H s = H(1.3 * R0(i, j));
      for (int k = 0; k < N; ++k) s = s + (0.05 * rng()) * x[k] * x[(k + 3 * i + j) % N];
      A.a[i][j] = s;
    }
  const energies::M3<H> direct = energies::polarRotationDirect(A);
  const energies::M3<H> composed = energies::polarRotationAD(A);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      EXPECT_TRUE(sameResult(direct.a[i][j], composed.a[i][j], kTol)) << "R(" << i << ", " << j << ")";
}

}  // namespace
}  // namespace rodmesh::detail
