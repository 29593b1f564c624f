// The connection kernel's composed joint evaluation (evalJoint: the fit from
// products of edge states and rest factors, the rotation over the fit's
// entries, each edge's energy over the connection edge's frame) against the
// reference that seeds every local variable in one Hess<N> (evalLocal):
// values, gradients and Hessians for every valence (2 to 6) and unknowns
// layout, and their directional derivatives (T = Dual) for valences 2, 3 and
// 6 in 3D with twist and for the other layouts at valence 3 (the directional
// reference over all of a six-valent connection's 56 locals is by far the
// largest thing this test compiles).
#include "tests/testutil/joint_kernels.hh"

namespace rodmesh::detail {
namespace {

using namespace testing_joint;
using ad::Dual;

// withDirection: also the directional (T = Dual) evaluation.
template <int D, bool TW, int K, bool withDirection = true>
void checkConnection(unsigned seed) {
  Rng rng(seed);
  const Mat32 B = planeBasis();
  ConnectionK<D, TW, K> kern;
  kern.k.youngModulus = 2e7;
  kern.k.shearModulus = 7e6;
  kern.k.bend = true;
  kern.k.twist = TW;
  kern.B = &B;
  LocalStencil ls;
  EdgeSample e[K];
  for (int i = 0; i < K; ++i) {
    e[i] = sampleEdge(rng, 2.0 * 3.14159265358979 * i / K + 0.2 * rng(), D);
    kern.k.n[i] = e[i].normal;
    kern.k.chartT[i] = e[i].chartT;
    kern.k.chartD[i] = e[i].chartD;
    kern.off[i] = Vec3::Zero();
    putEdge(ls, e[i].current, D);
  }
  if (TW)
    for (int i = 0; i < K; ++i) ls.xv[ls.nx++] = 0.4 * rng();
  for (int i = 0; i < K; ++i)
    for (int c = 0; c < 3; ++c) ls.pv[ls.np++] = e[i].rest[c];
  for (int v = 0; v <= K; ++v) {
    ls.pv[ls.np++] = 0.0012 * (1.0 + 0.3 * rng());
    ls.pv[ls.np++] = 0.0008 * (1.0 + 0.3 * rng());
  }
  constexpr int N = KernelSize<ConnectionK<D, TW, K>>::nx + KernelSize<ConnectionK<D, TW, K>>::np;
  ASSERT_EQ(ls.nx + ls.np, N);
  const std::string what = "connection K=" + std::to_string(K) + " D=" + std::to_string(D) + (TW ? " twist" : "");
  expectSame<double, N>(kern, ls, rng, what);
  if constexpr (withDirection) expectSame<Dual, N>(kern, ls, rng, what);
}

TEST(JointKernels, ConnectionsMatchReference3D) {
  onLargeStack([] {
    for (unsigned seed : {4u, 5u}) {
      checkConnection<3, true, 2>(seed);
      checkConnection<3, true, 3>(seed);
      checkConnection<3, true, 4, false>(seed);
      checkConnection<3, true, 5, false>(seed);
      checkConnection<3, true, 6>(seed);
      checkConnection<3, false, 3>(seed);
      checkConnection<3, false, 5, false>(seed);
    }
  });
}

TEST(JointKernels, ConnectionsMatchReferencePlanar) {
  onLargeStack([] {
    for (unsigned seed : {6u, 7u}) {
      checkConnection<2, false, 2, false>(seed);
      checkConnection<2, false, 3>(seed);
      checkConnection<2, false, 4, false>(seed);
      checkConnection<2, true, 3>(seed);
      checkConnection<2, true, 6, false>(seed);
    }
  });
}

}  // namespace
}  // namespace rodmesh::detail
