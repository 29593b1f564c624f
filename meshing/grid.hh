// Generated planar rod sheets: hexagonal (honeycomb), quad and triangle grids
// in the z = 0 plane (paper Fig. 4 and the "Sheet" example of §5 / Table 1).
// CGAL-free, and kept out of the CGAL translation units of meshing/.
//
// Layout. A sheet is a patch of whole cells of a regular lattice; every
// lattice edge is one straight rod with K vertices (K - 1 equal edges), and
// every lattice node is a connection (the end vertex of two or more rods).
// There are no free rod ends and no trimmed stubs: the boundary runs along
// cell sides, so perimeter nodes have valence 2 (two rods meeting at an
// angle; the connection model couples them) or more.
//
//   hex   Regular hexagons, pointy side up, in NY horizontal rows; odd rows
//         are shifted by half a cell. HexRows::Alternate (default): even rows
//         hold NX cells and odd rows NX - 1, so both sides are alike (cells:
//         NX ceil(NY/2) + (NX-1) floor(NY/2)). HexRows::Offset: every row
//         holds NX cells (cells: NX NY). Interior valence 3, perimeter 2 or 3.
//         NX = 4, NY = 5, K = 11 (alternate) is the paper's Sheet: 18 cells,
//         71 rods, 54 connections, 693 vertices, 710 edges.
//   quad  Squares, NX across and NY up. Interior valence 4, perimeter 3,
//         corners 2.
//   tri   Equilateral triangles in NY horizontal strips between NY + 1 rows
//         of nodes; even rows have NX + 1 nodes, odd rows NX nodes shifted by
//         half a spacing (the sides zigzag; top and bottom are straight).
//         Each strip holds 2 NX - 1 triangles. Interior valence 6.
//
// Size. GridFit::Regular (default) keeps the cells regular: the lattice is
// scaled uniformly to the largest size that fits in W x H, so it fills one
// direction exactly and is centred in the other. GridFit::Stretch scales x and
// y separately so that the sheet spans W x H exactly (cells are regular only
// when W / H happens to match). Either way the sheet is centred at the origin:
// its bounding box lies within [-W/2, W/2] x [-H/2, H/2].
//
// Numbering. Connections come first (vertices 0 .. C-1, ordered by y, then
// x), then the interior vertices of each rod, rod by rod. Rods run from the
// lower-numbered connection to the higher one.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "model/scene.hh"

namespace rodmesh::meshing {

enum class GridKind { Hex, Quad, Tri };
enum class GridFit { Regular, Stretch };
enum class HexRows { Alternate, Offset };
// A side of the sheet's bounding box: the vertices whose rest position lies
// on it (within a tolerance of 1e-6 x the shortest rod edge).
enum class GridSide { Left, Right, Bottom, Top };

// A pull: a total force [N] shared equally by the connections on a side that
// are not held. Rod interiors are not loaded, so a pull does not bend the
// boundary rods sideways (it acts where a wire would be tied).
struct SidePull {
  GridSide side = GridSide::Right;
  Vec3 force = Vec3::Zero();
};

struct GridOptions {
  GridKind kind = GridKind::Hex;
  double width = 0.2, height = 0.2;  // W, H [m]
  int cellsX = 4, cellsY = 5;        // NX, NY
  int rodVertices = 11;              // K >= 2: vertices per rod, ends included
  GridFit fit = GridFit::Regular;
  HexRows hexRows = HexRows::Alternate;

  Material material{32e6, 0.48, 1200.0};        // TPU 92A (paper Table 1)
  Vec2 radius{0.002, 0.002};                    // [r_t, r_n] of every vertex [m]
  double radiusMin = 0.001, radiusMax = 0.005;  // design bounds [m]
  bool designRadii = true, designRestShape = true;
  int controlPointsPerRod = 4;
  std::optional<Vec3> gravity;  // none by default

  // Vertices of these sides are held at rest in every pose.
  std::vector<GridSide> fixSides;
  // One pose per pull (named pull_<side>, with a suffix _2, _3, ... when a
  // name repeats); without pulls, one pose "rest".
  std::vector<SidePull> pulls;
};

struct GridReport {
  GridKind kind = GridKind::Hex;
  int cells = 0, rods = 0, connections = 0, freeEnds = 0, vertices = 0, edges = 0;
  std::map<int, int> valence;  // rods at a connection -> number of connections
  double rodLengthMin = 0.0, rodLengthMax = 0.0;
  double edgeLengthMin = 0.0, edgeLengthMax = 0.0;
  double width = 0.0, height = 0.0;  // extent of the sheet [m]
  bool regular = true;               // cells are regular polygons
  int fixedVertices = 0;
  std::vector<std::pair<std::string, int>> pulledVertices;  // pose name -> loaded vertices
};

struct GridResult {
  Scene scene;
  GridReport report;
};

// Throws InputError naming the flag for inconsistent options.
void validateGridOptions(const GridOptions& o);

// Builds the sheet scene (calls validateGridOptions first).
GridResult makeGridSheet(const GridOptions& o);

// Vertices of `scene` lying on a side of its rest bounding box (x or y within
// `tolerance` of the extreme value), in index order.
std::vector<int> sideVertices(const Scene& scene, GridSide side, double tolerance);

// Human-readable summary (several lines, millimetres).
std::string formatGridReport(const GridReport& r);

// Names used by the command line ("hex", "quad", "tri"; "left", ...). The
// parsers throw InputError naming `flag` and listing the accepted words.
const char* gridKindName(GridKind k);
const char* gridSideName(GridSide s);
GridKind parseGridKind(const std::string& word, const std::string& flag);
GridSide parseGridSide(const std::string& word, const std::string& flag);

}  // namespace rodmesh::meshing
