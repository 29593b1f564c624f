// Tests of meshing/solid.*, solid_check.cc and export.*: swept solids, the
// CGAL printability checks and the export of an archive.
#include "meshing/export.hh"
#include "meshing/rod_mesher.hh"
#include "meshing/solid.hh"

#include "io/archive.hh"
#include "io/scene_reader.hh"
#include "io/scene_writer.hh"
#include "test_surfaces.hh"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <sys/stat.h>

namespace rodmesh::meshing {
namespace {

bool fileExists(const std::string& p) {
  struct stat st;
  return ::stat(p.c_str(), &st) == 0;
}

// A straight rod from a to b in `n` edges with constant radii, d2 along `up`.
std::vector<SweepEdge> straightRod(const Vec3& a, const Vec3& b, int n, const Vec2& r, const Vec3& up, int rod) {
  std::vector<SweepEdge> out;
  const Vec3 t = (b - a).normalized();
  const Vec3 d2 = (up - up.dot(t) * t).normalized();
  const Vec3 d1 = d2.cross(t);
  for (int i = 0; i < n; ++i) {
    SweepEdge e;
    e.p0 = a + (b - a) * (double(i) / n);
    e.p1 = a + (b - a) * (double(i + 1) / n);
    e.d1 = d1;
    e.d2 = d2;
    e.r0 = e.r1 = r;
    e.rod = rod;
    out.push_back(e);
  }
  return out;
}

TEST(Solid, StraightEllipticRodHasTheExpectedVolumeAndShape) {
  const double L = 0.05, rt = 0.003, rn = 0.0015;
  const auto edges = straightRod(Vec3(0, 0, 0), Vec3(L, 0, 0), 10, Vec2(rt, rn), Vec3(0, 0, 1), 0);
  SolidOptions o;
  o.resolution = 0.0003;
  IndexedMesh m = sweepRods(edges, o);
  roundToFloat(m);
  const SolidCheck c = checkSolid(m);
  ASSERT_TRUE(c.ok()) << c.problems();
  // Elliptic cylinder plus two half-ellipsoid caps of length max(rt, rn).
  const double expected = M_PI * rt * rn * L + 4.0 / 3.0 * M_PI * rt * rn * std::max(rt, rn);
  EXPECT_NEAR(c.volume, expected, 0.02 * expected);
  // r_t lies along d1 = y, r_n along d2 = z.
  EXPECT_NEAR(c.hi.y(), rt, 0.05 * rt);
  EXPECT_NEAR(c.hi.z(), rn, 0.05 * rn);
  EXPECT_NEAR(c.hi.x(), L + rt, 0.05 * rt);
}

TEST(Solid, RodsMeetingAtAConnectionFormOnePieceWithFillets) {
  std::vector<SweepEdge> edges;
  for (int k = 0; k < 3; ++k) {
    const double a = 2 * M_PI * k / 3;
    auto r = straightRod(Vec3(0, 0, 0), 0.03 * Vec3(std::cos(a), std::sin(a), 0), 6, Vec2(0.002, 0.0015),
                         Vec3(0, 0, 1), k);
    edges.insert(edges.end(), r.begin(), r.end());
  }
  SolidOptions sharp;
  sharp.resolution = 0.0004;
  sharp.fillet = 0;
  SolidOptions smooth = sharp;
  smooth.fillet = 0.002;
  IndexedMesh a = sweepRods(edges, sharp), b = sweepRods(edges, smooth);
  roundToFloat(a);
  roundToFloat(b);
  const SolidCheck ca = checkSolid(a), cb = checkSolid(b);
  ASSERT_TRUE(ca.ok()) << ca.problems();
  ASSERT_TRUE(cb.ok()) << cb.problems();
  EXPECT_EQ(cb.components, 1);
  EXPECT_GT(cb.volume, ca.volume * 1.001);  // fillets add material at the joint
  EXPECT_LT(cb.volume, ca.volume * 1.2);
}

TEST(Solid, ChecksCatchDefects) {
  // Two separate rods: two components.
  auto edges = straightRod(Vec3(0, 0, 0), Vec3(0.02, 0, 0), 4, Vec2(0.002, 0.002), Vec3(0, 0, 1), 0);
  auto other = straightRod(Vec3(0, 0.02, 0), Vec3(0.02, 0.02, 0), 4, Vec2(0.002, 0.002), Vec3(0, 0, 1), 1);
  edges.insert(edges.end(), other.begin(), other.end());
  SolidOptions o;
  o.resolution = 0.0006;
  IndexedMesh m = sweepRods(edges, o);
  SolidCheck c = checkSolid(m);
  EXPECT_EQ(c.components, 2);
  EXPECT_FALSE(c.ok());
  // An open mesh (one face removed), and a reversed (inward) mesh.
  IndexedMesh single = sweepRods(straightRod(Vec3(0, 0, 0), Vec3(0.02, 0, 0), 4, Vec2(0.002, 0.002), Vec3(0, 0, 1), 0), o);
  IndexedMesh open = single;
  open.faces.pop_back();
  c = checkSolid(open);
  EXPECT_FALSE(c.closed);
  EXPECT_FALSE(c.ok());
  IndexedMesh inward = single;
  for (Tri& t : inward.faces) std::swap(t[1], t[2]);
  c = checkSolid(inward);
  EXPECT_FALSE(c.outward);
  EXPECT_FALSE(c.ok());
  // Two overlapping copies of the same closed mesh intersect each other.
  IndexedMesh twice = single;
  const int nv = static_cast<int>(single.vertices.size());
  for (const Vec3& v : single.vertices) twice.vertices.push_back(v + Vec3(0.001, 0.0005, 0.0003));
  for (const Tri& t : single.faces) twice.faces.push_back({t[0] + nv, t[1] + nv, t[2] + nv});
  c = checkSolid(twice);
  EXPECT_TRUE(c.selfIntersecting);
  EXPECT_FALSE(c.ok());
}

TEST(Solid, WorkIsBoundedBeforeAnythingIsAllocated) {
  const auto edges = straightRod(Vec3(0, 0, 0), Vec3(0.05, 0, 0), 10, Vec2(0.002, 0.002), Vec3(0, 0, 1), 0);
  SolidOptions o;
  o.resolution = 1e-6;     // ~3e9 triangles
  o.maxTriangles = 20000;  // keeps the suggested step quick to run here
  std::string suggestion;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    sweepRods(edges, o);
    ADD_FAILURE() << "--resolution 1e-6 accepted";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.find("--resolution 1e-06 m would need about"), 0u) << m;
    const std::string use = "use --resolution ";
    ASSERT_NE(m.find(use), std::string::npos) << m;
    suggestion = m.substr(m.find(use) + use.size());
    suggestion = suggestion.substr(0, suggestion.find(' '));
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 1.0);
  // The suggested step is within the limits.
  o.resolution = std::stod(suggestion);
  SolidReport r;
  const IndexedMesh m = sweepRods(edges, o, &r);
  EXPECT_FALSE(r.coarsened);
  EXPECT_LE(r.work.triangles, o.maxTriangles);
  EXPECT_GT(static_cast<double>(m.faces.size()), 0.5 * r.work.triangles);
  EXPECT_LT(static_cast<double>(m.faces.size()), 1.5 * r.work.triangles);
  // The default step is coarsened to fit instead.
  SolidOptions d;
  d.maxTriangles = 3000;
  const IndexedMesh c = sweepRods(edges, d, &r);
  EXPECT_TRUE(r.coarsened);
  EXPECT_LE(r.work.triangles, 3000);
  EXPECT_LT(static_cast<double>(c.faces.size()), 1.5 * 3000);
  EXPECT_TRUE(checkSolid(c).ok()) << checkSolid(c).problems();
}

