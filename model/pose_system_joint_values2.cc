// Joint derivative values (PoseSystem::runJoint over double), explicitly
// instantiated for the planar layouts (see model/pose_system_impl.hh).
#include "model/pose_system_impl.hh"

RODMESH_INSTANTIATE_JOINT(2, true, double)
RODMESH_INSTANTIATE_JOINT(2, false, double)
