// Lumped masses of a rod network, shared by the dynamic integrator
// (solver/dynamics.hh) and the reports of the relaxation solver.
//
// Each edge e = (a, b) carries the mass of its rest length with the mean
// cross-section of its two end vertices,
//   m_e = rho pi |X_b - X_a| (r_tA r_nA + r_tB r_nB) / 2     [kg],
// lumped half to each endpoint; a vertex's mass is the sum over its incident
// edges. This is exactly the lumping of the gravity term
// (model/energies/gravity.hh), so that an unsupported vertex under gravity
// alone accelerates at g. With uniform radii it is rho pi r_t r_n times half
// the rest length of every incident edge.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "model/network.hh"
#include "model/pose_system.hh"

namespace rodmesh {

// Mass of every vertex [kg] for the design's rest positions and radii.
std::vector<double> lumpedVertexMasses(const RodNetwork& network, const Design& design, double density);

// Mass per unknown of a pose [kg]: each free vertex's mass on each of its
// position unknowns (3, or 2 in a planar scene); zero on twist unknowns
// (massless: the material frames are quasi-static, Bergou et al. 2010).
Eigen::VectorXd dofMasses(const PoseSystem& system, const std::vector<double>& vertexMasses);

}  // namespace rodmesh
