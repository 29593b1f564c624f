// Third-order directional joint derivatives (PoseSystem::runJoint over Dual),
// explicitly instantiated for the planar layouts (see
// model/pose_system_impl.hh).
#include "model/pose_system_impl.hh"

RODMESH_INSTANTIATE_JOINT(2, true, rodmesh::ad::Dual)
RODMESH_INSTANTIATE_JOINT(2, false, rodmesh::ad::Dual)
