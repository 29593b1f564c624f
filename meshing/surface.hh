// Triangle surfaces: reading OBJ/OFF/PLY, validation, topology and point
// location. No CGAL here (see meshing/geodesic.cc and friends for that).
//
// A TriSurface is an indexed triangle mesh in metres. A SurfacePoint names a
// point on it by a face index and barycentric coordinates relative to that
// face's three corners, in the order they are listed in `faces`. Rod vertices
// keep their SurfacePoint so that the same point can be found on a deformed
// copy with the same connectivity (paper §5, "we store a mapping to its
// projection triangle").
#pragma once

#include "model/scene.hh"

#include <Eigen/Geometry>

#include <array>
#include <string>
#include <vector>

namespace rodmesh::meshing {

using Tri = std::array<int, 3>;

struct TriSurface {
  std::vector<Vec3> vertices;
  std::vector<Tri> faces;
  std::string sourcePath;  // for messages
};

struct SurfacePoint {
  int face = -1;
  Vec3 bary = Vec3(1.0 / 3, 1.0 / 3, 1.0 / 3);
};

// Vertex coordinates of an input file must lie within +-kMaxSurfaceCoordinate
// (any unit: --scale applies afterwards), so that lengths, areas and their
// squares stay far from overflow.
constexpr double kMaxSurfaceCoordinate = 1e15;

// Reads an .obj, .off or .ply file (ASCII; PLY also binary) without checking
// it beyond syntax. Every number is parsed strictly (the whole token; reals
// finite and within kMaxSurfaceCoordinate, integers without overflow) and
// every face index is checked against the vertex count (OBJ: 1-based, negative
// counts back from the last vertex defined so far; OFF and PLY: 0-based);
// declared OFF/PLY counts are checked against the file size before reading.
// Throws InputError (io/scene_reader.hh) naming the file, the line (binary PLY:
// the element entry) and the offending text. Faces with other than three
// corners are kept as they are read, so that validateSurface can reject them
// clearly.
struct PolygonSoup {
  std::vector<Vec3> vertices;
  std::vector<std::vector<int>> faces;
};
PolygonSoup readPolygonFile(const std::string& path);

// The same for the contents `data` of a file in `format` ("obj", "off" or
// "ply"); `path` names the file in messages.
PolygonSoup parsePolygonText(const std::string& data, const std::string& format, const std::string& path);

// Checks a polygon soup and turns it into a TriSurface. Rejects, with an
// InputError naming the file and the face/edge/vertex: no faces, non-finite
// coordinates, non-triangle faces, out-of-range indices, degenerate (repeated
// corner or zero-area) faces, duplicate faces, edges shared by more than two
// faces, vertices whose faces form several fans (non-manifold vertices), and
// non-orientable surfaces. Inconsistently oriented faces are flipped to agree
// with the first face of their connected component (the flips are returned in
// `flipped` so deformed copies can be treated identically).
TriSurface validateSurface(const PolygonSoup& soup, const std::string& path,
                           std::vector<char>* flipped = nullptr);

// readPolygonFile + validateSurface.
TriSurface readSurface(const std::string& path);

// A deformed copy of `rest`: same vertex count and the same faces (as read, in
// the same order). Throws InputError otherwise. Applies the rest surface's
// orientation flips.
TriSurface readDeformedCopy(const std::string& path, const TriSurface& rest,
                            const std::vector<char>& restFlips);

// Point at a surface location; works on any surface with rest's connectivity.
Vec3 evalPoint(const TriSurface& s, const SurfacePoint& p);

// Angle-weighted unit vertex normals (zero vector for unused vertices).
std::vector<Vec3> vertexNormals(const TriSurface& s);
// Unit normal at a location: interpolated vertex normals, renormalised.
Vec3 evalNormal(const TriSurface& s, const std::vector<Vec3>& vnormals, const SurfacePoint& p);

double faceArea(const TriSurface& s, int f);
double surfaceArea(const TriSurface& s);
// Length of the bounding box diagonal.
double bboxDiagonal(const TriSurface& s);

// Closest point on triangle (a, b, c) to p; returns barycentric coordinates.
Vec3 closestPointBary(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);

// Closest point on the surface (brute force over `faceSubset`, or all faces if
// empty). Returns the location; `dist` receives the distance.
SurfacePoint closestPoint(const TriSurface& s, const Vec3& p, const std::vector<int>& faceSubset,
                          double* dist = nullptr);

// Edge/face adjacency of a validated surface.
struct SurfaceTopology {
  explicit SurfaceTopology(const TriSurface& s);
  // For face f and corner i, the face across edge (faces[f][i], faces[f][(i+1)%3]), or -1.
  std::vector<std::array<int, 3>> faceNeighbours;
  std::vector<std::vector<int>> vertexFaces;
  std::vector<std::vector<int>> vertexNeighbours;
  // Boundary loops as closed vertex cycles following the face orientation.
  std::vector<std::vector<int>> boundaryLoops;
  std::vector<char> isBoundaryVertex;
};

}  // namespace rodmesh::meshing
