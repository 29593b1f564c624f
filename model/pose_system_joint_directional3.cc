// Third-order directional joint derivatives (PoseSystem::runJoint over Dual),
// explicitly instantiated for the 3D layouts (see model/pose_system_impl.hh).
#include "model/pose_system_impl.hh"

RODMESH_INSTANTIATE_JOINT(3, true, rodmesh::ad::Dual)
RODMESH_INSTANTIATE_JOINT(3, false, rodmesh::ad::Dual)
