#include "meshing/rod_mesher.hh"

#include "io/scene_reader.hh"
#include "meshing/geodesic.hh"
#include "meshing/simplify.hh"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <numeric>
#include <queue>
#include <set>
#include <sstream>

namespace rodmesh::meshing {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double polylineLength(const std::vector<Vec3>& p) {
  double l = 0;
  for (std::size_t i = 1; i < p.size(); ++i) l += (p[i] - p[i - 1]).norm();
  return l;
}

// Graph distance from the corners of a's face to the corners of b's face,
// plus the straight pieces inside those faces: an upper bound on the geodesic
// distance between a and b.
double graphDistanceBound(const TriSurface& s, const SurfaceTopology& topo, const SurfacePoint& a,
                          const SurfacePoint& b) {
  const Vec3 pa = evalPoint(s, a), pb = evalPoint(s, b);
  if (a.face == b.face) return (pa - pb).norm();
  std::vector<double> dist(s.vertices.size(), kInf);
  using QE = std::pair<double, int>;
  std::priority_queue<QE, std::vector<QE>, std::greater<QE>> q;
  for (int v : s.faces[a.face]) {
    dist[v] = (s.vertices[v] - pa).norm();
    q.push({dist[v], v});
  }
  std::set<int> targets(s.faces[b.face].begin(), s.faces[b.face].end());
  double best = kInf;
  while (!q.empty()) {
    auto [d, v] = q.top();
    q.pop();
    if (d > dist[v]) continue;
    if (d >= best) break;
    if (targets.count(v)) best = std::min(best, d + (s.vertices[v] - pb).norm());
    for (int w : topo.vertexNeighbours[v]) {
      const double nd = d + (s.vertices[v] - s.vertices[w]).norm();
      if (nd < dist[w]) {
        dist[w] = nd;
        q.push({nd, w});
      }
    }
  }
  return best;
}

// Faces that can hold a point x with |x - pa| + |x - pb| <= L: every surface
// path from a to b of length <= L lies on them.
std::vector<int> ellipseRegion(const TriSurface& s, const std::vector<Vec3>& centre,
                               const std::vector<double>& radius, const Vec3& pa, const Vec3& pb, double L) {
  std::vector<int> out;
  for (int f = 0; f < static_cast<int>(s.faces.size()); ++f) {
    const double lower = (pa - centre[f]).norm() + (pb - centre[f]).norm() - 2 * radius[f];
    if (lower > L) continue;
    const Tri& t = s.faces[f];
    const Vec3 &A = s.vertices[t[0]], &B = s.vertices[t[1]], &C = s.vertices[t[2]];
    const Vec3 ba = closestPointBary(pa, A, B, C), bb = closestPointBary(pb, A, B, C);
    const double da = (ba[0] * A + ba[1] * B + ba[2] * C - pa).norm();
    const double db = (bb[0] * A + bb[1] * B + bb[2] * C - pb).norm();
    if (da + db <= L) out.push_back(f);
  }
  return out;
}

// Points at equal arc-length steps along a polyline (n edges, n+1 points).
std::vector<Vec3> resample(const std::vector<Vec3>& p, int n) {
  std::vector<double> cum(p.size(), 0.0);
  for (std::size_t i = 1; i < p.size(); ++i) cum[i] = cum[i - 1] + (p[i] - p[i - 1]).norm();
  const double L = cum.back();
  std::vector<Vec3> out{p.front()};
  std::size_t seg = 1;
  for (int k = 1; k < n; ++k) {
    const double s = L * k / n;
    while (seg + 1 < p.size() && cum[seg] < s) ++seg;
    const double len = cum[seg] - cum[seg - 1];
    const double t = len > 0 ? std::clamp((s - cum[seg - 1]) / len, 0.0, 1.0) : 0.0;
    out.push_back((1 - t) * p[seg - 1] + t * p[seg]);
  }
  out.push_back(p.back());
  return out;
}

Layout dualLayout(const TriSurface& s, int targetFaces) {
  if (targetFaces < 4) throw InputError(s.sourcePath + ": --faces must be at least 4 (got " + std::to_string(targetFaces) + ")");
  if (targetFaces >= static_cast<int>(s.faces.size()))
    throw InputError(s.sourcePath + ": --faces " + std::to_string(targetFaces) +
                     " is not below the surface's face count (" + std::to_string(s.faces.size()) + ")");
  const TriSurface coarse = decimate(s, targetFaces);
  const SurfaceTopology ct(coarse);
  Layout lay;
  lay.numCells = static_cast<int>(coarse.vertices.size());
  lay.cellOpen.assign(lay.numCells, 0);
  for (int v = 0; v < lay.numCells; ++v) lay.cellOpen[v] = ct.isBoundaryVertex[v];
  lay.cellOnBoundary = lay.cellOpen;
  for (const Tri& t : coarse.faces) {
    const Vec3 c = (coarse.vertices[t[0]] + coarse.vertices[t[1]] + coarse.vertices[t[2]]) / 3;
    LayoutNode n;
    n.at = closestPoint(s, c, {});
    lay.nodes.push_back(n);
  }
  for (int f = 0; f < static_cast<int>(coarse.faces.size()); ++f)
    for (int i = 0; i < 3; ++i) {
      const int g = ct.faceNeighbours[f][i];
      if (g <= f) continue;
      LayoutLink l;
      l.a = f;
      l.b = g;
      l.cellA = coarse.faces[f][i];
      l.cellB = coarse.faces[f][(i + 1) % 3];
      lay.links.push_back(l);
    }
  return lay;
}

}  // namespace

