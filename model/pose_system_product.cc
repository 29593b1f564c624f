// First-order design product (dF/dp)^T lambda (PoseSystem::runProduct),
// explicitly instantiated for every unknowns layout (see
// model/pose_system_impl.hh).
#include "model/pose_system_impl.hh"

RODMESH_INSTANTIATE_PRODUCT(3, true)
RODMESH_INSTANTIATE_PRODUCT(3, false)
RODMESH_INSTANTIATE_PRODUCT(2, true)
RODMESH_INSTANTIATE_PRODUCT(2, false)
