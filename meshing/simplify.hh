// Edge-collapse decimation (CGAL Surface_mesh_simplification, Lindstrom-Turk
// cost and placement). CGAL-free header; implementation in simplify.cc.
#pragma once

#include "meshing/surface.hh"

namespace rodmesh::meshing {

// Decimates `s` to about `targetFaces` triangles. CGAL 5.5 has no face-count
// stop predicate, so we stop on the edge count E = (3F + B) / 2 (B: boundary
// edges, estimated from the input's boundary length ratio).
TriSurface decimate(const TriSurface& s, int targetFaces);

}  // namespace rodmesh::meshing
