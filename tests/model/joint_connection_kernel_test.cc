// The connection kernel's composed joint evaluation (evalJoint: the fit from
// products of edge states and rest factors, the rotation over the fit's
// entries, each edge's energy over the connection edge's frame) against the
// reference that seeds every local variable in one Hess<N> (evalLocal):
// values, gradients and Hessians for every valence (2 to 6) and unknowns
// layout, and their directional derivatives (T = Dual) for valences 2, 3 and
// 6 in 3D with twist and for the other layouts at valence 3 (the directional
// reference over all of a six-valent connection's 56 locals is by far the
// largest thing these tests compile). Split in three translation units of
// similar compile time: 3D (this file), the six-valent 3D connection
// (joint_connection_kernel_six_test.cc) and the planar layouts
// (joint_connection_kernel_planar_test.cc); checkConnection is in
// tests/testutil/joint_kernels.hh.
#include "tests/testutil/joint_kernels.hh"

namespace rodmesh::detail {
namespace {

using namespace testing_joint;
using ad::Dual;

TEST(JointKernels, ConnectionsMatchReference3D) {
  onLargeStack([] {
    for (unsigned seed : {4u, 5u}) {
      checkConnection<3, true, 2>(seed);
      checkConnection<3, true, 3>(seed);
      checkConnection<3, true, 4, false>(seed);
      checkConnection<3, true, 5, false>(seed);
      checkConnection<3, false, 3>(seed);
      checkConnection<3, false, 5, false>(seed);
    }
  });
}

}  // namespace
}  // namespace rodmesh::detail
