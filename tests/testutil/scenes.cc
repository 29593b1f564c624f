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

Scene cantileverOverHeldRod(int edges, double length, double r, double drop) {
  Scene s = cantilever(edges, length, r, r, Vec3(0, 0, 1));
  const int below = static_cast<int>(s.vertices.size());
  s.vertices.push_back(Vec3(length, 0.0, -drop));
  s.vertices.push_back(Vec3(length + 0.01, 0.0, -drop));
  for (int i = 0; i < 2; ++i) {
    s.normals.push_back(Vec3(0, 0, 1));
    s.radii.push_back(s.radii.front());
  }
  Rod rod;
  rod.vertices = {below, below + 1};
  s.rods.push_back(rod);
  s.poses.at(0).fixed.push_back({below, std::nullopt});
  s.poses.at(0).fixed.push_back({below + 1, std::nullopt});
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

Scene starNetwork(const StarNetworkOptions& o) {
  Scene s;
  s.sourcePath = "<star network>";
  s.material = Material{2e7, 0.45, 1100.0};
  s.vertices.push_back(Vec3(0, 0, 0));
  const double angles[3] = {0.1, 2.2, 4.1};
  for (int r = 0; r < 3; ++r) {
    const Vec3 dir(std::cos(angles[r]), std::sin(angles[r]), 0.0);
    const Vec3 side(-dir.y(), dir.x(), 0.0);
    Rod rod{{0}, std::nullopt};
    for (int i = 1; i <= o.verticesPerArm; ++i) {
      rod.vertices.push_back(static_cast<int>(s.vertices.size()));
      s.vertices.push_back(0.01 * i * dir + 0.0008 * i * i * side + Vec3(0, 0, o.lift * i * i));
    }
    s.rods.push_back(rod);
  }
  // Split the first arm at its vertex 2.
  Rod tail{{}, std::nullopt};
  tail.vertices.assign(s.rods[0].vertices.begin() + 2, s.rods[0].vertices.end());
  s.rods[0].vertices.resize(3);
  s.rods.push_back(tail);
  for (std::size_t v = 0; v < s.vertices.size(); ++v)
    s.radii.push_back(Vec2(o.radiusBase.x() + o.radiusStep.x() * static_cast<double>(v % 4),
                           o.radiusBase.y() + o.radiusStep.y() * static_cast<double>(v % 3)));
  s.gravity = o.lift == 0.0 ? Vec3(0.0, -9.81, 0.0) : Vec3(0.5, -2.0, -9.81);
  return s;
}

int tipVertex(const Scene& s) { return s.rods.front().vertices.back(); }

Scene connectionStar(const std::vector<Vec3>& directions, const std::vector<double>& radiusScale, bool gravity) {
  Scene s;
  s.sourcePath = "<connection star>";
  s.material = Material{2e7, 0.45, 1100.0};
  if (gravity) s.gravity = Vec3(0.5, -2.0, -9.81);
  s.vertices.push_back(Vec3(0, 0, 0));
  s.radii.push_back(Vec2(0.001, 0.0007));
  Pose p;
  p.name = "p";
  for (std::size_t r = 0; r < directions.size(); ++r) {
    const Vec3& dir = directions[r];
    const Vec3 side(-dir.y(), dir.x(), 0.0);
    const int a = static_cast<int>(s.vertices.size());
    s.vertices.push_back(0.01 * dir + 0.0003 * side);
    s.vertices.push_back(0.02 * dir + 0.001 * side + Vec3(0, 0, 0.0005));
    const double scale = r < radiusScale.size() ? radiusScale[r] : 1.0;
    s.radii.push_back(scale * Vec2(0.001, 0.0007));
    s.radii.push_back(scale * Vec2(0.001, 0.0007));
    s.rods.push_back(Rod{{0, a, a + 1}, std::nullopt});
    p.fixed.push_back({a + 1, std::nullopt});
  }
  s.normals.assign(s.vertices.size(), Vec3(0, 0, 1));
  s.effects = std::vector<Effect>{Effect::Stretch, Effect::Bend, Effect::Twist, Effect::Connections};
  if (gravity) s.effects->push_back(Effect::Gravity);
  s.poses.push_back(p);
  return s;
}

}  // namespace rodmesh::testutil
