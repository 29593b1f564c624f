// Stability of in-plane equilibria against out-of-plane motion.
//
// A planar scene is solved with two in-plane unknowns per vertex and no
// twist (model/effects.hh). Its equilibrium is also an equilibrium of the
// full 3D model (by the mirror symmetry through the plane), but not
// necessarily a stable one: beyond lateral-torsional buckling it is a saddle
// whose descent directions leave the plane. The check assembles the Hessian
// of the full 3D model (3 coordinates per free vertex, one twist per edge) at
// the in-plane state with zero twist and tests its inertia with a sparse
// LDL^T factorization: stable when no pivot is below -1e-8 of the largest.
#pragma once

#include "model/design.hh"
#include "model/effects.hh"
#include "model/network.hh"
#include "model/scene.hh"

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <vector>

namespace rodmesh {

// For a pose solved with in-plane unknowns: is the equilibrium stable in the
// full 3D model (out-of-plane motion and twist)? False means it is a saddle,
// e.g. beyond lateral-torsional buckling; solve with twist to find the 3D state.
// `positions`: every vertex's position at the in-plane equilibrium.
bool outOfPlaneStable(const Scene& scene, const RodNetwork& network, const EffectSet& planarEffects, int pose,
                      const Design& design, const std::vector<Vec3>& positions);

// A fill-reducing elimination order for a symmetric matrix whose unknowns
// belong to a few groups each (here: the coordinates of a vertex and the
// twists of the edges it starts): approximate minimum degree on the graph of
// the groups, the unknowns of each group kept together in their order.
// `group[i]` (0 <= group[i] < groups) is the group of unknown i; `pattern`
// is the lower or upper triangle (or both) of the matrix. Returns the new
// position of every unknown (a permutation of 0 .. n-1). Ordering a graph of
// vertices instead of one of unknowns costs a fraction of the time and gives
// the same kind of order.
std::vector<int> groupedMinimumDegreeOrder(const Eigen::SparseMatrix<double>& pattern, const std::vector<int>& group,
                                           int groups);

}  // namespace rodmesh