namespace {
std::string fmt(double v) {
  std::ostringstream o;
  o.precision(10);
  o << v;
  return o.str();
}

// Throws "FLAG must lie in [lo, hi] UNIT (got v)" unless lo <= v <= hi (NaN fails).
void requireRange(const std::string& flag, double v, double lo, double hi, const std::string& unit = "") {
  if (!(v >= lo && v <= hi))
    throw InputError(flag + " must lie in [" + fmt(lo) + ", " + fmt(hi) + "]" + (unit.empty() ? "" : " " + unit) +
                     " (got " + fmt(v) + ")");
}
// Throws unless 0 < v <= hi.
void requirePositive(const std::string& flag, double v, double hi, const std::string& unit) {
  if (!(v > 0 && v <= hi))
    throw InputError(flag + " must be positive and at most " + fmt(hi) + " " + unit + " (got " + fmt(v) + ")");
}
}  // namespace

void validateOptions(const MeshOptions& o) {
  auto bad = [](const std::string& m) { throw InputError(m); };
  if (o.method == MeshMethod::Cells) {
    requireRange("--cells", o.cvt.cells, 2, kMaxCells);
    requireRange("--iterations", o.cvt.maxIterations, 1, kMaxLloydIterations);
    requireRange("--restarts", o.cvt.restarts, 1, kMaxRestarts);
    requireRange("--tolerance", o.cvt.tolerance, 0, 1, "x cell radius");
    requireRange("--merge", o.cvt.mergeFraction, 0, 1, "x median Voronoi edge");
    requireRange("--refinement", o.cvt.refinement, kMinRefinement, kMaxRefinement, "edges per cell radius");
  }
  if (o.method == MeshMethod::Dual) requireRange("--faces", o.dualFaces, 4, kMaxDualFaces);
  if (o.edgeLength != 0) requirePositive("--edge-length", o.edgeLength, kMaxLength, "m");
  requireRange("--young-modulus", o.material.youngModulus, limits::kMinYoungModulus, kMaxYoungModulus, "Pa");
  if (!(o.material.poissonRatio > -1 && o.material.poissonRatio <= 0.5))
    bad("--poisson-ratio must lie in (-1, 0.5] (got " + fmt(o.material.poissonRatio) + ")");
  requireRange("--material-density", o.material.density, limits::kMinDensity, kMaxDensity, "kg/m^3");
  for (int k = 0; k < 2; ++k) requireRange("--radius", o.radius[k], limits::kMinRadius, kMaxLength, "m");
  requireRange("--radius-bounds", o.radiusMin, limits::kMinRadius, kMaxLength, "m");
  requireRange("--radius-bounds", o.radiusMax, limits::kMinRadius, kMaxLength, "m");
  if (!(o.radiusMin <= o.radiusMax))
    bad("--radius-bounds must satisfy 0 < min <= max (got " + fmt(o.radiusMin) + ", " + fmt(o.radiusMax) + ")");
  if (o.radius.minCoeff() < o.radiusMin || o.radius.maxCoeff() > o.radiusMax)
    bad("--radius must lie within --radius-bounds");
  requireRange("--control-points", o.controlPointsPerRod, 2, kMaxControlPoints);
  if (o.gravity)
    for (int k = 0; k < 3; ++k) requireRange("--gravity", (*o.gravity)[k], -kMaxGravity, kMaxGravity, "m/s^2");
  for (const auto& b : o.fixBoxes) {
    if (!b.lo.allFinite() || !b.hi.allFinite()) bad("--fix-box coordinates must be finite");
    if (!(b.lo.array() <= b.hi.array()).all()) bad("--fix-box needs xmin <= xmax, ymin <= ymax, zmin <= zmax");
  }
}

