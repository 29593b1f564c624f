// Generated planar rod sheets (see grid.hh for the layouts and conventions).
#include "meshing/grid.hh"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>
#include <utility>

#include "io/scene_reader.hh"
#include "model/limits.hh"

namespace rodmesh::meshing {

namespace {

// A lattice node in integer coordinates: position (X * dx, Y * dy) for cells of
// unit edge length. Integers make shared corners identical by construction.
using Key = std::pair<long long, long long>;  // (Y, X): sorts by row, then x

struct Lattice {
  double dx = 1.0, dy = 1.0;               // lengths of one X and one Y step (unit rod length)
  std::vector<Key> nodes;                  // sorted, unique
  std::vector<std::pair<int, int>> links;  // node indices, first < second, sorted
  int cells = 0;
};

// Collects nodes and links given as key pairs, then numbers the nodes by (Y, X).
class LatticeBuilder {
 public:
  void link(Key a, Key b) {
    if (b < a) std::swap(a, b);
    links_.insert({a, b});
  }
  Lattice finish(double dx, double dy, int cells) const {
    Lattice L;
    L.dx = dx;
    L.dy = dy;
    L.cells = cells;
    std::set<Key> nodes;
    for (const auto& [a, b] : links_) nodes.insert(a), nodes.insert(b);
    L.nodes.assign(nodes.begin(), nodes.end());
    auto index = [&](const Key& k) {
      return static_cast<int>(std::lower_bound(L.nodes.begin(), L.nodes.end(), k) - L.nodes.begin());
    };
    for (const auto& [a, b] : links_) L.links.push_back({index(a), index(b)});
    std::sort(L.links.begin(), L.links.end());
    return L;
  }

