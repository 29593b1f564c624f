// Simulation energy, gradient and Hessian (PoseSystem::runSim), explicitly
// instantiated for the 3D layouts (see model/pose_system_impl.hh).
#include "model/pose_system_impl.hh"

RODMESH_INSTANTIATE_SIM(3, true)
RODMESH_INSTANTIATE_SIM(3, false)
