// Shortest geodesic paths on a triangle surface (CGAL
// Surface_mesh_shortest_path, the exact algorithm of Xin and Wang 2009).
// This header is CGAL-free; the implementation lives in geodesic.cc.
#pragma once

#include "meshing/surface.hh"

#include <vector>

namespace rodmesh::meshing {

// The shortest path from `a` to `b` over the part of `s` made of the faces in
// `faces` (which must contain a.face and b.face). Vertices where the subset is
// pinched (two fans) are duplicated, so any subset works. Returns the polyline
// from a to b inclusive (consecutive duplicates removed), or an empty vector
// when b cannot be reached from a within the subset.
std::vector<Vec3> shortestGeodesic(const TriSurface& s, const std::vector<int>& faces, const SurfacePoint& a,
                                   const SurfacePoint& b);

}  // namespace rodmesh::meshing
