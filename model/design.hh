// Design: the per-vertex design parameters of a rod mesh, the quantities an
// optimiser may change (docs/formats.md §4).
//
// Vector layout (toVector / fromVector), used by every design derivative:
//   1. rest positions, 3 per vertex, vertex-major [m];
//   2. radii [r_t, r_n], 2 per vertex, vertex-major [m].
// Control points and their interpolation to vertices live in
// model/design_space.hh; this is what they interpolate to.
#pragma once

#include "model/scene.hh"

#include <Eigen/Core>

#include <vector>

namespace rodmesh {

struct Design {
  std::vector<Vec3> restPositions;
  std::vector<Vec2> radii;  // [r_t, r_n] per vertex

  static Design fromScene(const Scene& s) { return Design{s.vertices, s.radii}; }
  int numVertices() const { return static_cast<int>(restPositions.size()); }
  int numParameters() const { return static_cast<int>(5 * restPositions.size()); }
  Eigen::VectorXd toVector() const;
  void fromVector(const Eigen::VectorXd& p);
  static int restIndex(int vertex, int coord) { return 3 * vertex + coord; }
  int radiusIndex(int vertex, int which) const { return static_cast<int>(3 * restPositions.size()) + 2 * vertex + which; }
};

// The scene `rodmesh simulate` reads for design `d` of scene `base` (what
// acceptance re-simulates an optimize archive with): `base` with d's rest
// positions as vertices and d's radii, without its design block. Normals
// the scene does not give are then derived from d's rest shape.
Scene sceneOfDesign(const Scene& base, const Design& d);

}  // namespace rodmesh
