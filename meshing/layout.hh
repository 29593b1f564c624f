// A rod-mesh layout on a surface: connections (nodes) and the links between
// them, before rods are traced and resampled. Both meshing routes (dual of a
// decimated surface, centroidal Voronoi tessellation) produce one.
#pragma once

#include "meshing/surface.hh"

#include <vector>

namespace rodmesh::meshing {

struct LayoutNode {
  SurfacePoint at;
  bool onBoundary = false;  // lies on the surface boundary (rim)
};

enum class LinkPath {
  Geodesic,  // the shortest geodesic between the two nodes
  Given,     // follow `given` (used for rim links along the surface boundary)
};

struct LayoutLink {
  int a = -1, b = -1;  // node indices
  LinkPath path = LinkPath::Geodesic;
  std::vector<SurfacePoint> given;  // a..b inclusive, when path == Given
  // The cells on either side (-1: none). For the dual route, cells are the
  // coarse mesh vertices at the ends of the shared coarse edge.
  int cellA = -1, cellB = -1;
  // A polyline length estimate (metres) used to bound the geodesic search.
  double lengthHint = 0.0;
};

struct Layout {
  std::vector<LayoutNode> nodes;
  std::vector<LayoutLink> links;
  int numCells = 0;
  // Cells whose polygon is open (boundary cells in "free" boundary mode, or
  // dual cells around boundary vertices): excluded from the polygon counts.
  std::vector<char> cellOpen;
  // Cells that touch the surface boundary (their polygon is clipped there).
  std::vector<char> cellOnBoundary;
};

}  // namespace rodmesh::meshing
