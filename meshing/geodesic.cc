// CGAL translation unit: exact geodesics with Surface_mesh_shortest_path.
#include "meshing/geodesic.hh"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_shortest_path.h>

#include <algorithm>
#include <array>
#include <functional>
#include <map>
#include <numeric>
#include <unordered_map>

namespace rodmesh::meshing {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
using Traits = CGAL::Surface_mesh_shortest_path_traits<Kernel, Mesh>;
using ShortestPath = CGAL::Surface_mesh_shortest_path<Traits>;

}  // namespace

std::vector<Vec3> shortestGeodesic(const TriSurface& s, const std::vector<int>& faces, const SurfacePoint& a,
                                   const SurfacePoint& b) {
  // Local copies of the vertices, one per (vertex, fan of subset faces).
  std::unordered_map<int, std::vector<int>> vfaces;  // input vertex -> positions in `faces`
  for (int k = 0; k < static_cast<int>(faces.size()); ++k)
    for (int v : s.faces[faces[k]]) vfaces[v].push_back(k);
  std::vector<std::array<int, 3>> local(faces.size());
  std::vector<Point> points;
  for (auto& [v, fs] : vfaces) {
    std::vector<int> comp(fs.size());
    std::iota(comp.begin(), comp.end(), 0);
    std::function<int(int)> find = [&](int x) { return comp[x] == x ? x : comp[x] = find(comp[x]); };
    std::map<int, int> otherToLocal;
    for (int i = 0; i < static_cast<int>(fs.size()); ++i)
      for (int w : s.faces[faces[fs[i]]]) {
        if (w == v) continue;
        auto [it, fresh] = otherToLocal.emplace(w, i);
        if (!fresh) comp[find(i)] = find(it->second);
      }
    std::map<int, int> fanVertex;
    for (int i = 0; i < static_cast<int>(fs.size()); ++i) {
      const int root = find(i);
      auto it = fanVertex.find(root);
      if (it == fanVertex.end()) {
        const Vec3& p = s.vertices[v];
        points.emplace_back(p.x(), p.y(), p.z());
        it = fanVertex.emplace(root, static_cast<int>(points.size()) - 1).first;
      }
      const auto& tri = s.faces[faces[fs[i]]];
      for (int c = 0; c < 3; ++c)
        if (tri[c] == v) local[fs[i]][c] = it->second;
    }
  }
  std::vector<std::vector<std::size_t>> polygons;
  polygons.reserve(faces.size());
  for (const auto& t : local) polygons.push_back({std::size_t(t[0]), std::size_t(t[1]), std::size_t(t[2])});
  Mesh mesh;
  CGAL::Polygon_mesh_processing::polygon_soup_to_polygon_mesh(points, polygons, mesh);
  // Map CGAL faces back to subset faces through their (unique) corner triples.
  std::map<std::array<int, 3>, int> byTriple;
  for (int k = 0; k < static_cast<int>(local.size()); ++k) {
    auto key = local[k];
    std::sort(key.begin(), key.end());
    byTriple[key] = k;
  }
  std::unordered_map<int, Mesh::Face_index> cgalFace;  // input face -> CGAL face
  for (Mesh::Face_index f : mesh.faces()) {
    std::array<int, 3> key;
    int i = 0;
    for (auto v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) key[i++] = static_cast<int>(v);
    std::sort(key.begin(), key.end());
    auto it = byTriple.find(key);
    if (it != byTriple.end()) cgalFace[faces[it->second]] = f;
  }
  auto location = [&](const SurfacePoint& p, Mesh::Face_index& f, ShortestPath::Barycentric_coordinates& bc) {
    auto it = cgalFace.find(p.face);
    if (it == cgalFace.end()) return false;
    f = it->second;
    int k = std::find(faces.begin(), faces.end(), p.face) - faces.begin();
    const Vec3 bary = p.bary / p.bary.sum();
    int i = 0;
    std::array<double, 3> c{};
    for (auto h : CGAL::halfedges_around_face(mesh.halfedge(f), mesh)) {
      const int v = static_cast<int>(mesh.source(h));
      for (int j = 0; j < 3; ++j)
        if (local[k][j] == v) c[i] = bary[j];
      ++i;
    }
    bc = {c[0], c[1], c[2]};
    return true;
  };
  Mesh::Face_index fa, fb;
  ShortestPath::Barycentric_coordinates ba, bb;
  if (!location(a, fa, ba) || !location(b, fb, bb)) return {};
  ShortestPath sp(mesh);
  sp.add_source_point(fa, ba);
  std::vector<Point> out;
  auto result = sp.shortest_path_points_to_source_points(fb, bb, std::back_inserter(out));
  if (result.first < 0 || out.empty()) return {};
  std::vector<Vec3> path;
  for (const Point& p : out) {
    Vec3 q(p.x(), p.y(), p.z());
    if (path.empty() || (q - path.back()).norm() > 1e-14) path.push_back(q);
  }
  const Vec3 pa = evalPoint(s, a), pb = evalPoint(s, b);
  if ((path.front() - pa).norm() > (path.front() - pb).norm()) std::reverse(path.begin(), path.end());
  if (path.size() < 2) return {pa, pb};
  path.front() = pa;
  path.back() = pb;
  return path;
}

}  // namespace rodmesh::meshing
