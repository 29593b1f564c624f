// The connection kernel's composed joint evaluation against the reference
// (see joint_connection_kernel_test.cc) for the planar layouts, with and
// without twist.
#include "tests/testutil/joint_kernels.hh"

namespace rodmesh::detail {
namespace {

using namespace testing_joint;
using ad::Dual;

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
