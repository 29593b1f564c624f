// CGAL translation unit: printability checks of a triangle mesh.
#include "meshing/solid.hh"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/shape_predicates.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/helpers.h>

namespace rodmesh::meshing {
namespace {
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
namespace PMP = CGAL::Polygon_mesh_processing;
}  // namespace

SolidCheck checkSolid(const IndexedMesh& m) {
  SolidCheck c;
  if (m.faces.empty()) return c;
  std::vector<Point> points;
  points.reserve(m.vertices.size());
  for (const Vec3& v : m.vertices) points.emplace_back(v.x(), v.y(), v.z());
  std::vector<std::vector<std::size_t>> polygons;
  polygons.reserve(m.faces.size());
  for (const Tri& t : m.faces) polygons.push_back({std::size_t(t[0]), std::size_t(t[1]), std::size_t(t[2])});
  c.polygonMesh = PMP::is_polygon_soup_a_polygon_mesh(polygons);
  if (!c.polygonMesh) return c;
  Mesh mesh;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, mesh);
  c.closed = CGAL::is_closed(mesh);
  for (auto f : mesh.faces())
    if (PMP::is_degenerate_triangle_face(f, mesh)) ++c.degenerateFaces;
  c.selfIntersecting = PMP::does_self_intersect(mesh);
  auto fcc = mesh.add_property_map<Mesh::Face_index, std::size_t>("f:cc", 0).first;
  c.components = static_cast<int>(PMP::connected_components(mesh, fcc));
  if (c.closed) {
    c.volume = PMP::volume(mesh);
    c.outward = PMP::is_outward_oriented(mesh);
  }
  c.lo = Vec3::Constant(1e300);
  c.hi = Vec3::Constant(-1e300);
  for (const Vec3& v : m.vertices) {
    c.lo = c.lo.cwiseMin(v);
    c.hi = c.hi.cwiseMax(v);
  }
  return c;
}

}  // namespace rodmesh::meshing
