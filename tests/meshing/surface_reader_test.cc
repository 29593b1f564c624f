// Tests of the OBJ, OFF and PLY readers of meshing/surface.*: every number is
// parsed strictly, and a bad index or coordinate is rejected with a message
// naming the file, the line (ASCII) or element entry (binary PLY) and the
// offending text, instead of being wrapped, truncated or read as inf.
#include "meshing/surface.hh"

#include "io/scene_reader.hh"
#include "test_surfaces.hh"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <limits>
#include <string>

namespace rodmesh::meshing {
namespace {

using testing::tempPath;
using testing::writeText;

// Expects readSurface(path) to throw InputError whose message names the file
// and contains every fragment.
void expectRejected(const std::string& path, std::initializer_list<std::string> fragments) {
  try {
    readSurface(path);
    ADD_FAILURE() << "accepted " << path << " (expected an error containing '" << *fragments.begin() << "')";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.find(path), 0u) << m;
    for (const std::string& f : fragments) EXPECT_NE(m.find(f), std::string::npos) << "'" << f << "' not in: " << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << "one line expected: " << m;
  }
}

// Writes `text` to a fresh file with the suffix and expects a rejection.
void expectTextRejected(const std::string& suffix, const std::string& text,
                        std::initializer_list<std::string> fragments) {
  const std::string p = tempPath(suffix);
  writeText(p, text);
  SCOPED_TRACE(text);
  expectRejected(p, fragments);
  std::remove(p.c_str());
}

const std::string kObjVertices = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";  // lines 1-3; faces start on line 4

TEST(SurfaceReaderObj, FaceIndicesAreCheckedNotWrapped) {
  // 4294967299 = 2^32 + 3 used to wrap to 3.
  expectTextRejected(".obj", kObjVertices + "f 1 2 4294967299\n",
                     {"line 4", "'4294967299'", "out of range", "3 vertices"});
  expectTextRejected(".obj", kObjVertices + "f 1 2 7\n", {"line 4", "'7'", "out of range"});
  expectTextRejected(".obj", kObjVertices + "f 1 2 2.5\n", {"line 4", "'2.5'", "not an integer"});
  expectTextRejected(".obj", kObjVertices + "f 1 2 3abc\n", {"line 4", "'3abc'", "not an integer"});
  expectTextRejected(".obj", kObjVertices + "f 1 2 1e30\n", {"line 4", "'1e30'", "not an integer"});
  expectTextRejected(".obj", kObjVertices + "f 1 2 99999999999999999999\n",
                     {"line 4", "'99999999999999999999'", "too large"});
  expectTextRejected(".obj", kObjVertices + "f 1 2 -4\n", {"line 4", "'-4'", "counts back 4"});
  expectTextRejected(".obj", kObjVertices + "f 1 2 -9223372036854775807\n", {"line 4", "counts back"});
  expectTextRejected(".obj", kObjVertices + "f 0 1 2\n", {"line 4", "'0'", "start at 1"});
  expectTextRejected(".obj", kObjVertices + "f 1/1 2/2 x/3\n", {"line 4", "'x/3'", "not an integer"});
  expectTextRejected(".obj", kObjVertices + "f 1 2 /3\n", {"line 4", "'/3'"});
  // A forward reference that is never defined is reported at its own line.
  expectTextRejected(".obj", "f 1 2 3\n" + kObjVertices + "f 1 2 5\n", {"line 5", "'5'", "out of range"});
}

TEST(SurfaceReaderObj, VertexCoordinatesAreChecked) {
  expectTextRejected(".obj", "v 0 0 0\nv 1 0 1e999\nv 0 1 0\nf 1 2 3\n",
                     {"line 2", "coordinate z", "'1e999'", "overflows"});
  expectTextRejected(".obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", {"line 2", "'nan'", "not finite"});
  expectTextRejected(".obj", "v 0 0 0\nv 1 0 0\nv 0 -inf 0\nf 1 2 3\n", {"line 3", "'-inf'", "not finite"});
  expectTextRejected(".obj", "v 0 0 0\nv 1 0 0\nv 0 1abc 0\nf 1 2 3\n", {"line 3", "'1abc'", "not a number"});
  expectTextRejected(".obj", "v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", {"line 2", "three coordinates"});
}

TEST(SurfaceReaderObj, SlashFormsRelativeAndForwardIndicesStillWork) {
  const std::string plain = tempPath(".obj"), forms = tempPath(".obj"), forward = tempPath(".obj");
  const std::string tetra = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n";
  writeText(plain, tetra + "f 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n");
  writeText(forms, tetra + "vt 0 0\nvn 0 0 1\nf 1/1/1 3//1 2/1\nf -4 -3 -1\nf 2/1/1 -2//1 4\nf -2 1 4\n");
  writeText(forward, "f 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n" + tetra);
  const TriSurface a = readSurface(plain), b = readSurface(forms), c = readSurface(forward);
  EXPECT_EQ(a.faces, b.faces);
  EXPECT_EQ(a.faces, c.faces);
  EXPECT_EQ(a.vertices, b.vertices);
  // Tiny coordinates that underflow are finite: accepted.
  const std::string tiny = tempPath(".obj");
  writeText(tiny, "v 0 0 1e-400\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_EQ(readSurface(tiny).faces.size(), 1u);
}

const std::string kOffHead = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n";  // the face is on line 6

TEST(SurfaceReaderOff, FaceIndicesAreCheckedNotWrapped) {
  expectTextRejected(".off", kOffHead + "3 0 1 4294967299\n",
                     {"line 6", "face 0", "'4294967299'", "out of range", "indices 0 to 2"});
  expectTextRejected(".off", kOffHead + "3 0 1 3\n", {"line 6", "'3'", "out of range"});
  expectTextRejected(".off", kOffHead + "3 0 1 -1\n", {"line 6", "'-1'", "out of range"});
  expectTextRejected(".off", kOffHead + "3 0 1 2.5\n", {"line 6", "'2.5'", "not an integer"});
  expectTextRejected(".off", kOffHead + "3 0 1 3abc\n", {"line 6", "'3abc'", "not an integer"});
  expectTextRejected(".off", kOffHead + "3 0 1 1e30\n", {"line 6", "'1e30'", "not an integer"});
  expectTextRejected(".off", kOffHead + "3 0 1 99999999999999999999\n", {"line 6", "too large"});
  expectTextRejected(".off", kOffHead + "3.0 0 1 2\n", {"line 6", "corner count", "'3.0'"});
  expectTextRejected(".off", kOffHead + "3 0 1\n", {"line 6", "ends after 2 of its 3"});
  expectTextRejected(".off", kOffHead + "# comment\n\n3 0 1 9 # trailing\n", {"line 8", "'9'"});
}

TEST(SurfaceReaderOff, CoordinatesAndHeaderCountsAreChecked) {
  expectTextRejected(".off", "OFF\n3 1 0\n0 0 0\n1 0 1e999\n0 1 0\n3 0 1 2\n",
                     {"line 4", "vertex 1", "coordinate z", "'1e999'", "overflows"});
  expectTextRejected(".off", "OFF\n3 1 0\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n", {"line 4", "'nan'", "not finite"});
  expectTextRejected(".off", "OFF\n1e18 1 0\n", {"line 2", "vertex count", "'1e18'", "not an integer"});
  expectTextRejected(".off", "OFF\n3 -1 0\n", {"line 2", "face count", "negative"});
  expectTextRejected(".off", "OFF\n1000000000000000000 1 0\n0 0 0\n", {"line 2", "more than the file"});
  expectTextRejected(".off", "OFF\n3 2000000000 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", {"more than the file"});
}

const std::string kPlyAsciiHead =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
    "element face 1\nproperty list uchar int vertex_indices\nend_header\n"  // 9 header lines
    "0 0 0\n1 0 0\n0 1 0\n";                                                // lines 10-12; the face is on line 13

TEST(SurfaceReaderPly, AsciiIndicesAndCoordinatesAreChecked) {
  expectTextRejected(".ply", kPlyAsciiHead + "3 0 1 4294967299\n",
                     {"line 13", "face 0", "'4294967299'", "does not fit PLY type int"});
  expectTextRejected(".ply", kPlyAsciiHead + "3 0 1 3\n", {"line 13", "face 0", "'3'", "out of range"});
  expectTextRejected(".ply", kPlyAsciiHead + "3 0 1 -1\n", {"line 13", "'-1'", "out of range"});
  expectTextRejected(".ply", kPlyAsciiHead + "3 0 1 2.5\n", {"line 13", "'2.5'", "not an integer"});
  expectTextRejected(".ply", kPlyAsciiHead + "3 0 1 3abc\n", {"line 13", "'3abc'", "not an integer"});
  expectTextRejected(".ply", kPlyAsciiHead + "3 0 1 99999999999999999999\n", {"line 13", "too large"});
  expectTextRejected(".ply", kPlyAsciiHead + "300 0 1 2\n", {"line 13", "'300'", "does not fit PLY type uchar"});
  expectTextRejected(".ply", kPlyAsciiHead + "3 0 1\n", {"face 0", "ends early"});
  std::string bad = kPlyAsciiHead;
  bad.replace(bad.find("1 0 0\n"), 6, "1 0 1e999\n");
  expectTextRejected(".ply", bad + "3 0 1 2\n", {"line 11", "vertex 1", "'1e999'", "overflows"});
  bad = kPlyAsciiHead;
  bad.replace(bad.find("0 1 0\n"), 6, "0 nan 0\n");
  expectTextRejected(".ply", bad + "3 0 1 2\n", {"line 12", "vertex 2", "coordinate y", "'nan'", "not finite"});
}

TEST(SurfaceReaderPly, HeaderCountsAreCheckedAgainstTheData) {
  const std::string head = "ply\nformat ascii 1.0\n";
  expectTextRejected(".ply", head + "element vertex 1e18\nproperty float x\nend_header\n",
                     {"line 3", "'1e18'", "not an integer"});
  expectTextRejected(".ply", head + "element junk 1000000000000000000\nend_header\n",
                     {"line 3", "1000000000000000000", "at most 2147483647"});
  expectTextRejected(".ply",
                     head +
                         "element vertex 2000000000\nproperty float x\nproperty float y\n"
                         "property float z\nend_header\n0 0 0\n",
                     {"line 3", "'vertex' declares 2000000000 entries", "more than the remaining"});
  // An element without properties carries no data: skipped at once.
  const std::string p = tempPath(".ply");
  std::string text = kPlyAsciiHead + "3 0 1 2\n";
  text.insert(text.find("end_header"), "element nothing 2000000000\n");
  writeText(p, text);
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(readSurface(p).faces.size(), 1u);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 2.0);
}

// Binary little-endian PLY: 3 double vertices, faces as uchar count + `indexType` indices.
std::string binaryPly(const double (*v)[3], int nv, const std::string& indexType, const std::string& faceBytes, int nf,
                      long long declaredFaces = -1) {
  std::string b = "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(nv) +
                  "\nproperty double x\nproperty double y\nproperty double z\nelement face " +
                  std::to_string(declaredFaces < 0 ? nf : declaredFaces) + "\nproperty list uchar " + indexType +
                  " vertex_indices\nend_header\n";
  b.append(reinterpret_cast<const char*>(v), sizeof(double) * 3 * nv);
  return b + faceBytes;
}

template <class T>
std::string face3(T a, T b, T c) {
  std::string s(1, '\x03');
  for (T x : {a, b, c}) s.append(reinterpret_cast<const char*>(&x), sizeof(T));
  return s;
}

const double kTri[3][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};

TEST(SurfaceReaderPly, BinaryIndicesAndCoordinatesAreChecked) {
  const std::uint32_t big = 4294967295u;
  expectTextRejected(".ply",
                     binaryPly(kTri, 3, "uint", face3<std::uint32_t>(0, 1, 2) + face3<std::uint32_t>(0, 1, big), 2),
                     {"face 1 (binary data)", "'4294967295'", "out of range", "indices 0 to 2"});
  expectTextRejected(".ply", binaryPly(kTri, 3, "int", face3<std::int32_t>(0, -1, 2), 1),
                     {"face 0 (binary data)", "'-1'", "out of range"});
  expectTextRejected(".ply", binaryPly(kTri, 3, "float", face3<float>(0, 1, 2.5f), 1),
                     {"face 0 (binary data)", "'2.5'", "not an integer"});
  double nanTri[3][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  nanTri[2][0] = std::numeric_limits<double>::quiet_NaN();
  expectTextRejected(".ply", binaryPly(nanTri, 3, "int", face3<std::int32_t>(0, 1, 2), 1),
                     {"vertex 2 (binary data)", "coordinate x", "not finite"});
  nanTri[2][0] = std::numeric_limits<double>::infinity();
  expectTextRejected(".ply", binaryPly(nanTri, 3, "int", face3<std::int32_t>(0, 1, 2), 1),
                     {"vertex 2 (binary data)", "'inf'", "not finite"});
  // Declared counts beyond the data: rejected from the header, before reading.
  expectTextRejected(".ply", binaryPly(kTri, 3, "int", face3<std::int32_t>(0, 1, 2), 1, 1000000000),
                     {"line 7", "'face' declares 1000000000 entries", "more than the remaining"});
  expectTextRejected(".ply", binaryPly(kTri, 3, "int", face3<std::int32_t>(0, 1, 2).substr(0, 9), 1),
                     {"face 0", "ends early"});
  // The well-formed file is accepted.
  const std::string p = tempPath(".ply");
  writeText(p, binaryPly(kTri, 3, "uint", face3<std::uint32_t>(0, 1, 2), 1));
  EXPECT_EQ(readSurface(p).faces.size(), 1u);
}

TEST(SurfaceReader, DeformedCopiesGetTheSameChecks) {
  const std::string rest = tempPath(".obj"), copy = tempPath(".obj");
  writeText(rest, kObjVertices + "f 1 2 3\n");
  std::vector<char> flips;
  const TriSurface s = validateSurface(readPolygonFile(rest), rest, &flips);
  writeText(copy, kObjVertices + "f 1 2 4294967299\n");
  try {
    readDeformedCopy(copy, s, flips);
    ADD_FAILURE() << "accepted " << copy;
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(copy + ": line 4"), std::string::npos) << m;
    EXPECT_NE(m.find("'4294967299'"), std::string::npos) << m;
  }
}

}  // namespace
}  // namespace rodmesh::meshing
