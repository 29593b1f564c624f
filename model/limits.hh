// Plausible ranges of the physical quantities of a rod mesh, in SI units,
// shared by the scene reader (io/scene_reader.cc: every scene, simulate and
// optimize alike) and the `mesh` command's flags (meshing/rod_mesher.hh), so
// that a value `mesh` refuses is refused in a scene too (docs/formats.md,
// "Plausible ranges"). Beyond them a run is not meaningful for a
// 3D-printable rod mesh and its arithmetic leaves double precision (radii to
// the fourth power, loads times lengths, squared target distances), so the
// input is refused before any work instead of failing, or running for ever,
// late.
#pragma once

namespace rodmesh::limits {

// |coordinate| of a vertex, a target or a held vertex's position [m]; also the
// largest surface or sheet a `mesh` run makes (its bounding-box diagonal).
constexpr double kMaxCoordinate = 1e6;
// Rest edge length [m]: shorter edges are below any printer's resolution and
// make curvatures (1/length) overflow for coordinates in range.
constexpr double kMinEdgeLength = 1e-8;
// Cross-section radius, initial or bound [m]: [kMinRadius, kMaxRadius]. Below
// a micrometre the stiffnesses (radius to the fourth power) vanish against
// any load.
constexpr double kMinRadius = 1e-6;
constexpr double kMaxRadius = 100.0;
// Young's modulus [Pa]: [kMinYoungModulus, kMaxYoungModulus] (soft gels are
// about 1e3, diamond about 1.2e12).
constexpr double kMinYoungModulus = 1.0;
constexpr double kMaxYoungModulus = 1e13;
// Density [kg/m^3]: [kMinDensity, kMaxDensity] (aerogels are about 1,
// osmium about 2.3e4).
constexpr double kMinDensity = 1e-3;
constexpr double kMaxDensity = 1e5;
// Each gravity component [m/s^2]: [-kMaxGravity, kMaxGravity].
constexpr double kMaxGravity = 1e4;
// Each component of a point force [N]: [-kMaxForce, kMaxForce].
constexpr double kMaxForce = 1e9;
// A twisting moment [N m]: [-kMaxMoment, kMaxMoment].
constexpr double kMaxMoment = 1e9;
// Tie stiffness, N/m (poses[i].ties[j].stiffness).
constexpr double kMaxTieStiffness = 1e12;
// A pose weight of the optimization objective: [0, kMaxWeight].
constexpr double kMaxWeight = 1e6;
// design.control_points_per_rod (and `mesh --control-points`): [2, kMaxControlPoints].
// The interpolation weights are Bernstein polynomials of degree n - 1 whose
// binomial coefficients leave double precision for n above about 1030.
constexpr int kMaxControlPoints = 1000;
// Sine of the angle below which a reference normal counts as lying along an
// edge, where it leaves the cross section's orientation undefined: the
// scene reader refuses such normals, and the rest frames of a designed rest
// shape that turns an edge that close to its normal are undefined too
// (model/energies/rod_math.hh, restFrameOf). Far below any surface normal's
// angle to its rods, far above the 1e-6 at which the edge frame falls back
// to an arbitrary perpendicular (model/network.cc, edgeFrameFromNormal).
constexpr double kNormalAlongEdgeSine = 1e-4;

}  // namespace rodmesh::limits
