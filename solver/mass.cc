#include "solver/mass.hh"

#include "model/stiffness.hh"

namespace rodmesh {

std::vector<double> lumpedVertexMasses(const RodNetwork& network, const Design& design, double density) {
  std::vector<double> m(network.numVertices(), 0.0);
  for (const Edge& e : network.edges()) {
    const double len = (design.restPositions[e.b] - design.restPositions[e.a]).norm();
    const Vec2& ra = design.radii[e.a];
    const Vec2& rb = design.radii[e.b];
    const double me = stiffness::edgeMass(density, len, ra[0], ra[1], rb[0], rb[1]);
    m[e.a] += 0.5 * me;
    m[e.b] += 0.5 * me;
  }
  return m;
}

Eigen::VectorXd dofMasses(const PoseSystem& system, const std::vector<double>& vertexMasses) {
  Eigen::VectorXd m = Eigen::VectorXd::Zero(system.numDofs());
  const std::vector<int>& first = system.vertexDof();
  const int D = system.dofsPerVertex();
  for (std::size_t v = 0; v < first.size(); ++v)
    if (first[v] >= 0) m.segment(first[v], D).setConstant(vertexMasses[v]);
  return m;
}

}  // namespace rodmesh