TEST(Solid, OptionsAndEdgesOutOfRangeAreInputErrors) {
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  for (double v : {nan, inf, -1.0, 2.0}) {
    SolidOptions o;
    o.resolution = v;
    EXPECT_THROW(validateOptions(o), InputError) << v;
    o.resolution = 0;
    o.fillet = v == -1.0 ? 5.0 : v;  // negative fillet = default, so test 5 m instead
    EXPECT_THROW(validateOptions(o), InputError) << v;
  }
  auto edges = straightRod(Vec3(0, 0, 0), Vec3(0.05, 0, 0), 4, Vec2(0.002, 0.002), Vec3(0, 0, 1), 0);
  edges[2].p1.x() = nan;
  EXPECT_THROW(sweepRods(edges, SolidOptions()), InputError);
  edges = straightRod(Vec3(0, 0, 0), Vec3(0.05, 0, 0), 4, Vec2(0.002, 0.002), Vec3(0, 0, 1), 0);
  edges[1].r0[0] = inf;
  EXPECT_THROW(sweepRods(edges, SolidOptions()), InputError);
  // Far-apart rods: the bounding grid, not the triangles, is what is too large.
  auto far = straightRod(Vec3(0, 0, 0), Vec3(0.05, 0, 0), 4, Vec2(0.002, 0.002), Vec3(0, 0, 1), 0);
  const auto other =
      straightRod(Vec3(1e4, 1e4, 1e4), Vec3(1e4 + 0.05, 1e4, 1e4), 4, Vec2(0.002, 0.002), Vec3(0, 0, 1), 1);
  far.insert(far.end(), other.begin(), other.end());
  SolidOptions o;
  o.resolution = 0.001;
  try {
    sweepRods(far, o);
    ADD_FAILURE() << "a 17 km grid accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("grid blocks"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("too large to export"), std::string::npos) << e.what();
  }
}

