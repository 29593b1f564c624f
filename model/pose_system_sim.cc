// Simulation energy, gradient and Hessian (PoseSystem::runSim),
// explicitly instantiated for every unknowns layout (see
// model/pose_system_impl.hh).
#include "model/pose_system_impl.hh"

RODMESH_INSTANTIATE_SIM(3, true)
RODMESH_INSTANTIATE_SIM(3, false)
RODMESH_INSTANTIATE_SIM(2, true)
RODMESH_INSTANTIATE_SIM(2, false)
