// Tests of meshing/cvt.* and meshing/rod_mesher.*: layouts, rods on the
// surface, targets from deformed copies, boundary conditions, scene validity.
#include "meshing/rod_mesher.hh"

#include "io/scene_reader.hh"
#include "io/scene_writer.hh"
#include "model/network.hh"
#include "test_surfaces.hh"

#include <gtest/gtest.h>

#include <cstdio>
#include <functional>
#include <limits>
#include <set>

namespace rodmesh::meshing {
namespace {

using testing::distanceToSurface;

// Contract checks on a generated scene: it parses, rods meet only at ends,
// every connection ends >= 2 rods, no zero-length edges; rod vertices lie on
// the surface (distance below 1% of the edge length).
void checkScene(const MeshResult& r, const TriSurface& surface) {
  const std::string path = testing::tempPath(".json");
  writeSceneFile(r.scene, path);
  const Scene back = readSceneFile(path);  // throws on any contract violation
  std::remove(path.c_str());
  ASSERT_EQ(back.vertices.size(), r.scene.vertices.size());
  ASSERT_EQ(back.rods.size(), r.scene.rods.size());
  ASSERT_EQ(r.locations.size(), r.scene.vertices.size());
  const RodNetwork net(back);
  for (const Connection& c : net.connections()) EXPECT_GE(c.edges.size(), 2u);
  for (const Edge& e : net.edges()) EXPECT_GT((back.vertices[e.a] - back.vertices[e.b]).norm(), 0.0);
  double worst = 0;
  for (std::size_t i = 0; i < r.scene.vertices.size(); ++i) {
    worst = std::max(worst, distanceToSurface(surface, r.scene.vertices[i]));
    EXPECT_NEAR(r.scene.normals[i].norm(), 1.0, 1e-9);
  }
  EXPECT_LT(worst, 0.01 * r.report.edgeLength);
}

TEST(Mesher, ClosedSphereIsMostlyHexagons) {
  const TriSurface s = testing::icosphere(0.08, 3);
  MeshOptions o;
  o.cvt.cells = 120;
  const MeshResult r = meshSurface(s, {}, {}, o);
  checkScene(r, s);
  EXPECT_EQ(r.report.closedCells, 120);
  EXPECT_GE(r.report.hexagonShare, 0.70) << formatReport(r.report);
  EXPECT_EQ(r.report.freeEnds, 0);
  // Voronoi vertices of a closed surface: valence 3 (4 after a contraction).
  for (auto [valence, n] : r.report.valence) {
    EXPECT_GE(valence, 3);
    EXPECT_LE(valence, 4);
  }
  EXPECT_GT(r.report.valence.at(3), 0.9 * r.report.connections);
  // Euler: V - E + F = 2 for the cell complex (connections, rods, cells).
  EXPECT_EQ(r.report.connections - r.report.rods + r.report.closedCells, 2);
  // Without --pose: one pose "rest" with no target.
  ASSERT_EQ(r.scene.poses.size(), 1u);
  EXPECT_EQ(r.scene.poses[0].name, "rest");
  EXPECT_TRUE(r.scene.poses[0].target.empty());
}

TEST(Mesher, DomeWithRimIsMostlyHexagonsAndClosed) {
  const TriSurface s = testing::dome(0.1, 16, 64);
  MeshOptions o;
  o.cvt.cells = 60;
  const MeshResult r = meshSurface(s, {}, {}, o);
  checkScene(r, s);
  EXPECT_EQ(r.report.freeEnds, 0);  // rim rods close the border cells
  EXPECT_EQ(r.report.openCells, 0);
  EXPECT_GE(r.report.interiorCells, 20);
  // A hemisphere carries the curvature of six pentagons, so fewer hexagons
  // than on a closed sphere (and cells clipped by the rim are mostly
  // pentagons): we require a majority of hexagons away from the rim.
  EXPECT_GE(r.report.interiorHexagonShare, 0.5) << formatReport(r.report);
  // Rim: rod vertices on the boundary circle z = 0 exist.
  int onRim = 0;
  for (const Vec3& v : r.scene.vertices) onRim += std::abs(v.z()) < 1e-9;
  EXPECT_GT(onRim, 50);

  o.cvt.boundary = BoundaryMode::Free;
  const MeshResult f = meshSurface(s, {}, {}, o);
  checkScene(f, s);
  EXPECT_GT(f.report.freeEnds, 5);
  EXPECT_GT(f.report.openCells, 5);
}

TEST(Mesher, TargetsReproduceDeformedSurfaceAtRodVertices) {
  const TriSurface s = testing::dome(0.1, 12, 48);
  // Affine copy: the target must be exactly the affine image of the rest
  // position (barycentric maps commute with affine maps).
  Eigen::Matrix3d A;
  A << 1.1, 0.2, 0.0, -0.1, 0.9, 0.3, 0.05, 0.0, 1.2;
  const Vec3 b(0.01, -0.02, 0.03);
  DeformedPose affine{"affine", s};
  for (Vec3& v : affine.surface.vertices) v = A * v + b;
  // Non-linear copy: targets must lie on the deformed surface.
  DeformedPose bent{"bent", s};
  for (Vec3& v : bent.surface.vertices) v = Vec3(v.x(), v.y() + 2.0 * v.x() * v.x(), v.z() - 3.0 * v.x() * v.z());
  MeshOptions o;
  o.cvt.cells = 30;
  o.fixBoxes.push_back({Vec3(-1, -1, -1e-6), Vec3(1, 1, 1e-6)});  // the rim (z = 0)
  const MeshResult r = meshSurface(s, {affine, bent}, {}, o);
  checkScene(r, s);
  ASSERT_EQ(r.scene.poses.size(), 2u);
  const Pose& pa = r.scene.poses[0];
  const Pose& pb = r.scene.poses[1];
  EXPECT_EQ(pa.name, "affine");
  ASSERT_EQ(pa.target.size(), r.scene.vertices.size());
  double worstAffine = 0, worstBent = 0;
  for (std::size_t i = 0; i < r.scene.vertices.size(); ++i) {
    worstAffine = std::max(worstAffine, (pa.target[i] - (A * r.scene.vertices[i] + b)).norm());
    worstBent = std::max(worstBent, distanceToSurface(bent.surface, pb.target[i]));
    // Same point of the same triangle of the deformed copy.
    EXPECT_LT((pb.target[i] - evalPoint(bent.surface, r.locations[i])).norm(), 1e-15);
  }
  EXPECT_LT(worstAffine, 1e-12);
  EXPECT_LT(worstBent, 1e-12);
  // Fixed vertices: the rim, at their deformed positions in every pose.
  ASSERT_GT(pa.fixed.size(), 10u);
  EXPECT_EQ(pa.fixed.size(), static_cast<std::size_t>(r.report.fixedVertices));
  for (const Pose* p : {&pa, &pb})
    for (const FixedVertex& f : p->fixed) {
      EXPECT_NEAR(r.scene.vertices[f.vertex].z(), 0.0, 1e-9);
      ASSERT_TRUE(f.position.has_value());
      EXPECT_LT((*f.position - p->target[f.vertex]).norm(), 1e-15);
    }
}

TEST(Mesher, FixVerticesPicksNearestRodVertex) {
  const TriSurface s = testing::icosphere(0.05, 2);
  MeshOptions o;
  o.cvt.cells = 20;
  o.fixSurfaceVertices = {0, 3};
  const MeshResult r = meshSurface(s, {}, {}, o);
  ASSERT_EQ(r.scene.poses.size(), 1u);
  ASSERT_EQ(r.scene.poses[0].fixed.size(), 2u);
  std::set<int> fixed;
  for (const FixedVertex& f : r.scene.poses[0].fixed) {
    EXPECT_FALSE(f.position.has_value());  // rest pose: held at the rest position
    fixed.insert(f.vertex);
  }
  for (int sv : {0, 3}) {
    int nearest = 0;
    for (int i = 1; i < static_cast<int>(r.scene.vertices.size()); ++i)
      if ((r.scene.vertices[i] - s.vertices[sv]).norm() < (r.scene.vertices[nearest] - s.vertices[sv]).norm()) nearest = i;
    EXPECT_TRUE(fixed.count(nearest)) << "surface vertex " << sv;
  }
}

TEST(Mesher, DualOfDecimatedSurface) {
  const TriSurface s = testing::icosphere(0.08, 3);
  MeshOptions o;
  o.method = MeshMethod::Dual;
  o.dualFaces = 100;
  const MeshResult r = meshSurface(s, {}, {}, o);
  checkScene(r, s);
  // One connection per coarse triangle, three rods each (closed surface).
  EXPECT_NEAR(r.report.connections, 100, 10);
  EXPECT_EQ(r.report.valence.size(), 1u);
  EXPECT_EQ(r.report.valence.begin()->first, 3);
  EXPECT_EQ(2 * r.report.rods, 3 * r.report.connections);
}

TEST(Mesher, DensityMakesCellsSmaller) {
  const TriSurface s = testing::icosphere(0.08, 3);
  std::vector<double> density(s.vertices.size());
  for (std::size_t i = 0; i < s.vertices.size(); ++i) density[i] = s.vertices[i].z() > 0 ? 16.0 : 1.0;
  MeshOptions o;
  o.cvt.cells = 60;
  const MeshResult r = meshSurface(s, {}, density, o);
  checkScene(r, s);
  // Connections are the rod ends; count them per hemisphere.
  int up = 0, down = 0;
  for (const Rod& rod : r.scene.rods)
    for (int v : {rod.vertices.front(), rod.vertices.back()}) (r.scene.vertices[v].z() > 0 ? up : down)++;
  // Cell size ~ density^-1/4: twice smaller, about four times as many cells.
  EXPECT_GT(up, 2 * down) << "up " << up << " down " << down;
}

TEST(Mesher, RejectsInconsistentOptions) {
  const TriSurface s = testing::icosphere(0.05, 2);
  MeshOptions o;
  o.cvt.cells = 20;
  o.radius = Vec2(0.01, 0.002);  // above the default upper bound 0.005
  EXPECT_THROW(meshSurface(s, {}, {}, o), InputError);
  o.radius = Vec2(0.002, 0.002);
  o.fixBoxes.push_back({Vec3(1, 1, 1), Vec3(2, 2, 2)});  // selects nothing
  EXPECT_THROW(meshSurface(s, {}, {}, o), InputError);
  o.fixBoxes.clear();
  o.cvt.cells = 1;
  EXPECT_THROW(meshSurface(s, {}, {}, o), InputError);
  o.method = MeshMethod::Dual;
  o.dualFaces = 100000;
  EXPECT_THROW(meshSurface(s, {}, {}, o), InputError);
}

TEST(Mesher, DensityAndVertexListFilesNameLineAndValue) {
  const std::string p = testing::tempPath(".txt");
  auto expectRejected = [&](const std::string& text, int nsv, bool density, const std::string& fragment) {
    testing::writeText(p, text);
    try {
      if (density)
        readDensityFile(p, nsv);
      else
        readVertexListFile(p, nsv);
      ADD_FAILURE() << "accepted " << text;
    } catch (const InputError& e) {
      const std::string m = e.what();
      EXPECT_EQ(m.find(p + ": "), 0u) << m;
      EXPECT_NE(m.find(fragment), std::string::npos) << m;
    }
  };
  expectRejected("1 1\n1e999\n", 3, true, "line 2: value 2 ('1e999')");
  expectRejected("1 nan 1\n", 3, true, "line 1: value 1 ('nan')");
  expectRejected("# ids\n0, 1\n2.5\n", 4, false, "line 3: entry '2.5'");
  expectRejected("0 99999999999999999999\n", 4, false, "line 1: entry '99999999999999999999'");
  expectRejected("0 4294967299\n", 4, false, "'4294967299' is not a surface vertex index in [0, 4)");
  expectRejected("-1\n", 4, false, "'-1'");
  testing::writeText(p, "0, 3 # corners\n");
  EXPECT_EQ(readVertexListFile(p, 4), (std::vector<int>{0, 3}));
}

// Every option out of its range is an InputError naming the flag and the value
// (NaN and infinities included), before any work is done.
TEST(Mesher, OptionsOutOfRangeNameTheFlagAndTheValue) {
  struct Case {
    std::function<void(MeshOptions&)> set;
    std::string flag, value;
  };
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Case> cases = {
      {[](MeshOptions& o) { o.cvt.cells = 2147483647; }, "--cells", "2147483647"},
      {[](MeshOptions& o) { o.cvt.cells = 1; }, "--cells", "1"},
      {[](MeshOptions& o) { o.cvt.maxIterations = 100000; }, "--iterations", "100000"},
      {[](MeshOptions& o) { o.cvt.restarts = 0; }, "--restarts", "0"},
      {[nan](MeshOptions& o) { o.cvt.tolerance = nan; }, "--tolerance", "nan"},
      {[](MeshOptions& o) { o.cvt.mergeFraction = -0.5; }, "--merge", "-0.5"},
      {[](MeshOptions& o) { o.cvt.refinement = 2147483648.0; }, "--refinement", "2147483648"},
      {[inf](MeshOptions& o) { o.cvt.refinement = inf; }, "--refinement", "inf"},
      {[](MeshOptions& o) {
         o.method = MeshMethod::Dual;
         o.dualFaces = 2147483647;
       },
       "--faces", "2147483647"},
      {[inf](MeshOptions& o) { o.edgeLength = inf; }, "--edge-length", "inf"},
      {[](MeshOptions& o) { o.edgeLength = -1; }, "--edge-length", "-1"},
      {[inf](MeshOptions& o) { o.material.youngModulus = inf; }, "--young-modulus", "inf"},
      {[nan](MeshOptions& o) { o.material.poissonRatio = nan; }, "--poisson-ratio", "nan"},
      {[](MeshOptions& o) { o.material.density = 0; }, "--material-density", "0"},
      {[inf](MeshOptions& o) { o.radius = Vec2(inf, 0.002); }, "--radius", "inf"},
      {[inf](MeshOptions& o) { o.radiusMax = inf; }, "--radius-bounds", "inf"},
      {[](MeshOptions& o) { o.controlPointsPerRod = 100000; }, "--control-points", "100000"},
      {[nan](MeshOptions& o) { o.gravity = Vec3(0, 0, nan); }, "--gravity", "nan"},
      {[inf](MeshOptions& o) {
         o.fixBoxes.push_back({Vec3::Zero(), Vec3(1, 1, inf)});
       },
       "--fix-box", ""},
  };
  for (const Case& c : cases) {
    MeshOptions o;
    c.set(o);
    try {
      validateOptions(o);
      ADD_FAILURE() << c.flag << " " << c.value << " accepted";
    } catch (const InputError& e) {
      const std::string m = e.what();
      EXPECT_EQ(m.find(c.flag), 0u) << m;
      EXPECT_NE(m.find(c.value), std::string::npos) << m;
    }
  }
  EXPECT_NO_THROW(validateOptions(MeshOptions()));
}

TEST(Mesher, EdgeLengthAndSurfaceSizeAreBounded) {
  MeshOptions o;
  o.cvt.cells = 20;
  o.edgeLength = 1e-9;  // about 1e8 rod vertices on this sphere
  try {
    meshSurface(testing::icosphere(0.05, 2), {}, {}, o);
    ADD_FAILURE() << "--edge-length 1e-9 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--edge-length 1e-09 m gives about"), std::string::npos) << e.what();
  }
  o.edgeLength = 0;
  try {
    meshSurface(testing::icosphere(1e-8, 2), {}, {}, o);
    ADD_FAILURE() << "a surface of 2e-8 m accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("the surface spans"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rodmesh::meshing
