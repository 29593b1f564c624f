// A planar scene is solved with in-plane unknowns; the solver then checks the
// in-plane equilibrium against out-of-plane motion and twist in the full 3D
// model. A flat cantilever (r_t = 2 r_n) loaded in its plane about its stiff
// axis is stable below its lateral-torsional buckling load and a saddle above.
#include "solver/equilibrium.hh"

#include <gtest/gtest.h>

namespace rodmesh {
namespace {

Scene flatCantilever(double load) {
  Scene s;
  s.sourcePath = "<planar-stability>";
  s.material = Material{1e7, 0.4, 1000.0};
  Rod rod;
  for (int i = 0; i <= 10; ++i) {
    s.vertices.push_back(Vec3(0.01 * i, 0, 0));
    rod.vertices.push_back(i);
  }
  rod.normal = Vec3(0, 0, 1);
  s.rods.push_back(rod);
  s.radii.assign(s.vertices.size(), Vec2(0.002, 0.001));  // wide in the plane: stiff in-plane bending
  Pose p;
  p.name = "p";
  p.clamped.push_back({0});
  p.forces.push_back({10, Vec3(0, -load, 0)});
  s.poses.push_back(p);
  return s;
}

TEST(PlanarStability, InPlaneEquilibriumCheckedAgainstLateralBuckling) {
  // Lateral-torsional buckling of a tip-loaded cantilever:
  // P_cr = 4.013 sqrt(E I_weak G J) / L^2.
  const double E = 1e7, G = E / 2.8, rt = 0.002, rn = 0.001, L = 0.1;
  const double Iweak = 3.14159265358979 * rt * rn * rn * rn / 4;
  const double J = 3.14159265358979 * rt * rt * rt * rn * rn * rn / (rt * rt + rn * rn);
  const double Pcr = 4.013 * std::sqrt(E * Iweak * G * J) / (L * L);
  for (double factor : {0.5, 3.0}) {
    const Scene s = flatCantilever(factor * Pcr);
    const SimulationResult r = [&] {
      SceneModel model(s);
      EXPECT_TRUE(model.effects().planar);
      return simulateAll(model, Design::fromScene(s), NewtonOptions{});
    }();
    ASSERT_TRUE(r.allConverged);
    ASSERT_TRUE(r.poses[0].outOfPlaneStable.has_value());
    EXPECT_EQ(*r.poses[0].outOfPlaneStable, factor < 1.0) << "load " << factor << " P_cr";
  }
}

}  // namespace
}  // namespace rodmesh
