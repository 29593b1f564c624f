// Joint derivative values (PoseSystem::runJoint over double),
// explicitly instantiated for every unknowns layout (see
// model/pose_system_impl.hh).
#include "model/pose_system_impl.hh"

RODMESH_INSTANTIATE_JOINT(3, true, double)
RODMESH_INSTANTIATE_JOINT(3, false, double)
RODMESH_INSTANTIATE_JOINT(2, true, double)
RODMESH_INSTANTIATE_JOINT(2, false, double)
