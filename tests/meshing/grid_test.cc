// Tests of meshing/grid: generated hex, quad and tri sheets.
//
// Counts for small sheets are derived by hand next to each test; every sheet
// must survive the scene reader (sceneToJson -> parseScene) and the rod
// network built from it.
#include "meshing/grid.hh"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>

#include "io/scene_reader.hh"
#include "io/scene_writer.hh"
#include "model/network.hh"

namespace rodmesh::meshing {
namespace {

GridOptions options(GridKind kind, int nx, int ny, int k, double w = 0.2, double h = 0.2) {
  GridOptions o;
  o.kind = kind;
  o.cellsX = nx;
  o.cellsY = ny;
  o.rodVertices = k;
  o.width = w;
  o.height = h;
  return o;
}

struct Topology {
  int connections = 0, freeEnds = 0;
  std::map<int, int> valence;  // rods ending at a vertex -> vertices (valence >= 2)
};

// Checks the rod-mesh invariants and returns the end-vertex topology:
// rods meet only at their end vertices, every vertex belongs to a rod, every
// rod is straight with K vertices at equal spacing.
Topology checkInvariants(const Scene& s, int K) {
  const int V = static_cast<int>(s.vertices.size());
  std::vector<int> ends(V, 0), interiorUse(V, 0);
  for (const Rod& r : s.rods) {
    EXPECT_EQ(static_cast<int>(r.vertices.size()), K);
    ++ends[r.vertices.front()];
    ++ends[r.vertices.back()];
    for (std::size_t i = 1; i + 1 < r.vertices.size(); ++i) ++interiorUse[r.vertices[i]];
    const Vec3 a = s.vertices[r.vertices.front()], b = s.vertices[r.vertices.back()];
    const double len = (b - a).norm();
    EXPECT_GT(len, 0.0);
    for (std::size_t i = 0; i < r.vertices.size(); ++i) {
      const Vec3 expect = a + (b - a) * (static_cast<double>(i) / (K - 1));
      EXPECT_LT((s.vertices[r.vertices[i]] - expect).norm(), 1e-12 * len) << "rod vertex " << i << " not on the chord";
    }
  }
  Topology t;
  for (int v = 0; v < V; ++v) {
    EXPECT_TRUE(ends[v] > 0 || interiorUse[v] > 0) << "vertex " << v << " belongs to no rod";
    EXPECT_LE(interiorUse[v], 1) << "vertex " << v << " is inside two rods";
    if (interiorUse[v] > 0) {
      EXPECT_EQ(ends[v], 0) << "rod ends at vertex " << v << " inside another rod";
    }
    if (ends[v] == 1) ++t.freeEnds;
    if (ends[v] >= 2) ++t.connections, ++t.valence[ends[v]];
  }
  for (const Vec3& x : s.vertices) EXPECT_EQ(x.z(), 0.0);
  EXPECT_EQ(s.normals.size(), s.vertices.size());
  for (const Vec3& n : s.normals) EXPECT_EQ(n, Vec3::UnitZ());
  return t;
}

// The scene goes through the writer and the reader unchanged in its counts.
Scene roundTrip(const Scene& s) {
  Scene back = parseScene(sceneToJson(s), "grid.json");
  EXPECT_EQ(back.vertices.size(), s.vertices.size());
  EXPECT_EQ(back.rods.size(), s.rods.size());
  EXPECT_EQ(back.poses.size(), s.poses.size());
  return back;
}

// Valence of the connection nearest the centre (an interior node).
int centralValence(const Scene& s) {
  std::map<int, int> ends;
  for (const Rod& r : s.rods) ++ends[r.vertices.front()], ++ends[r.vertices.back()];
  int best = -1;
  for (auto [v, n] : ends)
    if (best < 0 || s.vertices[v].head<2>().norm() < s.vertices[best].head<2>().norm()) best = v;
  return ends[best];
}

TEST(GridSheet, Quad2x2CountsByHand) {
  // 3 x 3 nodes; 2 rows x 3 horizontal rods + 3 columns x 2 vertical = 12 rods.
  // Valence: 4 corners of 2, 4 edge midpoints of 3, 1 centre of 4.
  // Vertices: 9 + 12 (K - 2) = 9 + 12 * 3 = 45 for K = 5.
  const GridResult g = makeGridSheet(options(GridKind::Quad, 2, 2, 5));
  const Scene s = roundTrip(g.scene);
  const Topology t = checkInvariants(s, 5);
  EXPECT_EQ(s.rods.size(), 12u);
  EXPECT_EQ(t.connections, 9);
  EXPECT_EQ(t.freeEnds, 0);
  EXPECT_EQ(s.vertices.size(), 45u);
  EXPECT_EQ(t.valence, (std::map<int, int>{{2, 4}, {3, 4}, {4, 1}}));
  EXPECT_EQ(g.report.cells, 4);
  EXPECT_EQ(g.report.valence, t.valence);
  EXPECT_EQ(g.report.edges, 12 * 4);
  RodNetwork net(s);
  EXPECT_EQ(net.numConnections(), 9);
  EXPECT_EQ(net.numEdges(), 48);
}

TEST(GridSheet, Tri2x2CountsByHand) {
  // Rows 0 and 2 hold 3 nodes (x = 0, 1, 2), row 1 holds 2 (x = 0.5, 1.5):
  // 8 nodes. Rods: in-row 2 + 1 + 2 = 5; between rows, each of the 2 strips
  // has 4 slanted rods: 8. Total 13. Triangles per strip 2 NX - 1 = 3: 6.
  // Euler check: V - E + F = 8 - 13 + 6 = 1. Valence: the four corners 2;
  // the middles of rows 0 and 2: 2 in-row + 2 slanted = 4; the row-1 nodes:
  // 1 in-row + 2 below + 2 above = 5.
  const GridResult g = makeGridSheet(options(GridKind::Tri, 2, 2, 3));
  const Scene s = roundTrip(g.scene);
  const Topology t = checkInvariants(s, 3);
  EXPECT_EQ(s.rods.size(), 13u);
  EXPECT_EQ(t.connections, 8);
  EXPECT_EQ(s.vertices.size(), 8u + 13u);
  EXPECT_EQ(t.valence, (std::map<int, int>{{2, 4}, {4, 2}, {5, 2}}));
  EXPECT_EQ(g.report.cells, 6);
}

TEST(GridSheet, Hex2x2CountsByHand) {
  // Offset rows, 2 x 2 hexagons: row 0 has 2 cells sharing one side, row 1
  // is shifted right by half a cell (its first cell sits in the notch of row
  // 0, its second overhangs on the right). Nodes: bottom zigzag 5, the
  // zigzag between the rows 6, top zigzag 5: 16. Rods: V + F - 1 = 19.
  // Boundary: 6F = 2E - Eb -> Eb = 38 - 24 = 14 perimeter rods, hence 14
  // perimeter nodes, 2 interior nodes of valence 3; valence sum 2E = 38 =
  // 2 n2 + 3 (16 - n2) -> n2 = 10, n3 = 6.
  GridOptions o = options(GridKind::Hex, 2, 2, 4);
  o.hexRows = HexRows::Offset;
  const GridResult g = makeGridSheet(o);
  const Scene s = roundTrip(g.scene);
  const Topology t = checkInvariants(s, 4);
  EXPECT_EQ(g.report.cells, 4);
  EXPECT_EQ(t.connections, 16);
  EXPECT_EQ(s.rods.size(), 19u);
  EXPECT_EQ(s.vertices.size(), 16u + 19u * 2u);
  EXPECT_EQ(t.valence, (std::map<int, int>{{2, 10}, {3, 6}}));

  // Alternating rows, 2 x 2: rows of 2 and 1 cells = 3 cells around one node.
  // Nodes: 5 (bottom) + 5 (between) + 3 (top) = 13; rods 13 + 3 - 1 = 15;
  // perimeter rods 2E - 6F = 12, so 1 interior node; 30 = 2 n2 + 3 (13 - n2)
  // gives n2 = 9, n3 = 4.
  o.hexRows = HexRows::Alternate;
  const Scene a = roundTrip(makeGridSheet(o).scene);
  const Topology ta = checkInvariants(a, 4);
  EXPECT_EQ(ta.connections, 13);
  EXPECT_EQ(a.rods.size(), 15u);
  EXPECT_EQ(ta.valence, (std::map<int, int>{{2, 9}, {3, 4}}));
}

TEST(GridSheet, PaperSheetCounts) {
  // The paper's Sheet (Table 1): 693 nodes, 710 edges, 71 rods, 54 connections.
  // 18 regular hexagons in rows 4, 3, 4, 3, 4 with 11 vertices per rod: every
  // rod ends at connections (20 of valence 2 on the perimeter, 34 of valence 3).
  const GridResult g = makeGridSheet(options(GridKind::Hex, 4, 5, 11));
  const Scene s = roundTrip(g.scene);
  const Topology t = checkInvariants(s, 11);
  EXPECT_EQ(g.report.cells, 18);
  EXPECT_EQ(s.vertices.size(), 693u);
  EXPECT_EQ(s.rods.size(), 71u);
  EXPECT_EQ(t.connections, 54);
  EXPECT_EQ(t.freeEnds, 0);
  EXPECT_EQ(g.report.edges, 710);
  EXPECT_EQ(t.valence, (std::map<int, int>{{2, 20}, {3, 34}}));
  // Regular hexagons fitted into 0.2 x 0.2: height 8 a = 0.2 -> a = 25 mm.
  EXPECT_NEAR(g.report.height, 0.2, 1e-12);
  EXPECT_NEAR(g.report.width, 0.2 * std::sqrt(3.0) * 4 / 8, 1e-12);
  EXPECT_NEAR(g.report.rodLengthMin, 0.025, 1e-12);
  EXPECT_NEAR(g.report.rodLengthMax, 0.025, 1e-12);
}

TEST(GridSheet, InteriorValences) {
  for (auto [kind, valence] : {std::pair{GridKind::Hex, 3}, {GridKind::Quad, 4}, {GridKind::Tri, 6}}) {
    const Scene s = makeGridSheet(options(kind, 6, 6, 3)).scene;
    const Topology t = checkInvariants(s, 3);
    EXPECT_EQ(centralValence(s), valence) << gridKindName(kind);
    EXPECT_EQ(t.valence.rbegin()->first, valence) << gridKindName(kind) << ": no connection above interior valence";
    EXPECT_EQ(t.freeEnds, 0);
  }
}

TEST(GridSheet, EdgeLengthsAreCellSizeOverKMinusOne) {
  // Regular fit of a square box: quad 4 x 4 in 0.2 x 0.2 -> 50 mm squares.
  const int K = 6;
  {
    const Scene s = makeGridSheet(options(GridKind::Quad, 4, 4, K)).scene;
    for (const Rod& r : s.rods)
      for (std::size_t i = 0; i + 1 < r.vertices.size(); ++i)
        EXPECT_NEAR((s.vertices[r.vertices[i + 1]] - s.vertices[r.vertices[i]]).norm(), 0.05 / (K - 1), 1e-12);
  }
  // Tri 4 x 4: width 4 s, height 4 (sqrt3/2) s -> s = 50 mm (width limits).
  // Hex: every side has the same length a.
  for (GridKind kind : {GridKind::Tri, GridKind::Hex}) {
    const GridResult g = makeGridSheet(options(kind, 4, 4, K));
    const double rod = g.report.rodLengthMin;
    EXPECT_NEAR(g.report.rodLengthMax, rod, 1e-12 * rod) << "cells are regular";
    if (kind == GridKind::Tri) {
      EXPECT_NEAR(rod, 0.05, 1e-12);
    }
    for (const Rod& r : g.scene.rods)
      for (std::size_t i = 0; i + 1 < r.vertices.size(); ++i)
        EXPECT_NEAR((g.scene.vertices[r.vertices[i + 1]] - g.scene.vertices[r.vertices[i]]).norm(), rod / (K - 1),
                    1e-12);
  }
}

TEST(GridSheet, FitRegularCentresAndStretchFills) {
  for (GridKind kind : {GridKind::Hex, GridKind::Quad, GridKind::Tri}) {
    for (GridFit fit : {GridFit::Regular, GridFit::Stretch}) {
      GridOptions o = options(kind, 3, 2, 2, 0.3, 0.1);
      o.fit = fit;
      const GridResult g = makeGridSheet(o);
      Eigen::Vector3d lo = g.scene.vertices[0], hi = lo;
      for (const Vec3& x : g.scene.vertices) lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
      EXPECT_NEAR(lo.x() + hi.x(), 0.0, 1e-12);
      EXPECT_NEAR(lo.y() + hi.y(), 0.0, 1e-12);
      EXPECT_LE(hi.x() - lo.x(), 0.3 + 1e-12);
      EXPECT_LE(hi.y() - lo.y(), 0.1 + 1e-12);
      if (fit == GridFit::Stretch) {
        EXPECT_NEAR(hi.x() - lo.x(), 0.3, 1e-12);
        EXPECT_NEAR(hi.y() - lo.y(), 0.1, 1e-12);
      } else {
        EXPECT_TRUE(std::abs(hi.x() - lo.x() - 0.3) < 1e-12 || std::abs(hi.y() - lo.y() - 0.1) < 1e-12);
        EXPECT_TRUE(g.report.regular);
      }
    }
  }
}

TEST(GridSheet, MaterialDesignAndDefaults) {
  const Scene s = roundTrip(makeGridSheet(options(GridKind::Hex, 2, 2, 2)).scene);
  EXPECT_EQ(s.material.youngModulus, 32e6);
  EXPECT_EQ(s.material.poissonRatio, 0.48);
  EXPECT_EQ(s.material.density, 1200.0);
  for (const Vec2& r : s.radii) EXPECT_EQ(r, Vec2(0.002, 0.002));
  EXPECT_TRUE(s.design.present && s.design.hasRadiusBounds);
  EXPECT_EQ(s.design.radiusMin, 0.001);
  EXPECT_EQ(s.design.radiusMax, 0.005);
  ASSERT_EQ(s.poses.size(), 1u);
  EXPECT_EQ(s.poses[0].name, "rest");
  EXPECT_TRUE(s.poses[0].fixed.empty());
  EXPECT_FALSE(s.gravity.has_value());
}

TEST(GridSheet, FixedSidesAndPulls) {
  // Quad 3 x 2, K = 4: the left side is the column x = xmin: 3 nodes and the
  // 2 interior vertices of each of its 2 rods = 7 vertices.
  GridOptions o = options(GridKind::Quad, 3, 2, 4, 0.3, 0.2);
  o.fixSides = {GridSide::Left};
  o.pulls = {{GridSide::Right, Vec3(0.6, 0, 0)}, {GridSide::Right, Vec3(0, 0.7, 0)}, {GridSide::Top, Vec3(0, 1, 0)}};
  const GridResult g = makeGridSheet(o);
  const Scene s = roundTrip(g.scene);
  ASSERT_EQ(s.poses.size(), 3u);
  EXPECT_EQ(s.poses[0].name, "pull_right");
  EXPECT_EQ(s.poses[1].name, "pull_right_2");
  EXPECT_EQ(s.poses[2].name, "pull_top");
  std::set<int> fixed;
  for (const FixedVertex& f : s.poses[0].fixed) fixed.insert(f.vertex);
  EXPECT_EQ(fixed.size(), 7u);
  for (int v : fixed) EXPECT_NEAR(s.vertices[v].x(), -0.15, 1e-12);
  // Right side: its 3 connections share the force equally.
  ASSERT_EQ(s.poses[0].forces.size(), 3u);
  Vec3 total = Vec3::Zero();
  for (const PointForce& f : s.poses[0].forces) {
    EXPECT_NEAR(s.vertices[f.vertex].x(), 0.15, 1e-12);
    total += f.force;
  }
  EXPECT_LT((total - Vec3(0.6, 0, 0)).norm(), 1e-15);
  // Top side: 4 connections, minus the fixed corner = 3.
  EXPECT_EQ(s.poses[2].forces.size(), 3u);
  for (const PointForce& f : s.poses[2].forces) EXPECT_EQ(fixed.count(f.vertex), 0u);
}

TEST(GridSheet, RejectsBadOptions) {
  auto bad = [](GridOptions o) { EXPECT_THROW(makeGridSheet(o), InputError); };
  GridOptions o = options(GridKind::Quad, 2, 2, 3);
  o.rodVertices = 1;
  bad(o);
  o = options(GridKind::Quad, 0, 2, 3);
  bad(o);
  o = options(GridKind::Quad, 2, 2, 3, -0.1, 0.2);
  bad(o);
  o = options(GridKind::Hex, 1, 3, 3);  // alternating rows would leave odd rows empty
  bad(o);
  o.hexRows = HexRows::Offset;
  EXPECT_NO_THROW(makeGridSheet(o));
  o = options(GridKind::Quad, 2, 2, 3);
  o.radius = Vec2(0.006, 0.002);  // outside the bounds
  bad(o);
  o = options(GridKind::Quad, 2, 2, 3);
  o.fixSides = {GridSide::Right};
  o.pulls = {{GridSide::Right, Vec3(1, 0, 0)}};  // nothing left to pull
  bad(o);
  EXPECT_THROW(parseGridKind("hexagon", "--grid"), InputError);
  EXPECT_THROW(parseGridSide("north", "--fix-side"), InputError);
  EXPECT_EQ(parseGridSide("bottom", "--fix-side"), GridSide::Bottom);
}

}  // namespace
}  // namespace rodmesh::meshing