Layout buildLayout(const TriSurface& surface, const SurfaceTopology& topo, const MeshOptions& opt,
                   const std::vector<double>& density, CvtReport* cvtReport) {
  if (opt.method == MeshMethod::Dual) return dualLayout(surface, opt.dualFaces);
  return cvtLayout(surface, topo, opt.cvt, density, cvtReport);
}

MeshResult meshSurface(const TriSurface& surface, const std::vector<DeformedPose>& poses,
                       const std::vector<double>& density, const MeshOptions& opt) {
  const auto t0 = std::chrono::steady_clock::now();
  validateOptions(opt);
  {
    const double size = bboxDiagonal(surface);
    if (!(size >= kMinSurfaceSize && size <= kMaxSurfaceSize))
      throw InputError(surface.sourcePath + ": the surface spans " + fmt(size) +
                       " m (bounding-box diagonal), outside the supported " + fmt(kMinSurfaceSize) + " to " +
                       fmt(kMaxSurfaceSize) + " m: check the units (--scale)");
  }
  const SurfaceTopology topo(surface);
  MeshResult res;
  MeshReport& rep = res.report;
  const Layout lay = buildLayout(surface, topo, opt, density, &rep.cvt);
  if (lay.links.empty()) throw InputError(surface.sourcePath + ": the layout has no rods (too few cells?)");

  const double diag = bboxDiagonal(surface);
  const int nf = static_cast<int>(surface.faces.size());
  std::vector<Vec3> centre(nf);
  std::vector<double> fradius(nf);
  for (int f = 0; f < nf; ++f) {
    const Tri& t = surface.faces[f];
    centre[f] = (surface.vertices[t[0]] + surface.vertices[t[1]] + surface.vertices[t[2]]) / 3;
    fradius[f] = 0;
    for (int v : t) fradius[f] = std::max(fradius[f], (surface.vertices[v] - centre[f]).norm());
  }

  // ---- trace every link on the surface
  struct Traced {
    std::vector<Vec3> points;
    std::vector<int> region;
  };
  std::vector<Traced> traced(lay.links.size());
  for (std::size_t k = 0; k < lay.links.size(); ++k) {
    const LayoutLink& l = lay.links[k];
    const Vec3 pa = evalPoint(surface, lay.nodes[l.a].at), pb = evalPoint(surface, lay.nodes[l.b].at);
    Traced& tr = traced[k];
    if (l.path == LinkPath::Given) {
      for (const SurfacePoint& p : l.given) tr.points.push_back(evalPoint(surface, p));
    } else {
      double bound = l.lengthHint > 0 ? l.lengthHint : graphDistanceBound(surface, topo, lay.nodes[l.a].at, lay.nodes[l.b].at);
      if (!std::isfinite(bound)) continue;  // different components: no rod
      bound = bound * 1.02 + 1e-9 * diag;
      std::vector<int> region = ellipseRegion(surface, centre, fradius, pa, pb, bound);
      for (int f : {lay.nodes[l.a].at.face, lay.nodes[l.b].at.face})
        if (std::find(region.begin(), region.end(), f) == region.end()) region.push_back(f);
      tr.points = shortestGeodesic(surface, region, lay.nodes[l.a].at, lay.nodes[l.b].at);
      if (tr.points.empty() && !l.given.empty())  // fall back to the traced cell boundary
        for (const SurfacePoint& p : l.given) tr.points.push_back(evalPoint(surface, p));
      if (tr.points.empty()) continue;
      tr.region = std::move(region);
    }
    if (tr.region.empty()) {
      const double L = polylineLength(tr.points) * 1.02 + 1e-9 * diag;
      tr.region = ellipseRegion(surface, centre, fradius, pa, pb, L);
    }
  }
  // ---- edge length
  double h = opt.edgeLength;
  {
    double sum = 0;
    int n = 0;
    for (const auto& tr : traced)
      if (!tr.points.empty()) {
        sum += polylineLength(tr.points);
        ++n;
      }
    if (n == 0) throw InputError(surface.sourcePath + ": no rod could be traced on the surface");
    if (h <= 0) h = sum / n / 10;
    // Bound the work (one closest-point search per rod vertex) before resampling.
    const double estimate = sum / h + opt.minEdgesPerRod * static_cast<double>(n);
    if (!(estimate <= kMaxRodVertices))
      throw InputError("--edge-length " + fmt(h) + " m gives about " + fmt(estimate) + " rod vertices on " +
                       surface.sourcePath + " (limit " + fmt(kMaxRodVertices) + "; the rods total " + fmt(sum) +
                       " m): use a longer edge length");
  }
  rep.edgeLength = h;

  // ---- rods and vertices
  Scene& sc = res.scene;
  std::vector<int> nodeVertex(lay.nodes.size(), -1);
  std::vector<int> nodeRods(lay.nodes.size(), 0);
  auto vertexOfNode = [&](int n) {
    if (nodeVertex[n] < 0) {
      nodeVertex[n] = static_cast<int>(res.locations.size());
      res.locations.push_back(lay.nodes[n].at);
    }
    return nodeVertex[n];
  };
  std::vector<double> rodLengths;
  std::map<int, int> cellSides;
  for (std::size_t k = 0; k < lay.links.size(); ++k) {
    const LayoutLink& l = lay.links[k];
    const Traced& tr = traced[k];
    if (tr.points.size() < 2) continue;
    const double L = polylineLength(tr.points);
    if (!(L > 1e-9 * diag)) continue;
    const int n = std::max(opt.minEdgesPerRod, static_cast<int>(std::lround(L / h)));
    const std::vector<Vec3> pts = resample(tr.points, n);
    Rod rod;
    rod.vertices.push_back(vertexOfNode(l.a));
    for (int i = 1; i < n; ++i) {
      rod.vertices.push_back(static_cast<int>(res.locations.size()));
      res.locations.push_back(closestPoint(surface, pts[i], tr.region));
    }
    rod.vertices.push_back(vertexOfNode(l.b));
    ++nodeRods[l.a];
    ++nodeRods[l.b];
    sc.rods.push_back(std::move(rod));
    rodLengths.push_back(L);
    if (l.cellA >= 0) ++cellSides[l.cellA];
    if (l.cellB >= 0) ++cellSides[l.cellB];
  }
  if (sc.rods.empty()) throw InputError(surface.sourcePath + ": no rod could be traced on the surface");

  // ---- geometry, normals, radii
  const std::vector<Vec3> vn = vertexNormals(surface);
  const int nv = static_cast<int>(res.locations.size());
  sc.vertices.resize(nv);
  sc.normals.resize(nv);
  for (int i = 0; i < nv; ++i) {
    sc.vertices[i] = evalPoint(surface, res.locations[i]);
    sc.normals[i] = evalNormal(surface, vn, res.locations[i]);
  }
  // Guard the contract: no zero-length edges.
  for (const Rod& r : sc.rods)
    for (std::size_t i = 1; i < r.vertices.size(); ++i)
      if (!((sc.vertices[r.vertices[i]] - sc.vertices[r.vertices[i - 1]]).norm() > 0))
        throw std::runtime_error("internal error: zero-length rod edge while meshing " + surface.sourcePath);
  sc.radii.assign(nv, opt.radius);
  sc.material = opt.material;
  sc.gravity = opt.gravity;
  sc.design.present = true;
  sc.design.radii = opt.designRadii;
  sc.design.restShape = opt.designRestShape;
  sc.design.hasRadiusBounds = true;
  sc.design.radiusMin = opt.radiusMin;
  sc.design.radiusMax = opt.radiusMax;
  sc.design.controlPointsPerRod = opt.controlPointsPerRod;

  // ---- boundary conditions
  std::set<int> fixedSet;
  for (const FixBox& b : opt.fixBoxes) {
    int count = 0;
    for (int i = 0; i < nv; ++i)
      if ((sc.vertices[i].array() >= b.lo.array()).all() && (sc.vertices[i].array() <= b.hi.array()).all()) {
        fixedSet.insert(i);
        ++count;
      }
    if (count == 0) {
      std::ostringstream m;
      m << "--fix-box " << b.lo.transpose() << " " << b.hi.transpose() << " contains no rod vertex";
      throw InputError(m.str());
    }
  }
  for (int sv : opt.fixSurfaceVertices) {
    if (sv < 0 || sv >= static_cast<int>(surface.vertices.size()))
      throw InputError("--fix-vertices: surface vertex " + std::to_string(sv) + " does not exist (the surface has " +
                       std::to_string(surface.vertices.size()) + " vertices)");
    int best = 0;
    for (int i = 1; i < nv; ++i)
      if ((sc.vertices[i] - surface.vertices[sv]).squaredNorm() < (sc.vertices[best] - surface.vertices[sv]).squaredNorm())
        best = i;
    fixedSet.insert(best);
  }
  rep.fixedVertices = static_cast<int>(fixedSet.size());
  if (poses.empty()) {
    Pose p;
    p.name = "rest";
    for (int v : fixedSet) p.fixed.push_back(FixedVertex{v, std::nullopt});
    sc.poses.push_back(std::move(p));
  }
  std::set<std::string> names;
  for (const DeformedPose& dp : poses) {
    Pose p;
    p.name = dp.name;
    for (int k = 2; !names.insert(p.name).second; ++k) p.name = dp.name + "_" + std::to_string(k);
    p.target.resize(nv);
    for (int i = 0; i < nv; ++i) p.target[i] = evalPoint(dp.surface, res.locations[i]);
    for (int v : fixedSet) p.fixed.push_back(FixedVertex{v, p.target[v]});
    sc.poses.push_back(std::move(p));
  }

  // ---- report
  rep.cells = lay.numCells;
  for (int c = 0; c < lay.numCells; ++c) {
    if (lay.cellOpen[c]) {
      ++rep.openCells;
      continue;
    }
    auto it = cellSides.find(c);
    if (it == cellSides.end()) continue;
    ++rep.polygonSides[it->second];
    ++rep.closedCells;
    if (!lay.cellOnBoundary.empty() && lay.cellOnBoundary[c]) continue;
    ++rep.interiorCells;
    if (it->second == 6) ++rep.interiorHexagons;
  }
  rep.hexagonShare = rep.closedCells ? static_cast<double>(rep.polygonSides[6]) / rep.closedCells : 0.0;
  rep.interiorHexagonShare = rep.interiorCells ? static_cast<double>(rep.interiorHexagons) / rep.interiorCells : 0.0;
  if (rep.polygonSides[6] == 0) rep.polygonSides.erase(6);
  for (std::size_t n = 0; n < lay.nodes.size(); ++n) {
    if (nodeRods[n] == 0) continue;
    ++rep.valence[nodeRods[n]];
    if (nodeRods[n] == 1) ++rep.freeEnds;
    else ++rep.connections;
  }
  rep.vertices = nv;
  rep.rods = static_cast<int>(sc.rods.size());
  for (const Rod& r : sc.rods) rep.edges += static_cast<int>(r.vertices.size()) - 1;
  rep.minRodLength = *std::min_element(rodLengths.begin(), rodLengths.end());
  rep.maxRodLength = *std::max_element(rodLengths.begin(), rodLengths.end());
  rep.meanRodLength = std::accumulate(rodLengths.begin(), rodLengths.end(), 0.0) / rodLengths.size();
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

std::string formatReport(const MeshReport& r) {
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(1);
  o << "rod mesh: " << r.vertices << " vertices, " << r.edges << " edges, " << r.rods << " rods, " << r.connections
    << " connections, " << r.freeEnds << " free ends\n";
  o << "cells: " << r.cells << " (" << r.closedCells << " closed, " << r.openCells << " open at the boundary); hexagons "
    << 100.0 * r.hexagonShare << "% of closed cells";
  if (r.interiorCells != r.closedCells)
    o << ", " << 100.0 * r.interiorHexagonShare << "% of the " << r.interiorCells << " cells away from the boundary";
  o << "\n";
  o << "cell sides:";
  for (auto [k, n] : r.polygonSides) o << " " << k << ":" << n;
  o << "\nconnection valence:";
  for (auto [k, n] : r.valence) o << " " << k << ":" << n;
  o.precision(2);
  o << "\nrod length: min " << 1e3 * r.minRodLength << " mm, mean " << 1e3 * r.meanRodLength << " mm, max "
    << 1e3 * r.maxRodLength << " mm; edge length " << 1e3 * r.edgeLength << " mm\n";
  if (r.cvt.workFaces > 0)
    o << "CVT: " << r.cvt.iterations << " Lloyd iterations (" << (r.cvt.converged ? "converged" : "iteration limit")
      << ") on " << r.cvt.workVertices << " refined vertices; " << r.cvt.mergedLinks << " short Voronoi edges contracted\n";
  if (r.fixedVertices) o << "fixed rod vertices: " << r.fixedVertices << "\n";
  o << "time: " << r.seconds << " s\n";
  return o.str();
}

namespace {
struct Token {
  std::string text;
  int line;
};

// Whitespace, comma or semicolon separated tokens with their 1-based lines;
// '#' starts a comment.
std::vector<Token> tokens(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open file");
  std::vector<Token> out;
  std::string line;
  int lineNo = 0;
  while (std::getline(in, line)) {  // bounded by the file
    ++lineNo;
    line = line.substr(0, line.find('#'));
    for (char& c : line)
      if (c == ',' || c == ';') c = ' ';
    std::istringstream ls(line);
    std::string t;
    while (ls >> t) out.push_back({t, lineNo});
  }
  return out;
}
}  // namespace

std::vector<double> readDensityFile(const std::string& path, int nsv) {
  std::vector<double> d;
  for (const Token& t : tokens(path)) {
    char* end = nullptr;
    const double v = std::strtod(t.text.c_str(), &end);
    if (end != t.text.c_str() + t.text.size() || !std::isfinite(v) || !(v > 0))
      throw InputError(path + ": line " + std::to_string(t.line) + ": value " + std::to_string(d.size()) + " ('" +
                       t.text + "') must be a positive finite number");
    d.push_back(v);
  }
  if (static_cast<int>(d.size()) != nsv)
    throw InputError(path + ": has " + std::to_string(d.size()) + " density values; the surface has " +
                     std::to_string(nsv) + " vertices (one value per vertex expected)");
  return d;
}

std::vector<int> readVertexListFile(const std::string& path, int nsv) {
  std::vector<int> out;
  for (const Token& t : tokens(path)) {
    // Digits only ("2.5", "3abc", "1e3", "-1" are not indices), at most 18 of them (no overflow).
    const bool digits =
        !t.text.empty() && t.text.size() <= 18 && t.text.find_first_not_of("0123456789") == std::string::npos;
    const long long v = digits ? std::stoll(t.text) : -1;
    if (!digits || v >= nsv)
      throw InputError(path + ": line " + std::to_string(t.line) + ": entry '" + t.text +
                       "' is not a surface vertex index in [0, " + std::to_string(nsv) + ")");
    out.push_back(static_cast<int>(v));
  }
  if (out.empty()) throw InputError(path + ": lists no vertices");
  return out;
}

}  // namespace rodmesh::meshing
