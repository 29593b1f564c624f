#include "tests/testutil/scenes.hh"

namespace rodmesh::testutil {

Scene straightRod(int edges, double length, double rt, double rn) {
  Scene s;
  s.sourcePath = "<test>";
  s.material = Material{1e7, 0.4, 1000.0};
  Rod rod;
  for (int i = 0; i <= edges; ++i) {
    s.vertices.push_back(Vec3(length * i / edges, 0.0, 0.0));
    rod.vertices.push_back(i);
  }
  s.rods.push_back(rod);
  s.radii.assign(s.vertices.size(), Vec2(rt, rn));
  Pose p;
  p.name = "pose0";
  s.poses.push_back(p);
  return s;
}

}  // namespace rodmesh::testutil
