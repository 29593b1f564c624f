// CGAL translation unit: edge-collapse simplification for the dual route.
#include "meshing/simplify.hh"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>

#include <cmath>
#include <unordered_map>

namespace rodmesh::meshing {
namespace {
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
namespace SMS = CGAL::Surface_mesh_simplification;
}  // namespace

TriSurface decimate(const TriSurface& s, int targetFaces) {
  Mesh mesh;
  std::vector<Mesh::Vertex_index> vid(s.vertices.size());
  std::vector<char> used(s.vertices.size(), 0);
  for (const Tri& t : s.faces)
    for (int v : t) used[v] = 1;
  for (std::size_t i = 0; i < s.vertices.size(); ++i)
    if (used[i]) vid[i] = mesh.add_vertex(Point(s.vertices[i].x(), s.vertices[i].y(), s.vertices[i].z()));
  for (const Tri& t : s.faces) mesh.add_face(vid[t[0]], vid[t[1]], vid[t[2]]);
  std::size_t boundary = 0;
  for (auto h : mesh.halfedges())
    if (mesh.is_border(h)) ++boundary;
  // Boundary edges shrink like sqrt(F) when the surface is decimated.
  const double ratio = static_cast<double>(targetFaces) / std::max<std::size_t>(1, mesh.number_of_faces());
  const double coarseBoundary = boundary * std::sqrt(std::min(1.0, ratio));
  const std::size_t targetEdges = static_cast<std::size_t>(std::lround((3.0 * targetFaces + coarseBoundary) / 2));
  SMS::Count_stop_predicate<Mesh> stop(targetEdges);
  SMS::edge_collapse(mesh, stop);
  mesh.collect_garbage();
  TriSurface out;
  out.sourcePath = s.sourcePath;
  for (auto v : mesh.vertices()) {
    const Point& p = mesh.point(v);
    out.vertices.emplace_back(p.x(), p.y(), p.z());
  }
  for (auto f : mesh.faces()) {
    Tri t;
    int i = 0;
    for (auto v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) t[i++] = static_cast<int>(v);
    out.faces.push_back(t);
  }
  return out;
}

}  // namespace rodmesh::meshing