// Meshes a small sphere, stores it in an archive (rest + one shifted pose)
// and exports it.
class ExportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const TriSurface s = testing::icosphere(0.04, 2);
    MeshOptions o;
    o.cvt.cells = 14;
    o.radius = Vec2(0.002, 0.0015);
    scene_ = meshSurface(s, {}, {}, o).scene;
    Archive a;
    a.version = "test";
    a.command = "simulate";
    a.status = "converged";
    a.sceneJson = sceneToJson(scene_);
    const int nv = static_cast<int>(scene_.vertices.size());
    // The /model counts every archive carries (checked against the scene by export).
    a.nVertices = nv;
    a.nRods = static_cast<long long>(scene_.rods.size());
    for (const Rod& r : scene_.rods) a.nEdges += static_cast<long long>(r.vertices.size()) - 1;
    a.restPositions.resize(nv, 3);
    a.radii.resize(nv, 2);
    ArchivePose p;
    p.name = "squashed";
    p.positions.resize(nv, 3);
    for (int i = 0; i < nv; ++i) {
      a.restPositions.row(i) = scene_.vertices[i].transpose();
      a.radii.row(i) = scene_.radii[i].transpose();
      p.positions.row(i) = Vec3(scene_.vertices[i].x() * 1.1, scene_.vertices[i].y() * 1.1,
                                scene_.vertices[i].z() * 0.7).transpose();
    }
    a.poses.push_back(p);
    archive_ = testing::tempPath(".h5");
    writeArchive(a, archive_);
  }
  void TearDown() override { std::remove(archive_.c_str()); }
  Scene scene_;
  std::string archive_;
};

TEST_F(ExportTest, RestAndPoseSolidsPassTheChecksAndAreWritten) {
  ExportOptions o;
  o.solid.resolution = 0.0007;
  const std::string stl = testing::tempPath(".stl");
  const ExportReport r = exportSolid(archive_, stl, o);
  EXPECT_TRUE(r.check.ok()) << r.check.problems();
  EXPECT_GT(r.check.volume, 0);
  EXPECT_NEAR(r.mass, r.check.volume * 1200.0, 1e-12);
  // Binary STL: 84 bytes + 50 per triangle.
  std::ifstream in(stl, std::ios::binary | std::ios::ate);
  EXPECT_EQ(static_cast<long long>(in.tellg()), 84LL + 50LL * r.triangles);
  std::remove(stl.c_str());

  o.pose = "squashed";
  const std::string ply = testing::tempPath(".ply");
  const ExportReport rp = exportSolid(archive_, ply, o);
  EXPECT_TRUE(rp.check.ok()) << rp.check.problems();
  EXPECT_LT(rp.check.hi.z() - rp.check.lo.z(), 0.8 * (r.check.hi.z() - r.check.lo.z()));
  // The PLY reads back as a valid closed surface.
  const TriSurface back = readSurface(ply);
  EXPECT_EQ(static_cast<int>(back.faces.size()), rp.triangles);
  EXPECT_TRUE(SurfaceTopology(back).boundaryLoops.empty());
  std::remove(ply.c_str());
}

TEST_F(ExportTest, BadRequestsWriteNothing) {
  ExportOptions o;
  o.pose = "nope";
  const std::string stl = testing::tempPath(".stl");
  try {
    exportSolid(archive_, stl, o);
    FAIL() << "unknown pose accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'nope'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("squashed"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fileExists(stl));
  o.pose.clear();
  EXPECT_THROW(exportSolid(archive_, testing::tempPath(".xyz"), o), InputError);
  EXPECT_THROW(exportSolid("/nonexistent/archive.h5", stl, o), std::exception);
  EXPECT_FALSE(fileExists(stl));
}

TEST_F(ExportTest, NonFiniteArchiveDataIsAnInputError) {
  Archive a = readArchive(archive_);
  a.poses[0].positions(3, 1) = std::numeric_limits<double>::quiet_NaN();
  const std::string bad = testing::tempPath(".h5");
  writeArchive(a, bad);
  ExportOptions o;
  o.pose = "squashed";
  const std::string stl = testing::tempPath(".stl");
  try {
    exportSolid(bad, stl, o);
    ADD_FAILURE() << "NaN position accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/poses/squashed/positions: entry [3][1] is not finite, got nan"),
              std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(fileExists(stl));
  std::remove(bad.c_str());
}

}  // namespace
}  // namespace rodmesh::meshing
