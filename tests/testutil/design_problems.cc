#include "tests/testutil/design_problems.hh"

#include <cmath>
#include <string>

namespace rodmesh::testutil {

Scene designNetwork(bool planar) {
  Scene s;
  s.sourcePath = "<design-network>";
  s.material = Material{2e7, 0.45, 1100.0};
  s.vertices.push_back(Vec3(0, 0, 0));
  const double angles[3] = {0.1, 2.2, 4.1};
  for (int r = 0; r < 3; ++r) {
    const Vec3 dir(std::cos(angles[r]), std::sin(angles[r]), 0.0);
    const Vec3 side(-dir.y(), dir.x(), 0.0);
    const int first = static_cast<int>(s.vertices.size());
    for (int i = 1; i <= 4; ++i)
      s.vertices.push_back(0.01 * i * dir + 0.0008 * i * i * side + Vec3(0, 0, planar ? 0.0 : 0.0008 * i * i));
    s.rods.push_back(Rod{{0, first, first + 1, first + 2, first + 3}, std::nullopt});
  }
  s.rods[0].vertices = {0, 1, 2};
  s.rods.push_back(Rod{{2, 3, 4}, std::nullopt});
  for (std::size_t v = 0; v < s.vertices.size(); ++v)
    s.radii.push_back(Vec2(0.0012 + 0.0001 * (v % 4), 0.0009 + 0.0001 * (v % 3)));
  s.gravity = planar ? Vec3(0.0, -9.81, 0.0) : Vec3(0.5, -2.0, -9.81);
  for (int k = 0; k < 2; ++k) {
    Pose p;
    p.name = "p" + std::to_string(k);
    p.weight = 1.0 + k;
    p.clamped.push_back({8});
    p.fixed.push_back({12, std::nullopt});
    if (k == 1) p.fixed.push_back({4, s.vertices[4] + Vec3(0.002, 0.001, 0.0)});
    p.forces.push_back({3, planar ? Vec3(0.002, -0.004 * (k + 1), 0.0) : Vec3(0.002, -0.004, 0.006 * (k + 1))});
    for (std::size_t v = 0; v < s.vertices.size(); ++v)
      p.target.push_back(s.vertices[v] + Vec3(0.001 * std::sin(3.0 * v + k), 0.001 * std::cos(2.0 * v),
                                              planar ? 0.0 : -0.002));
    s.poses.push_back(p);
  }
  s.design.present = true;
  s.design.radii = s.design.restShape = true;
  s.design.radiusMin = 0.0005;
  s.design.radiusMax = 0.003;
  s.design.hasRadiusBounds = true;
  s.design.controlPointsPerRod = 4;
  return s;
}

}  // namespace rodmesh::testutil
