#include "model/network.hh"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <cmath>

namespace rodmesh {
namespace {

// Deterministic unit vector perpendicular to d: the coordinate axis least
// aligned with d, orthogonalised.
Vec3 perpendicular(const Vec3& d) {
  Vec3 a = d.normalized();
  int k = 0;
  for (int i = 1; i < 3; ++i)
    if (std::abs(a[i]) < std::abs(a[k])) k = i;
  // Prefer z, then y, then x among (nearly) equally unaligned axes.
  for (int i = 2; i >= 0; --i)
    if (std::abs(a[i]) <= std::abs(a[k]) + 1e-12) { k = i; break; }
  Vec3 axis = Vec3::Unit(k);
  return (axis - axis.dot(a) * a).normalized();
}

// Best-fit plane normal of a set of direction vectors or points (already
// centred). Returns false if the set does not span a plane clearly (collinear).
bool fitPlaneNormal(const std::vector<Vec3>& centred, Vec3& normal) {
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (const Vec3& p : centred) C += p * p.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(C);
  const Eigen::Vector3d ev = es.eigenvalues();  // ascending
  if (!(ev[1] > 1e-6 * ev[2])) return false;     // collinear (or empty)
  normal = es.eigenvectors().col(0).normalized();
  return true;
}

}  // namespace

EdgeFrame edgeFrameFromNormal(const Vec3& E, const Vec3& n) {
  EdgeFrame f;
  f.t = E.normalized();
  Vec3 d2 = n - n.dot(f.t) * f.t;
  if (d2.norm() < 1e-6 * n.norm() || !(n.norm() > 0)) d2 = perpendicular(f.t);
  f.d2 = d2.normalized();
  f.d1 = f.d2.cross(f.t);
  return f;
}

RodNetwork::RodNetwork(const Scene& scene) {
  const int nv = static_cast<int>(scene.vertices.size());
  vertexEdges_.assign(nv, {});
  std::vector<int> endCount(nv, 0);
  for (int r = 0; r < static_cast<int>(scene.rods.size()); ++r) {
    const auto& vs = scene.rods[r].vertices;
    std::vector<int> ids;
    for (std::size_t i = 0; i + 1 < vs.size(); ++i) {
      int e = static_cast<int>(edges_.size());
      edges_.push_back(Edge{vs[i], vs[i + 1], r});
      vertexEdges_[vs[i]].push_back(e);
      vertexEdges_[vs[i + 1]].push_back(e);
      ids.push_back(e);
    }
    for (std::size_t i = 1; i + 1 < vs.size(); ++i) interior_.push_back(InteriorVertex{vs[i], ids[i - 1], ids[i]});
    endCount[vs.front()]++;
    endCount[vs.back()]++;
    rodEdges_.push_back(std::move(ids));
  }
  for (int v = 0; v < nv; ++v)
    if (endCount[v] >= 2) connections_.push_back(Connection{v, vertexEdges_[v]});

  // ---- reference normals ----
  vertexNormals_.assign(nv, Vec3::Zero());
  if (!scene.normals.empty()) {
    vertexNormals_ = scene.normals;
    normalSource_ = "scene";
  } else {
    normalSource_ = "derived";
    std::vector<bool> known(nv, false);
    // 1. Rod-level normals.
    for (std::size_t r = 0; r < scene.rods.size(); ++r)
      if (scene.rods[r].normal)
        for (int v : scene.rods[r].vertices) { vertexNormals_[v] = *scene.rods[r].normal; known[v] = true; }
    // 2. Connections: best-fit plane of the incident edge directions.
    for (const Connection& c : connections_) {
      if (known[c.vertex]) continue;
      std::vector<Vec3> dirs;
      for (int e : c.edges) {
        Vec3 d = (scene.vertices[edges_[e].b] - scene.vertices[edges_[e].a]).normalized();
        dirs.push_back(d);
        dirs.push_back(-d);
      }
      Vec3 n;
      if (fitPlaneNormal(dirs, n)) { vertexNormals_[c.vertex] = n; known[c.vertex] = true; }
    }
    // 3. The scene's own plane, if all vertices are coplanar.
    Vec3 centroid = Vec3::Zero();
    for (const Vec3& p : scene.vertices) centroid += p;
    centroid /= nv;
    std::vector<Vec3> centred;
    double extent = 0;
    for (const Vec3& p : scene.vertices) { centred.push_back(p - centroid); extent = std::max(extent, (p - centroid).norm()); }
    Vec3 sceneNormal;
    bool scenePlanar = false;
    if (fitPlaneNormal(centred, sceneNormal)) {
      double dev = 0;
      for (const Vec3& p : centred) dev = std::max(dev, std::abs(p.dot(sceneNormal)));
      scenePlanar = dev <= 1e-9 * extent;
    }
    // 4. Per rod: endpoints' normals interpolated, else the rod's plane, else
    //    the scene plane, else a deterministic perpendicular.
    for (std::size_t r = 0; r < scene.rods.size(); ++r) {
      const auto& vs = scene.rods[r].vertices;
      Vec3 chord = scene.vertices[vs.back()] - scene.vertices[vs.front()];
      if (chord.norm() <= 0) chord = scene.vertices[vs[1]] - scene.vertices[vs[0]];
      Vec3 rodNormal;
      bool haveRod = false;
      if (scenePlanar) { rodNormal = sceneNormal; haveRod = true; }
      if (!haveRod) {
        Vec3 c = Vec3::Zero();
        for (int v : vs) c += scene.vertices[v];
        c /= static_cast<double>(vs.size());
        std::vector<Vec3> pts;
        for (int v : vs) pts.push_back(scene.vertices[v] - c);
        haveRod = fitPlaneNormal(pts, rodNormal);
      }
      if (!haveRod) rodNormal = perpendicular(chord);
      const int v0 = vs.front(), v1 = vs.back();
      Vec3 n0 = known[v0] ? vertexNormals_[v0] : rodNormal;
      Vec3 n1 = known[v1] ? vertexNormals_[v1] : rodNormal;
      if (n0.dot(n1) < 0) n1 = -n1;
      // Arc-length parameter along the rod for interpolation.
      std::vector<double> s(vs.size(), 0.0);
      for (std::size_t i = 1; i < vs.size(); ++i) s[i] = s[i - 1] + (scene.vertices[vs[i]] - scene.vertices[vs[i - 1]]).norm();
      for (std::size_t i = 0; i < vs.size(); ++i) {
        int v = vs[i];
        if (known[v]) continue;
        double u = s.back() > 0 ? s[i] / s.back() : 0.0;
        Vec3 n = (1 - u) * n0 + u * n1;
        vertexNormals_[v] = n.norm() > 1e-12 ? n.normalized() : rodNormal;
        if (i != 0 && i + 1 != vs.size()) known[v] = true;  // ends may belong to other rods
      }
      if (!known[v0]) { vertexNormals_[v0] = n0; known[v0] = true; }
      if (!known[v1]) { vertexNormals_[v1] = n1; known[v1] = true; }
    }
  }
  edgeNormals_.resize(edges_.size());
  for (std::size_t e = 0; e < edges_.size(); ++e) {
    Vec3 na = vertexNormals_[edges_[e].a], nb = vertexNormals_[edges_[e].b];
    if (na.dot(nb) < 0) nb = -nb;
    Vec3 n = na + nb;
    edgeNormals_[e] = n.norm() > 1e-12 ? n.normalized() : na;
  }
}

EdgeFrame RodNetwork::restFrame(int e, const std::vector<Vec3>& restPositions) const {
  const Edge& ed = edges_[e];
  return edgeFrameFromNormal(restPositions[ed.b] - restPositions[ed.a], edgeNormals_[e]);
}

}  // namespace rodmesh
