// The connection kernel's composed joint evaluation against the reference
// (see joint_connection_kernel_test.cc) for the six-valent connection in 3D
// with twist, values and directional derivatives: its own translation unit,
// the reference over 56 locals being the largest instantiation of the tests.
#include "tests/testutil/joint_kernels.hh"

namespace rodmesh::detail {
namespace {

using namespace testing_joint;
using ad::Dual;

TEST(JointKernels, ConnectionsMatchReference3DSixValent) {
  onLargeStack([] {
    for (unsigned seed : {4u, 5u}) checkConnection<3, true, 6>(seed);
  });
}

}  // namespace
}  // namespace rodmesh::detail
