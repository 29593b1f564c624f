// Tests of meshing/surface.*: readers and the validation of input surfaces.
#include "meshing/surface.hh"

#include "io/scene_reader.hh"
#include "test_surfaces.hh"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>

namespace rodmesh::meshing {
namespace {

using testing::tempPath;
using testing::writeText;

// Expects readSurface(path) to throw InputError whose message names the file
// and contains `fragment`.
void expectRejected(const std::string& path, const std::string& fragment) {
  try {
    readSurface(path);
    FAIL() << "accepted " << path << " (expected an error containing '" << fragment << "')";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(path), std::string::npos) << m;
    EXPECT_NE(m.find(fragment), std::string::npos) << m;
  }
}

const char* kTetraObj =
    "# tetrahedron\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
    "f 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n";

TEST(SurfaceRead, ObjOffPlyAsciiAndBinaryAgree) {
  const std::string obj = tempPath(".obj"), off = tempPath(".off"), ply = tempPath(".ply"), bply = tempPath(".ply");
  writeText(obj, std::string(kTetraObj) + "vn 0 0 1\nf 1/1/1 3//1 2\n");  // slash forms; extra face is a duplicate
  writeText(off, "OFF\n# comment\n4 4 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 1 2 3\n3 2 0 3\n");
  writeText(ply,
            "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 4\nproperty list uchar int vertex_indices\nend_header\n"
            "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 1 2 3\n3 2 0 3\n");
  {
    std::string b =
        "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty double x\nproperty double y\n"
        "property double z\nproperty uchar red\nelement face 4\nproperty list uchar uint vertex_indices\nend_header\n";
    const double P[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (auto& p : P) {
      b.append(reinterpret_cast<const char*>(p), 24);
      b.push_back('\x7f');
    }
    const std::uint32_t F[4][3] = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3}};
    for (auto& f : F) {
      b.push_back('\x03');
      b.append(reinterpret_cast<const char*>(f), 12);
    }
    writeText(bply, b);
  }
  // The OBJ with the duplicate face is rejected; the others load identically.
  expectRejected(obj, "duplicates face 0");
  const TriSurface a = readSurface(off), c = readSurface(ply), d = readSurface(bply);
  ASSERT_EQ(a.faces.size(), 4u);
  EXPECT_EQ(a.vertices, c.vertices);
  EXPECT_EQ(a.vertices, d.vertices);
  EXPECT_EQ(a.faces, c.faces);
  EXPECT_EQ(a.faces, d.faces);
  writeText(obj, kTetraObj);
  const TriSurface o = readSurface(obj);
  EXPECT_EQ(o.faces, a.faces);
  EXPECT_EQ(SurfaceTopology(o).boundaryLoops.size(), 0u);
}

TEST(SurfaceRead, RejectsBadSurfacesWithClearMessages) {
  const std::string p = tempPath(".obj");
  writeText(p, "# nothing\nv 0 0 0\n");
  expectRejected(p, "empty");
  writeText(p, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
  expectRejected(p, "face 0 has 4 corners");
  writeText(p, "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
  expectRejected(p, "face 0 is degenerate");
  writeText(p, "v 0 0 0\nv 1 0 0\nf 1 2 2\n");
  expectRejected(p, "degenerate");
  writeText(p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
  expectRejected(p, "line 4: face index '7' is out of range");
  // Three triangles on one edge (a "book").
  writeText(p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n");
  expectRejected(p, "non-manifold edge");
  // Two triangles touching at one vertex (a bow tie).
  writeText(p, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv -1 0 0\nv -1 -1 0\nf 1 2 3\nf 1 4 5\n");
  expectRejected(p, "non-manifold vertex 0");
  writeText(p, "v 0 0 0\nv 1 0 x\nf 1 2 3\n");
  expectRejected(p, "line 2");
  expectRejected("/nonexistent/dir/surface.obj", "cannot open");
  const std::string stl = tempPath(".stl");
  writeText(stl, "solid x\nendsolid x\n");
  expectRejected(stl, "unsupported surface format");
}

TEST(SurfaceRead, InconsistentOrientationIsRepaired) {
  const std::string p = tempPath(".obj");
  // Square of two triangles with opposite orientations.
  writeText(p, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 4 3\n");
  std::vector<char> flips;
  const TriSurface s = validateSurface(readPolygonFile(p), p, &flips);
  EXPECT_EQ(flips[1], 1);
  const std::vector<Vec3> n = vertexNormals(s);
  for (const Vec3& v : n) EXPECT_NEAR(std::abs(v.z()), 1.0, 1e-12);
  EXPECT_NEAR(n[0].z(), n[2].z(), 1e-12);
  // A deformed copy written with the input's (inconsistent) faces is accepted.
  const std::string q = tempPath(".obj");
  writeText(q, "v 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 1 2 3\nf 1 4 3\n");
  const TriSurface d = readDeformedCopy(q, s, flips);
  EXPECT_EQ(d.faces, s.faces);
  // A copy with other faces is rejected, naming the face.
  writeText(q, "v 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 1 2 3\nf 1 3 4\n");
  EXPECT_THROW(readDeformedCopy(q, s, flips), InputError);
  writeText(q, "v 0 0 1\nv 1 0 1\nv 1 1 1\nf 1 2 3\n");
  EXPECT_THROW(readDeformedCopy(q, s, flips), InputError);
}

TEST(SurfaceGeometry, ClosestPointAndBoundaryLoops) {
  const TriSurface d = testing::dome(1.0, 6, 12);
  const SurfaceTopology t(d);
  ASSERT_EQ(t.boundaryLoops.size(), 1u);
  EXPECT_EQ(t.boundaryLoops[0].size(), 12u);
  double dist = -1;
  const SurfacePoint p = closestPoint(d, Vec3(0, 0, 2), {}, &dist);
  EXPECT_NEAR(dist, 1.0, 1e-12);
  EXPECT_NEAR((evalPoint(d, p) - Vec3(0, 0, 1)).norm(), 0.0, 1e-12);
}

}  // namespace
}  // namespace rodmesh::meshing
