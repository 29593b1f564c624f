// Scene builders shared by the tests (straight and curved rods, cantilevers,
// a small network with connections).
#pragma once

#include "model/scene.hh"

namespace rodmesh::testutil {

// A straight rod along +x from the origin, `edges` edges over `length`,
// uniform radii, one pose with no boundary conditions. Material: E = 1e7 Pa,
// nu = 0.4, rho = 1000 kg/m^3 unless changed by the caller.
Scene straightRod(int edges, double length, double rt, double rn);

// A cantilever: straight rod along +x from the origin (`edges` equal edges
// over `length`, uniform radii [rt, rn]), clamped at vertex 0 (the root), free
// at vertex `edges` (the tip). Every vertex gets the explicit reference
// normal `normal` (Scene::normals, perpendicular to x), so the r_n semi-axis
// lies along `normal` and the r_t semi-axis along normal x x.
// One pose named "pose0" with only the clamp; loads are added by the caller.
// Material as in straightRod.
Scene cantilever(int edges, double length, double rt, double rn, const Vec3& normal);

// The cantilever above (normal +z, radius r) and a short rod of two vertices
// held in pose 0 (fixed at rest), its first vertex `drop` below the tip
// (x = length, z = -drop), the second 10 mm further along x: a support for
// terms between the tip and a fixed vertex (contacts, ties). Returns the
// scene; the held vertex below the tip is vertex edges + 1.
Scene cantileverOverHeldRod(int edges, double length, double r, double drop);

// A circular arc of `radius` in the xy plane, centred at the origin, from
// angle 0 to `angle` [rad] (counter-clockwise), `edges` equal edges, uniform
// radii, reference normals +z, clamped at vertex 0. One pose "pose0" with only
// the clamp. Material as in straightRod.
Scene clampedArc(int edges, double radius, double angle, double rt, double rn);

// A small rod network with connections, for derivative and gradient tests.
// Three curved arms leave vertex 0 (a 3-valent connection) along the
// directions dir at angles 0.1, 2.2 and 4.1 rad in the xy plane, each with
// `verticesPerArm` (>= 3) further vertices, numbered arm after arm: vertex i
// of an arm lies at 0.01 i dir + 0.0008 i^2 side + lift i^2 z, side = dir
// turned by +90 degrees in the plane. The first arm is split at its vertex 2
// into rods {0, 1, 2} and {2, 3, ..., verticesPerArm} (a 2-valent, nearly
// straight connection). Radii: r_t = radiusBase.x + radiusStep.x (v mod 4),
// r_n = radiusBase.y + radiusStep.y (v mod 3). Material E = 2e7 Pa, nu = 0.45,
// rho = 1100 kg/m^3. Gravity (0, -9.81, 0), in the plane, when lift == 0 (a
// planar scene), else (0.5, -2, -9.81). No poses: supports, loads and
// targets are the caller's.
struct StarNetworkOptions {
  int verticesPerArm = 3;
  double lift = 0.0;  // m: out-of-plane rise, z = lift i^2; 0 = planar
  Vec2 radiusBase = Vec2(0.0012, 0.0008);
  Vec2 radiusStep = Vec2(0.0002, 0.0001);
};
Scene starNetwork(const StarNetworkOptions& options);

// A connection at vertex 0 with one rod of two edges per direction: rod r
// runs 0 -> 0.01 dir_r + 0.0003 side_r -> 0.02 dir_r + 0.001 side_r + 0.0005 z
// (side_r = the xy part of dir_r turned by +90 degrees), its far end fixed, in
// one pose "p". Radii (0.001, 0.0007) times radiusScale[r] on rod r (empty:
// 1 everywhere). Material E = 2e7 Pa, nu = 0.45, rho = 1100 kg/m^3; effects
// stretch, bend, twist, connections, and gravity (0.5, -2, -9.81) when
// `gravity`.
Scene connectionStar(const std::vector<Vec3>& directions, const std::vector<double>& radiusScale = {},
                     bool gravity = false);

// Index of the last vertex of the first rod (the free tip of the builders above).
int tipVertex(const Scene& s);

}  // namespace rodmesh::testutil
