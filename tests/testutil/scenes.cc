#include "tests/testutil/scenes.hh"

#include <cmath>

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

Scene cantilever(int edges, double length, double rt, double rn, const Vec3& normal) {
  Scene s = straightRod(edges, length, rt, rn);
  s.normals.assign(s.vertices.size(), normal.normalized());
  s.poses[0].clamped.push_back(ClampedVertex{0});
  return s;
}

Scene clampedArc(int edges, double radius, double angle, double rt, double rn) {
  Scene s;
  s.sourcePath = "<test>";
  s.material = Material{1e7, 0.4, 1000.0};
  Rod rod;
  for (int i = 0; i <= edges; ++i) {
    const double a = angle * i / edges;
    s.vertices.push_back(Vec3(radius * std::cos(a), radius * std::sin(a), 0.0));
    rod.vertices.push_back(i);
  }
  s.rods.push_back(rod);
  s.radii.assign(s.vertices.size(), Vec2(rt, rn));
  s.normals.assign(s.vertices.size(), Vec3::UnitZ());
  Pose p;
  p.name = "pose0";
  p.clamped.push_back(ClampedVertex{0});
  s.poses.push_back(p);
  return s;
}

int tipVertex(const Scene& s) { return s.rods.front().vertices.back(); }

}  // namespace rodmesh::testutil
