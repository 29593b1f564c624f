// Hexagon-dominant layouts from a centroidal Voronoi tessellation (CVT) of a
// surface (paper §4.1; Valette and Chassery 2004 approximate the CVT by
// clustering the elements of a fine mesh, which is what we do).
//
// 1. The input surface is refined by longest-edge bisection (geometry
//    unchanged) until its edges are about a fifth of the expected cell radius,
//    so that every cell holds dozens of mesh vertices.
// 2. Seeds: farthest-point sampling in the metric ds' = density^(1/4) ds, so
//    cell diameters scale as density^(-1/4), the CVT's own law in 2-D.
// 3. Lloyd iterations: each refined-mesh vertex joins its nearest seed
//    (multi-source Dijkstra along mesh edges, an approximation of geodesic
//    distance); each seed moves to the mesh vertex of its cell nearest the
//    cell's density-weighted centroid. Stops when no seed moves.
// 4. Voronoi graph: where three cells meet inside a refined triangle there is
//    a Voronoi vertex (a connection), placed at the point of the triangle
//    equidistant from the three seeds; the chains of cell-boundary crossings
//    between two such points are Voronoi edges (links).
// 5. Open surfaces: cell boundaries that reach the surface boundary end in a
//    boundary node. With BoundaryMode::Rim (default) the surface boundary
//    between consecutive boundary nodes becomes a rim link, so every cell is a
//    closed polygon and the rod mesh has a continuous rim (like a hat brim).
//    With BoundaryMode::Free the boundary nodes are free rod ends.
// 6. Voronoi edges shorter than `mergeFraction` times the median are
//    contracted (a near-degenerate four-cell junction becomes one valence-4
//    connection instead of two connections joined by a stub rod).
#pragma once

#include "meshing/layout.hh"
#include "meshing/surface.hh"

#include <vector>

namespace rodmesh::meshing {

enum class BoundaryMode { Rim, Free };

struct CvtOptions {
  int cells = 64;                // number of Voronoi cells (seeds)
  int maxIterations = 200;       // Lloyd iterations (stops earlier when converged)
  int restarts = 3;              // Lloyd runs from different farthest-point starts; lowest energy wins
  double tolerance = 1e-3;       // converged when no seed moves more than this x cell radius
  double mergeFraction = 0.15;   // contract Voronoi edges shorter than this x median
  int maxWorkFaces = 400000;     // cap on the refined mesh size
  double refinement = 6;         // refined-mesh edges per expected cell radius
  BoundaryMode boundary = BoundaryMode::Rim;
};

struct CvtReport {
  int workVertices = 0, workFaces = 0;
  int iterations = 0;
  bool converged = false;
  int mergedLinks = 0;
};

// `density`: empty, or one positive value per input surface vertex.
// Throws InputError for impossible requests (cells < 2, more cells than
// refined vertices).
Layout cvtLayout(const TriSurface& surface, const SurfaceTopology& topo, const CvtOptions& opt,
                 const std::vector<double>& density, CvtReport* report = nullptr);

}  // namespace rodmesh::meshing
