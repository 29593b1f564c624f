#include "model/design.hh"

namespace rodmesh {

Eigen::VectorXd Design::toVector() const {
  const int n = numVertices();
  Eigen::VectorXd p(5 * n);
  for (int v = 0; v < n; ++v) {
    p.segment<3>(3 * v) = restPositions[v];
    p.segment<2>(3 * n + 2 * v) = radii[v];
  }
  return p;
}

void Design::fromVector(const Eigen::VectorXd& p) {
  const int n = static_cast<int>(p.size() / 5);
  restPositions.resize(n);
  radii.resize(n);
  for (int v = 0; v < n; ++v) {
    restPositions[v] = p.segment<3>(3 * v);
    radii[v] = p.segment<2>(3 * n + 2 * v);
  }
}

Scene sceneOfDesign(const Scene& base, const Design& d) {
  Scene s = base;
  s.vertices = d.restPositions;
  s.radii = d.radii;
  s.design = DesignSpec{};
  return s;
}

}  // namespace rodmesh
