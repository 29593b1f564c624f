// Printable solids from rod meshes.
//
// Each rod edge is swept with its elliptical cross-section: semi-axis r_t
// along d1 (in the surface's tangent plane) and r_n along d2 (along the
// reference normal), linearly interpolated between the edge's end vertices,
// with ellipsoidal caps of length max(r_t, r_n) at both ends so that
// consecutive edges of a rod join without notches at bends.
//
// The solid is the zero sublevel set of an implicit function: per rod, the
// minimum over its edges of a metric-scaled ellipse "distance"
// g = (q - 1) min(r_t, r_n), q the normalised elliptic radius; across rods, a
// polynomial smooth minimum with blend radius `fillet` (Quilez), which adds
// fillets where rods meet at connections, i.e. "joined smoothly".
//
// The function is sampled on a regular grid, block by block (only near rods),
// and contoured by marching tetrahedra on the Kuhn (Freudenthal) split of
// every cube. That contour is closed, 2-manifold and free of
// self-intersections by construction: every tetrahedron holds one planar
// piece (triangle) or a two-triangle quad, pieces meet exactly on shared
// tetrahedron faces, and crossing points are kept strictly inside grid edges.
// checkSolid (CGAL) verifies all of this on the final coordinates anyway.
#pragma once

#include "meshing/surface.hh"
#include "model/scene.hh"

#include <Eigen/Geometry>

#include <string>
#include <vector>

namespace rodmesh::meshing {

struct IndexedMesh {
  std::vector<Vec3> vertices;
  std::vector<Tri> faces;
};

// One rod edge to sweep: centreline p0 -> p1, cross-section axes d1 (r_t) and
// d2 (r_n) perpendicular to p1 - p0, radii [r_t, r_n] at p0 and at p1.
struct SweepEdge {
  Vec3 p0, p1, d1, d2;
  Vec2 r0, r1;
  int rod = 0;
};

struct SolidOptions {
  double resolution = 0.0;  // grid spacing [m], at most 1 m; 0: max(min radius / 2.5, median minor radius / 4)
  double fillet = -1.0;     // blend radius [m], at most 1 m; < 0: half the median minor radius; 0: sharp union
  // Limits on the work, estimated before anything grid-sized is allocated. An
  // explicit `resolution` beyond them is refused (InputError suggesting a
  // coarser step); the default one is coarsened to fit. 5e6 triangles take
  // about 3 GB of memory while contouring (and a 250 MB binary STL).
  double maxTriangles = 5e6;       // estimated output triangles (~9 per h^2 of rod surface)
  double maxActivePoints = 2.5e8;  // grid samples in the band around the rods
  double maxBlocks = 1e6;          // 40^3-cell blocks of the bounding grid
};

// Throws InputError naming --resolution or --fillet for values out of range
// (NaN and infinities included).
void validateOptions(const SolidOptions& o);

// Estimated work of sweepRods at one grid step.
struct SolidWork {
  double triangles = 0, samples = 0, blocks = 0;
  bool within(const SolidOptions& o) const {
    return triangles <= o.maxTriangles && samples <= o.maxActivePoints && blocks <= o.maxBlocks;
  }
};

struct SolidReport {
  double resolution = 0.0, fillet = 0.0;
  SolidWork work;          // estimate at the step used
  bool coarsened = false;  // the default step was coarsened to stay within the limits
  long long sampledPoints = 0;
  double seconds = 0.0;
};

// Throws InputError for invalid options, non-finite or non-positive edge data,
// or an explicit resolution whose estimated work exceeds the limits.
IndexedMesh sweepRods(const std::vector<SweepEdge>& edges, const SolidOptions& opt, SolidReport* report = nullptr);

// Result of the CGAL checks on a triangle mesh.
struct SolidCheck {
  bool polygonMesh = false;       // the triangle soup is a manifold, orientable polygon mesh
  bool closed = false;            // no border edges
  bool selfIntersecting = true;
  bool outward = false;           // outward oriented
  int degenerateFaces = 0;
  int components = 0;
  double volume = 0.0;            // m^3
  Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();
  bool ok() const {
    return polygonMesh && closed && !selfIntersecting && outward && degenerateFaces == 0 && components == 1 &&
           volume > 0;
  }
  std::string problems() const;  // empty when ok()
};

SolidCheck checkSolid(const IndexedMesh& mesh);

// Rounds coordinates to single precision (what STL stores), so that checks
// run on exactly the coordinates that get written.
void roundToFloat(IndexedMesh& mesh);

// Writes .stl (binary), .obj or .ply (binary little endian) by extension,
// atomically (temporary file in the same directory, then rename). Throws
// InputError for an unsupported extension, std::runtime_error on I/O errors.
void writeMeshFile(const IndexedMesh& mesh, const std::string& path);
// Throws InputError unless the extension is .stl, .obj or .ply.
void checkMeshExtension(const std::string& path);

}  // namespace rodmesh::meshing
