// Joint derivative values (PoseSystem::runJoint over double), explicitly
// instantiated for the 3D layouts (see model/pose_system_impl.hh).
#include "model/pose_system_impl.hh"

RODMESH_INSTANTIATE_JOINT(3, true, double)
RODMESH_INSTANTIATE_JOINT(3, false, double)
