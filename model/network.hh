// RodNetwork: the topology and rest geometry of a rod mesh, derived once from a
// Scene (docs/formats.md §1).
//
// Vertices are scene vertices. Edges are numbered rod by rod, each oriented
// along its rod's vertex order (edge e goes from edges[e].a to edges[e].b).
// A vertex ending two or more rods is a connection; a vertex inside a rod is an
// interior vertex with an incoming and an outgoing edge.
//
// Reference normals (one unit vector per vertex) orient the cross sections:
// r_n lies along the normal, r_t in the tangent plane. They come from the scene
// ("normals"), else from the rod-level "normal", else are derived from the
// geometry (best-fit plane of a connection's incident edges, the scene's plane,
// the rod's plane, or a deterministic perpendicular of a straight rod). Their
// sign is irrelevant to the physics (elliptic sections are symmetric).
#pragma once

#include "model/scene.hh"

#include <string>
#include <vector>

namespace rodmesh {

struct Edge {
  int a = -1, b = -1;  // from a to b, along the rod
  int rod = -1;
};

// A vertex inside a rod: bending and twist act between its two edges.
struct InteriorVertex {
  int vertex = -1;
  int edgeIn = -1;   // edge ending at vertex
  int edgeOut = -1;  // edge starting at vertex
};

// A vertex that ends two or more rods.
struct Connection {
  int vertex = -1;
  std::vector<int> edges;  // incident edges
};

// Orthonormal rest frame of an edge: tangent t, director d1 (tangent plane,
// the r_t axis) and d2 (along the reference normal, the r_n axis); t x d1 = d2.
struct EdgeFrame {
  Vec3 t, d1, d2;
};

class RodNetwork {
 public:
  explicit RodNetwork(const Scene& scene);

  int numVertices() const { return static_cast<int>(vertexNormals_.size()); }
  int numEdges() const { return static_cast<int>(edges_.size()); }
  int numRods() const { return static_cast<int>(rodEdges_.size()); }
  int numConnections() const { return static_cast<int>(connections_.size()); }

  const std::vector<Edge>& edges() const { return edges_; }
  const std::vector<std::vector<int>>& rodEdges() const { return rodEdges_; }
  const std::vector<InteriorVertex>& interiorVertices() const { return interior_; }
  const std::vector<Connection>& connections() const { return connections_; }
  // Edges incident to each vertex.
  const std::vector<std::vector<int>>& vertexEdges() const { return vertexEdges_; }

  // Unit reference normal per vertex, and per edge (normalised sum of the
  // endpoint normals, signs aligned).
  const std::vector<Vec3>& vertexNormals() const { return vertexNormals_; }
  const std::vector<Vec3>& edgeNormals() const { return edgeNormals_; }
  // Where the normals came from ("scene", "derived"), for reports.
  const std::string& normalSource() const { return normalSource_; }

  // Rest frame of edge e for the given rest positions (V x 3 as a list).
  EdgeFrame restFrame(int e, const std::vector<Vec3>& restPositions) const;

 private:
  std::vector<Edge> edges_;
  std::vector<std::vector<int>> rodEdges_;
  std::vector<InteriorVertex> interior_;
  std::vector<Connection> connections_;
  std::vector<std::vector<int>> vertexEdges_;
  std::vector<Vec3> vertexNormals_;
  std::vector<Vec3> edgeNormals_;
  std::string normalSource_;
};

// Unit tangent-plane frame of an edge vector E with reference normal n:
// d2 = n projected perpendicular to E, d1 = d2 x t. Falls back to a
// deterministic perpendicular when n is (nearly) parallel to E.
EdgeFrame edgeFrameFromNormal(const Vec3& E, const Vec3& n);

}  // namespace rodmesh
