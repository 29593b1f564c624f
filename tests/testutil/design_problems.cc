#include "tests/testutil/design_problems.hh"

#include "solver/equilibrium.hh"
#include "tests/testutil/scenes.hh"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace rodmesh::testutil {

Scene designNetwork(bool planar) {
  testutil::StarNetworkOptions o;
  o.verticesPerArm = 4;
  o.lift = planar ? 0.0 : 0.0008;
  o.radiusBase = Vec2(0.0012, 0.0009);
  o.radiusStep = Vec2(0.0001, 0.0001);
  Scene s = testutil::starNetwork(o);
  s.sourcePath = "<design-network>";
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

void setScaledRadiiTargets(Scene& s, double radiusScale) {
  Scene h = s;
  for (Vec2& r : h.radii) r *= radiusScale;
  SceneModel hm(h);
  const SimulationResult sim = simulateAll(hm, Design::fromScene(h), NewtonOptions{});
  EXPECT_TRUE(sim.allConverged) << "targets: the design with radii scaled by " << radiusScale;
  for (std::size_t p = 0; p < s.poses.size(); ++p) s.poses[p].target = sim.poses[p].positions;
}

void freeRadii(Scene& s) {
  s.design.present = true;
  s.design.radii = true;
  s.design.hasRadiusBounds = true;
  s.design.radiusMin = 0.0005;
  s.design.radiusMax = 0.002;
  s.design.controlPointsPerRod = 4;
}

Scene bentCantilever(double force) {
  Scene s = cantilever(20, 0.2, 0.001, 0.001, Vec3::UnitZ());
  s.sourcePath = "<bent cantilever>";
  s.poses[0].name = "bend";
  s.poses[0].forces.push_back({tipVertex(s), Vec3(0.0, force, 0.0)});
  freeRadii(s);
  return s;
}

Scene fallbackCase() {
  Scene s = bentCantilever(2e-3);
  setScaledRadiiTargets(s, 0.6);
  return s;
}

NewtonOptions fallbackCaseNewton() {
  NewtonOptions o;
  o.maxIterations = 6;
  return o;
}

Scene invertibleArch() {
  const int n = 41;
  const double span = 1.0, rise = 0.05, R = (span * span / 4 + rise * rise) / (2 * rise);
  const double half = std::asin(span / 2 / R);
  Scene s;
  s.sourcePath = "<arch>";
  s.material = Material{1e8, 0.4, 500.0};
  Rod rod;
  for (int i = 0; i < n; ++i) {
    const double a = -half + 2 * half * i / (n - 1);
    s.vertices.push_back(Vec3(R * std::sin(a), 0, R * std::cos(a) - (R - rise)));
    rod.vertices.push_back(i);
  }
  s.rods.push_back(rod);
  s.radii.assign(n, Vec2(0.005, 0.005));
  s.effects = std::vector<Effect>{Effect::Stretch, Effect::Bend};
  Pose p;
  p.name = "crown";
  p.fixed = {{0, std::nullopt}, {n - 1, std::nullopt}};
  p.forces.push_back({n / 2, Vec3(0, 0, -0.2)});
  s.poses.push_back(p);
  s.design.present = s.design.radii = true;
  s.design.hasRadiusBounds = true;
  s.design.radiusMin = 0.004;
  s.design.radiusMax = 0.006;
  return s;
}

PoseState invertedArchState(const Scene& s, const PoseSystem& sys, const Design& d) {
  std::vector<Vec3> mirrored = s.vertices;
  for (Vec3& x : mirrored) x.z() = -x.z();
  PoseState inverted = sys.restState(d);
  inverted.u = sys.dofsFrom(mirrored, Eigen::VectorXd());
  inverted.loadFactor = 1.0;
  solveEquilibrium(sys, d, inverted, NewtonOptions{});
  return inverted;
}

}  // namespace rodmesh::testutil