 private:
  std::set<std::pair<Key, Key>> links_;
};

Key key(long long x, long long y) { return {y, x}; }

// Squares: nodes (i, j), i = 0..NX, j = 0..NY.
Lattice quadLattice(int nx, int ny) {
  LatticeBuilder b;
  for (long long j = 0; j <= ny; ++j)
    for (long long i = 0; i <= nx; ++i) {
      if (i < nx) b.link(key(i, j), key(i + 1, j));
      if (j < ny) b.link(key(i, j), key(i, j + 1));
    }
  return b.finish(1.0, 1.0, nx * ny);
}

// Equilateral triangles. X counts half spacings: row j holds X = 0, 2, .., 2NX
// (j even) or X = 1, 3, .., 2NX - 1 (j odd); Y counts rows (height sqrt(3)/2).
Lattice triLattice(int nx, int ny) {
  LatticeBuilder b;
  auto rowX = [&](long long j) {
    std::vector<long long> xs;
    if (j % 2 == 0)
      for (long long i = 0; i <= nx; ++i) xs.push_back(2 * i);
    else
      for (long long i = 0; i < nx; ++i) xs.push_back(2 * i + 1);
    return xs;
  };
  for (long long j = 0; j <= ny; ++j) {
    const std::vector<long long> xs = rowX(j);
    for (std::size_t k = 0; k + 1 < xs.size(); ++k) b.link(key(xs[k], j), key(xs[k + 1], j));
    if (j == ny) break;
    const std::vector<long long> up = rowX(j + 1);
    for (long long x : xs)
      for (long long u : up)
        if (u == x - 1 || u == x + 1) b.link(key(x, j), key(u, j + 1));
  }
  return b.finish(0.5, std::sqrt(3.0) / 2.0, ny * (2 * nx - 1));
}

// Regular hexagons of unit side, pointy side up. X counts sqrt(3)/2, Y counts
// 1/2. Cell (c, r) is centred at (2c + r mod 2, 3r); its corners, counter-
// clockwise from the top, are at the offsets below.
Lattice hexLattice(int nx, int ny, HexRows rows) {
  static const std::array<std::pair<int, int>, 6> corner = {{{0, 2}, {-1, 1}, {-1, -1}, {0, -2}, {1, -1}, {1, 1}}};
  LatticeBuilder b;
  int cells = 0;
  for (long long r = 0; r < ny; ++r) {
    const int inRow = (rows == HexRows::Alternate && r % 2 == 1) ? nx - 1 : nx;
    for (long long c = 0; c < inRow; ++c) {
      const long long cx = 2 * c + r % 2, cy = 3 * r;
      for (int k = 0; k < 6; ++k) {
        const auto& p = corner[k];
        const auto& q = corner[(k + 1) % 6];
        b.link(key(cx + p.first, cy + p.second), key(cx + q.first, cy + q.second));
      }
      ++cells;
    }
  }
  return b.finish(std::sqrt(3.0) / 2.0, 0.5, cells);
}

std::string fmt(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

}  // namespace

const char* gridKindName(GridKind k) {
  switch (k) {
    case GridKind::Hex:
      return "hex";
    case GridKind::Quad:
      return "quad";
    case GridKind::Tri:
      return "tri";
  }
  return "?";
}

const char* gridSideName(GridSide s) {
  switch (s) {
    case GridSide::Left:
      return "left";
    case GridSide::Right:
      return "right";
    case GridSide::Bottom:
      return "bottom";
    case GridSide::Top:
      return "top";
  }
  return "?";
}

GridKind parseGridKind(const std::string& word, const std::string& flag) {
  for (GridKind k : {GridKind::Hex, GridKind::Quad, GridKind::Tri})
    if (word == gridKindName(k)) return k;
  throw InputError(flag + " must be hex, quad or tri (got '" + word + "')");
}

GridSide parseGridSide(const std::string& word, const std::string& flag) {
  for (GridSide s : {GridSide::Left, GridSide::Right, GridSide::Bottom, GridSide::Top})
    if (word == gridSideName(s)) return s;
  throw InputError(flag + " must name a side: left, right, bottom or top (got '" + word + "')");
}

void validateGridOptions(const GridOptions& o) {
  auto bad = [](const std::string& m) { throw InputError(m); };
  // As meshing::kMinSurfaceSize / kMaxSurfaceSize for surfaces.
  if (!(o.width >= 1e-6 && o.width <= 1e6 && o.height >= 1e-6 && o.height <= 1e6))
    bad("--size must be two lengths W H in [1e-06, 1e+06] metres (got " + fmt(o.width) + " " + fmt(o.height) + ")");
  if (o.cellsX < 1 || o.cellsY < 1)
    bad("--cells must be two positive counts NX NY (got " + std::to_string(o.cellsX) + " " + std::to_string(o.cellsY) +
        ")");
  if (o.kind == GridKind::Hex && o.hexRows == HexRows::Alternate && o.cellsY >= 2 && o.cellsX < 2)
    bad("--grid hex with alternating rows (NX, NX-1, ...) needs NX >= 2 when NY >= 2 (got NX = " +
        std::to_string(o.cellsX) + "); use --hex-rows offset for a single column");
  if (o.rodVertices < 2) bad("--rod-vertices must be at least 2 (got " + std::to_string(o.rodVertices) + ")");
  // Sanity limit: about 6 rods per cell of K vertices each.
  const double estimate = 6.0 * o.cellsX * static_cast<double>(o.cellsY) * o.rodVertices;
  if (estimate > 2e7)
    bad("--cells and --rod-vertices give a sheet of about " + fmt(estimate) + " vertices (limit 2e7)");
  // The plausible ranges of every scene (model/limits.hh).
  if (!(o.material.youngModulus >= limits::kMinYoungModulus && o.material.youngModulus <= limits::kMaxYoungModulus))
    bad("--young-modulus must lie in [" + fmt(limits::kMinYoungModulus) + ", " + fmt(limits::kMaxYoungModulus) +
        "] Pa (got " +
        fmt(o.material.youngModulus) + ")");
  if (!(o.material.poissonRatio > -1 && o.material.poissonRatio <= 0.5)) bad("--poisson-ratio must lie in (-1, 0.5]");
  if (!(o.material.density >= limits::kMinDensity && o.material.density <= limits::kMaxDensity))
    bad("--material-density must lie in [" + fmt(limits::kMinDensity) + ", " + fmt(limits::kMaxDensity) +
        "] kg/m^3 (got " +
        fmt(o.material.density) + ")");
  for (int k = 0; k < 2; ++k)
    if (!(o.radius[k] >= limits::kMinRadius && o.radius[k] <= limits::kMaxRadius))
      bad("--radius values must lie in [" + fmt(limits::kMinRadius) + ", " + fmt(limits::kMaxRadius) + "] m (got " +
          fmt(o.radius[k]) + ")");
  if (!(o.radiusMin >= limits::kMinRadius && o.radiusMin <= o.radiusMax && o.radiusMax <= limits::kMaxRadius))
    bad("--radius-bounds must satisfy " + fmt(limits::kMinRadius) + " <= min <= max <= " + fmt(limits::kMaxRadius) +
        " m (got " + fmt(o.radiusMin) + ", " + fmt(o.radiusMax) + ")");
  if (o.radius.minCoeff() < o.radiusMin || o.radius.maxCoeff() > o.radiusMax)
    bad("--radius must lie within --radius-bounds");
  if (o.controlPointsPerRod < 2 || o.controlPointsPerRod > limits::kMaxControlPoints)
    bad("--control-points must lie in [2, " + std::to_string(limits::kMaxControlPoints) + "] (got " +
        std::to_string(o.controlPointsPerRod) + ")");
  if (o.gravity && !(o.gravity->allFinite() && o.gravity->cwiseAbs().maxCoeff() <= limits::kMaxGravity))
    bad("--gravity components must lie in [-" + fmt(limits::kMaxGravity) + ", " + fmt(limits::kMaxGravity) + "] m/s^2");
  for (const SidePull& p : o.pulls)
    if (!(p.force.allFinite() && p.force.cwiseAbs().maxCoeff() <= limits::kMaxForce))
      bad(std::string("--pull ") + gridSideName(p.side) + ": force components must lie in [-" +
          fmt(limits::kMaxForce) + ", " + fmt(limits::kMaxForce) + "] N (got " + fmt(p.force[0]) + " " +
          fmt(p.force[1]) + " " + fmt(p.force[2]) + ")");
}

std::vector<int> sideVertices(const Scene& scene, GridSide side, double tolerance) {
  std::vector<int> out;
  if (scene.vertices.empty()) return out;
  const int axis = (side == GridSide::Left || side == GridSide::Right) ? 0 : 1;
  const bool low = side == GridSide::Left || side == GridSide::Bottom;
  double extreme = low ? std::numeric_limits<double>::infinity() : -std::numeric_limits<double>::infinity();
  for (const Vec3& v : scene.vertices) extreme = low ? std::min(extreme, v[axis]) : std::max(extreme, v[axis]);
  for (int i = 0; i < static_cast<int>(scene.vertices.size()); ++i)
    if (std::abs(scene.vertices[i][axis] - extreme) <= tolerance) out.push_back(i);
  return out;
}

GridResult makeGridSheet(const GridOptions& o) {
  validateGridOptions(o);
  Lattice L;
  switch (o.kind) {
    case GridKind::Hex:
      L = hexLattice(o.cellsX, o.cellsY, o.hexRows);
      break;
    case GridKind::Quad:
      L = quadLattice(o.cellsX, o.cellsY);
      break;
    case GridKind::Tri:
      L = triLattice(o.cellsX, o.cellsY);
      break;
  }

  // Scale (unit rod length -> metres) and centre.
  long long xmin = std::numeric_limits<long long>::max(), xmax = std::numeric_limits<long long>::min();
  long long ymin = xmin, ymax = xmax;
  for (const Key& k : L.nodes) {
    ymin = std::min(ymin, k.first), ymax = std::max(ymax, k.first);
    xmin = std::min(xmin, k.second), xmax = std::max(xmax, k.second);
  }
  const double ex = (xmax - xmin) * L.dx, ey = (ymax - ymin) * L.dy;  // natural extent
  double sx = o.width / ex, sy = o.height / ey;
  if (o.fit == GridFit::Regular) sx = sy = std::min(sx, sy);
  const double cx = 0.5 * (xmin + xmax), cy = 0.5 * (ymin + ymax);
  auto place = [&](const Key& k) { return Vec3(sx * L.dx * (k.second - cx), sy * L.dy * (k.first - cy), 0.0); };

  GridResult res;
  Scene& sc = res.scene;
  sc.sourcePath = std::string("<grid ") + gridKindName(o.kind) + ">";
  sc.material = o.material;
  sc.gravity = o.gravity;
  const int C = static_cast<int>(L.nodes.size());
  const int K = o.rodVertices;
  sc.vertices.reserve(C + L.links.size() * (K - 2));
  for (const Key& k : L.nodes) sc.vertices.push_back(place(k));
  for (const auto& [a, b] : L.links) {
    Rod rod;
    rod.vertices.push_back(a);
    const Vec3 pa = sc.vertices[a], pb = sc.vertices[b];
    for (int i = 1; i + 1 < K; ++i) {
      const double t = static_cast<double>(i) / (K - 1);
      rod.vertices.push_back(static_cast<int>(sc.vertices.size()));
      sc.vertices.push_back((1.0 - t) * pa + t * pb);
    }
    rod.vertices.push_back(b);
    sc.rods.push_back(std::move(rod));
  }
  const int V = static_cast<int>(sc.vertices.size());
  sc.normals.assign(V, Vec3::UnitZ());
  sc.radii.assign(V, o.radius);
  sc.design.present = true;
  sc.design.radii = o.designRadii;
  sc.design.restShape = o.designRestShape;
  sc.design.hasRadiusBounds = true;
  sc.design.radiusMin = o.radiusMin;
  sc.design.radiusMax = o.radiusMax;
  sc.design.controlPointsPerRod = o.controlPointsPerRod;

  // Report: counts, valences, lengths.
  GridReport& r = res.report;
  r.kind = o.kind;
  r.cells = L.cells;
  r.rods = static_cast<int>(sc.rods.size());
  r.vertices = V;
  r.edges = r.rods * (K - 1);
  std::vector<int> valence(C, 0);
  for (const auto& [a, b] : L.links) ++valence[a], ++valence[b];
  for (int v : valence) {
    if (v >= 2)
      ++r.connections, ++r.valence[v];
    else
      ++r.freeEnds;  // cannot happen for whole cells; kept for honesty of the report
  }
  r.rodLengthMin = std::numeric_limits<double>::infinity();
  for (const auto& [a, b] : L.links) {
    const double len = (sc.vertices[b] - sc.vertices[a]).norm();
    r.rodLengthMin = std::min(r.rodLengthMin, len);
    r.rodLengthMax = std::max(r.rodLengthMax, len);
  }
  r.edgeLengthMin = r.rodLengthMin / (K - 1);
  r.edgeLengthMax = r.rodLengthMax / (K - 1);
  r.width = sx * ex;
  r.height = sy * ey;
  r.regular = std::abs(sx - sy) <= 1e-12 * std::max(sx, sy);

  // Boundary conditions and poses.
  const double tol = 1e-6 * r.edgeLengthMin;
  std::vector<char> held(V, 0);
  for (GridSide s : o.fixSides)
    for (int v : sideVertices(sc, s, tol)) held[v] = 1;
  std::vector<FixedVertex> fixed;
  for (int v = 0; v < V; ++v)
    if (held[v]) fixed.push_back(FixedVertex{v, std::nullopt});
  r.fixedVertices = static_cast<int>(fixed.size());
  if (o.pulls.empty()) {
    Pose p;
    p.name = "rest";
    p.fixed = fixed;
    sc.poses.push_back(std::move(p));
  }
  std::map<std::string, int> seen;
  for (const SidePull& pull : o.pulls) {
    Pose p;
    const std::string base = std::string("pull_") + gridSideName(pull.side);
    const int n = ++seen[base];
    p.name = n == 1 ? base : base + "_" + std::to_string(n);
    p.fixed = fixed;
    std::vector<int> loaded;
    for (int v : sideVertices(sc, pull.side, tol))
      if (v < C && !held[v]) loaded.push_back(v);  // connections only (numbered first)
    if (loaded.empty())
      throw InputError(std::string("--pull ") + gridSideName(pull.side) + ": every connection on that side is fixed");
    for (int v : loaded) p.forces.push_back(PointForce{v, pull.force / static_cast<double>(loaded.size())});
    r.pulledVertices.push_back({p.name, static_cast<int>(loaded.size())});
    sc.poses.push_back(std::move(p));
  }
  return res;
}

std::string formatGridReport(const GridReport& r) {
  static const char* cellName[] = {"hexagons", "squares", "triangles"};
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(1);
  o << "grid sheet: " << r.cells << " " << (r.regular ? "regular " : "stretched ") << cellName[static_cast<int>(r.kind)]
    << ", " << 1e3 * r.width << " x " << 1e3 * r.height << " mm\n";
  o << "rod mesh: " << r.vertices << " vertices, " << r.edges << " edges, " << r.rods << " rods, " << r.connections
    << " connections, " << r.freeEnds << " free ends\n";
  o << "connection valence:";
  for (auto [k, n] : r.valence) o << " " << k << ":" << n;
  o.precision(2);
  o << "\nrod length: " << 1e3 * r.rodLengthMin;
  if (r.rodLengthMax > r.rodLengthMin * (1 + 1e-9)) o << " to " << 1e3 * r.rodLengthMax;
  o << " mm; edge length " << 1e3 * r.edgeLengthMin;
  if (r.edgeLengthMax > r.edgeLengthMin * (1 + 1e-9)) o << " to " << 1e3 * r.edgeLengthMax;
  o << " mm\n";
  if (r.fixedVertices) o << "fixed vertices: " << r.fixedVertices << "\n";
  for (const auto& [name, n] : r.pulledVertices) o << "pose " << name << ": force shared by " << n << " vertices\n";
  return o.str();
}

}  // namespace rodmesh::meshing
