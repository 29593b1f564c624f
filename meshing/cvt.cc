#include "meshing/cvt.hh"

#include "io/scene_reader.hh"

#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <numeric>
#include <queue>
#include <set>
#include <unordered_map>

namespace rodmesh::meshing {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::uint64_t ukey(int a, int b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b);
}

// The refined ("work") mesh: same geometry as the input, finer triangles. Each
// work face remembers its input face and its corners' barycentric coordinates
// there, so any point on it maps back to a SurfacePoint of the input.
struct WorkMesh {
  std::vector<Vec3> V;
  std::vector<Tri> F;
  std::vector<int> parent;
  std::vector<std::array<Vec3, 3>> cornerBary;
};

// Longest-edge bisection (Rivara): an edge is split only once it is the
// longest edge of every face containing it, which keeps angles bounded.
class Refiner {
 public:
  Refiner(WorkMesh& m) : m_(m) {
    for (int f = 0; f < static_cast<int>(m_.F.size()); ++f)
      for (int i = 0; i < 3; ++i) edgeFaces_[ukey(m_.F[f][i], m_.F[f][(i + 1) % 3])].push_back(f);
  }

  void refine(double ell, int maxFaces) {
    const double ell2 = ell * ell;
    for (int f = 0; f < static_cast<int>(m_.F.size()); ++f) {
      while (static_cast<int>(m_.F.size()) < maxFaces) {
        const int i = longestCorner(f);
        const int a = m_.F[f][i], b = m_.F[f][(i + 1) % 3];
        if (len2(a, b) <= ell2) break;
        splitEdge(a, b);
      }
    }
  }

 private:
  double len2(int a, int b) const { return (m_.V[a] - m_.V[b]).squaredNorm(); }

  int longestCorner(int f) const {
    int best = 0;
    double bl = -1;
    for (int i = 0; i < 3; ++i) {
      const int a = m_.F[f][i], b = m_.F[f][(i + 1) % 3];
      const double l = len2(a, b);
      // Deterministic tie-break on vertex ids (regular grids have many ties).
      if (l > bl * (1 + 1e-12) || (std::abs(l - bl) <= 1e-12 * bl && ukey(a, b) < ukey(m_.F[f][best], m_.F[f][(best + 1) % 3]))) {
        bl = l;
        best = i;
      }
    }
    return best;
  }

  void splitEdge(int a, int b) {
    for (;;) {
      bool changed = false;
      const std::vector<int> faces = edgeFaces_[ukey(a, b)];
      for (int g : faces) {
        const int i = longestCorner(g);
        const int u = m_.F[g][i], v = m_.F[g][(i + 1) % 3];
        if (ukey(u, v) != ukey(a, b) && len2(u, v) > len2(a, b) * (1 + 1e-12)) {
          splitEdge(u, v);
          changed = true;
          break;
        }
      }
      if (!changed) break;
    }
    const int m = static_cast<int>(m_.V.size());
    m_.V.push_back(0.5 * (m_.V[a] + m_.V[b]));
    const std::vector<int> faces = edgeFaces_[ukey(a, b)];
    for (int g : faces) splitFace(g, a, b, m);
    edgeFaces_.erase(ukey(a, b));
  }

  void splitFace(int g, int a, int b, int m) {
    int i = 0;
    while (!((m_.F[g][i] == a && m_.F[g][(i + 1) % 3] == b) || (m_.F[g][i] == b && m_.F[g][(i + 1) % 3] == a))) ++i;
    const int p = m_.F[g][i], q = m_.F[g][(i + 1) % 3], r = m_.F[g][(i + 2) % 3];
    const Vec3 bp = m_.cornerBary[g][i], bq = m_.cornerBary[g][(i + 1) % 3], br = m_.cornerBary[g][(i + 2) % 3];
    const Vec3 bm = 0.5 * (bp + bq);
    const int h = static_cast<int>(m_.F.size());
    m_.F[g] = {p, m, r};
    m_.cornerBary[g] = {bp, bm, br};
    m_.F.push_back({m, q, r});
    m_.cornerBary.push_back({bm, bq, br});
    m_.parent.push_back(m_.parent[g]);
    auto remove = [&](std::uint64_t k, int f) {
      auto& v = edgeFaces_[k];
      v.erase(std::remove(v.begin(), v.end(), f), v.end());
    };
    remove(ukey(q, r), g);
    edgeFaces_[ukey(p, m)].push_back(g);
    edgeFaces_[ukey(m, r)].push_back(g);
    edgeFaces_[ukey(m, q)].push_back(h);
    edgeFaces_[ukey(q, r)].push_back(h);
    edgeFaces_[ukey(m, r)].push_back(h);
  }

  WorkMesh& m_;
  std::unordered_map<std::uint64_t, std::vector<int>> edgeFaces_;
};

// Compressed adjacency with edge lengths.
struct Graph {
  std::vector<int> start, nbr;
  std::vector<double> len;
};

Graph buildGraph(const WorkMesh& m) {
  const int nv = static_cast<int>(m.V.size());
  std::vector<std::vector<int>> adj(nv);
  for (const Tri& t : m.F)
    for (int i = 0; i < 3; ++i) {
      adj[t[i]].push_back(t[(i + 1) % 3]);
      adj[t[(i + 1) % 3]].push_back(t[i]);
    }
  Graph g;
  g.start.assign(nv + 1, 0);
  for (int v = 0; v < nv; ++v) {
    auto& a = adj[v];
    std::sort(a.begin(), a.end());
    a.erase(std::unique(a.begin(), a.end()), a.end());
    g.start[v + 1] = g.start[v] + static_cast<int>(a.size());
    for (int w : a) {
      g.nbr.push_back(w);
      g.len.push_back((m.V[v] - m.V[w]).norm());
    }
  }
  return g;
}

// Multi-source Dijkstra; `scale` (per vertex, may be empty) multiplies edge
// lengths by the mean of its endpoint values. Only improves existing
// distances, so it can be called incrementally.
void dijkstra(const Graph& g, const std::vector<int>& sources, const std::vector<int>& sourceLabels,
              const std::vector<double>& scale, std::vector<double>& dist, std::vector<int>& label) {
  using QE = std::pair<double, int>;
  std::priority_queue<QE, std::vector<QE>, std::greater<QE>> q;
  for (std::size_t i = 0; i < sources.size(); ++i) {
    dist[sources[i]] = 0;
    label[sources[i]] = sourceLabels[i];
    q.push({0.0, sources[i]});
  }
  while (!q.empty()) {
    auto [d, v] = q.top();
    q.pop();
    if (d > dist[v]) continue;
    for (int k = g.start[v]; k < g.start[v + 1]; ++k) {
      const int w = g.nbr[k];
      const double l = scale.empty() ? g.len[k] : g.len[k] * 0.5 * (scale[v] + scale[w]);
      const double nd = d + l;
      if (nd < dist[w] || (nd == dist[w] && label[v] < label[w])) {
        const bool better = nd < dist[w];
        dist[w] = nd;
        label[w] = label[v];
        if (better) q.push({nd, w});
      }
    }
  }
}

double polylineLength(const std::vector<Vec3>& p) {
  double l = 0;
  for (std::size_t i = 1; i < p.size(); ++i) l += (p[i] - p[i - 1]).norm();
  return l;
}

}  // namespace

Layout cvtLayout(const TriSurface& surface, const SurfaceTopology& topo, const CvtOptions& opt,
                 const std::vector<double>& density, CvtReport* report) {
  const std::string& path = surface.sourcePath;
  if (opt.cells < 2) throw InputError(path + ": --cells must be at least 2 (got " + std::to_string(opt.cells) + ")");
  const int nIn = static_cast<int>(surface.vertices.size());
  if (!density.empty() && static_cast<int>(density.size()) != nIn)
    throw InputError(path + ": density has " + std::to_string(density.size()) + " values for " +
                     std::to_string(nIn) + " surface vertices");

  // ---- 1. refined work mesh
  WorkMesh wm;
  wm.V = surface.vertices;
  wm.F = surface.faces;
  wm.parent.resize(wm.F.size());
  std::iota(wm.parent.begin(), wm.parent.end(), 0);
  wm.cornerBary.assign(wm.F.size(), {Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)});
  const double area = surfaceArea(surface);
  double rhoMax = 1, rhoMean = 1;
  if (!density.empty()) {
    rhoMax = *std::max_element(density.begin(), density.end());
    rhoMean = std::accumulate(density.begin(), density.end(), 0.0) / nIn;
  }
  // Expected hexagon circumradius R from area / cells (hexagon area 2.6 R^2),
  // for the smallest cells (highest density: size ~ density^-1/4).
  const double cellArea = area / opt.cells;
  double R = std::sqrt(cellArea / 2.598) * std::pow(rhoMean / rhoMax, 0.25);
  double ell = R / opt.refinement;
  const double estFaces = area / (0.433 * ell * ell);
  if (estFaces > opt.maxWorkFaces) ell *= std::sqrt(estFaces / opt.maxWorkFaces);
  {
    Refiner r(wm);
    r.refine(ell, opt.maxWorkFaces);
  }
  const int nv = static_cast<int>(wm.V.size());
  const int nf = static_cast<int>(wm.F.size());
  // Per work vertex: a location on the input surface, an area weight, density.
  std::vector<SurfacePoint> vloc(nv);
  std::vector<char> used(nv, 0);
  std::vector<double> vArea(nv, 0.0), rho(nv, 1.0);
  for (int f = 0; f < nf; ++f) {
    const Tri& t = wm.F[f];
    const double a = 0.5 * (wm.V[t[1]] - wm.V[t[0]]).cross(wm.V[t[2]] - wm.V[t[0]]).norm();
    for (int i = 0; i < 3; ++i) {
      vArea[t[i]] += a / 3;
      if (!used[t[i]]) {
        used[t[i]] = 1;
        vloc[t[i]] = SurfacePoint{wm.parent[f], wm.cornerBary[f][i]};
        if (!density.empty()) {
          const Tri& pt = surface.faces[wm.parent[f]];
          const Vec3& b = wm.cornerBary[f][i];
          rho[t[i]] = b[0] * density[pt[0]] + b[1] * density[pt[1]] + b[2] * density[pt[2]];
        }
      }
    }
  }
  int usedCount = 0;
  for (char u : used) usedCount += u;
  if (opt.cells > usedCount / 4)
    throw InputError(path + ": --cells " + std::to_string(opt.cells) + " is too many for this surface");
  const Graph g = buildGraph(wm);

  // ---- 2. seeds by farthest-point sampling in the density-scaled metric
  std::vector<double> scale;
  if (!density.empty()) {
    scale.resize(nv);
    for (int v = 0; v < nv; ++v) scale[v] = std::pow(std::max(rho[v], 1e-12) / rhoMean, 0.25);
  }
  // ---- 3. Lloyd iterations. Seeds are points of the work mesh (face +
  // position). Cells are grown from the seeds along mesh edges, each vertex
  // keeping the seed nearest in straight-line distance among those whose cell
  // reaches it: a restricted Voronoi diagram kept connected on the surface,
  // free of the metrication error of graph distances.
  std::vector<int> vertexFace(nv, -1);
  for (int f = 0; f < nf; ++f)
    for (int v : wm.F[f])
      if (vertexFace[v] < 0) vertexFace[v] = f;
  std::vector<int> seedFace(opt.cells);
  std::vector<Vec3> seedPos(opt.cells);
  std::vector<double> dist(nv);
  std::vector<int> label(nv);
  auto assign = [&]() {
    std::fill(dist.begin(), dist.end(), kInf);
    std::fill(label.begin(), label.end(), -1);
    using QE = std::pair<double, int>;
    std::priority_queue<QE, std::vector<QE>, std::greater<QE>> q;
    for (int c = 0; c < opt.cells; ++c)
      for (int v : wm.F[seedFace[c]]) {
        const double d = (wm.V[v] - seedPos[c]).norm();
        if (d < dist[v]) {
          dist[v] = d;
          label[v] = c;
          q.push({d, v});
        }
      }
    while (!q.empty()) {
      auto [d, v] = q.top();
      q.pop();
      if (d > dist[v]) continue;
      const int c = label[v];
      for (int k = g.start[v]; k < g.start[v + 1]; ++k) {
        const int w = g.nbr[k];
        const double dw = (wm.V[w] - seedPos[c]).norm();
        if (dw < dist[w]) {
          dist[w] = dw;
          label[w] = c;
          q.push({dw, w});
        }
      }
    }
  };
  // Lloyd converges to a local minimum whose defects (5-7 pairs) depend on
  // the start: try several farthest-point starts, keep the lowest CVT energy.
  double bestEnergy = kInf;
  std::vector<Vec3> bestPos;
  std::vector<int> bestFace;
  int bestIt = 0, totalIt = 0;
  bool bestConverged = false;
  for (int attempt = 0; attempt < std::max(1, opt.restarts); ++attempt) {
    std::vector<int> seeds;
    {
      std::vector<double> dist(nv, kInf);
      std::vector<int> lab(nv, -1);
      int first = static_cast<int>((static_cast<long long>(attempt) * nv) / std::max(1, opt.restarts));
      while (!used[first]) first = (first + 1) % nv;
      dijkstra(g, {first}, {0}, scale, dist, lab);
      int far = first;
      for (int v = 0; v < nv; ++v)
        if (used[v] && dist[v] > dist[far]) far = v;
      std::fill(dist.begin(), dist.end(), kInf);
      std::fill(lab.begin(), lab.end(), -1);
      int next = far;
      for (int c = 0; c < opt.cells; ++c) {
        seeds.push_back(next);
        dijkstra(g, {next}, {c}, scale, dist, lab);
        next = -1;
        for (int v = 0; v < nv; ++v)
          if (used[v] && (next < 0 || dist[v] > dist[next])) next = v;
      }
    }

    for (int c = 0; c < opt.cells; ++c) {
      seedFace[c] = vertexFace[seeds[c]];
      seedPos[c] = wm.V[seeds[c]];
    }
    int it = 0;
    bool converged = false;
    const double tol = opt.tolerance * R;
    for (; it < opt.maxIterations; ++it) {
      assign();
      std::vector<Vec3> csum(opt.cells, Vec3::Zero());
      std::vector<double> wsum(opt.cells, 0.0);
      for (int v = 0; v < nv; ++v) {
        if (label[v] < 0) continue;
        const double w = vArea[v] * rho[v];
        csum[label[v]] += w * wm.V[v];
        wsum[label[v]] += w;
      }
      // Project each centroid onto its own cell (faces touching the cell).
      std::vector<double> bestD(opt.cells, kInf);
      std::vector<int> bestF(opt.cells, -1);
      std::vector<Vec3> bestP(opt.cells);
      for (int f = 0; f < nf; ++f) {
        const Tri& t = wm.F[f];
        for (int i = 0; i < 3; ++i) {
          const int c = label[t[i]];
          if (c < 0 || wsum[c] <= 0 || (i > 0 && (c == label[t[0]] || (i > 1 && c == label[t[1]])))) continue;
          const Vec3 target = csum[c] / wsum[c];
          const Vec3 b = closestPointBary(target, wm.V[t[0]], wm.V[t[1]], wm.V[t[2]]);
          const Vec3 p = b[0] * wm.V[t[0]] + b[1] * wm.V[t[1]] + b[2] * wm.V[t[2]];
          const double d = (p - target).squaredNorm();
          if (d < bestD[c]) {
            bestD[c] = d;
            bestF[c] = f;
            bestP[c] = p;
          }
        }
      }
      double move = 0;
      for (int c = 0; c < opt.cells; ++c) {
        if (bestF[c] < 0) continue;
        move = std::max(move, (bestP[c] - seedPos[c]).norm());
        seedPos[c] = bestP[c];
        seedFace[c] = bestF[c];
      }
      if (move < tol) {
        converged = true;
        break;
      }
    }
    assign();
    {
      double energy = 0;
      for (int v = 0; v < nv; ++v)
        if (label[v] >= 0) energy += vArea[v] * rho[v] * (wm.V[v] - seedPos[label[v]]).squaredNorm();
      if (energy < bestEnergy) {
        bestEnergy = energy;
        bestPos = seedPos;
        bestFace = seedFace;
        bestIt = it;
        bestConverged = converged;
      }
      totalIt += it;
    }
  }
  seedPos = bestPos;
  seedFace = bestFace;
  const int it = bestIt;
  const bool converged = bestConverged;
  assign();

  // ---- 4. Voronoi graph on the work mesh
  TriSurface workSurface;
  workSurface.vertices = wm.V;
  workSurface.faces = wm.F;
  SurfaceTopology wtopo(workSurface);

  auto toInput = [&](int f, const Vec3& bw) {
    SurfacePoint p;
    p.face = wm.parent[f];
    p.bary = bw[0] * wm.cornerBary[f][0] + bw[1] * wm.cornerBary[f][1] + bw[2] * wm.cornerBary[f][2];
    return p;
  };
  struct GNode {
    bool triple = false;
    int face = -1, corner = -1;  // crossing: work face and corner i of edge (i, i+1); triple: face
    std::vector<int> adj;
    SurfacePoint at;
    Vec3 pos;
  };
  std::vector<GNode> gn;
  std::unordered_map<std::uint64_t, int> crossingOf;
  auto crossing = [&](int f, int i) {
    const int u = wm.F[f][i], v = wm.F[f][(i + 1) % 3];
    auto it = crossingOf.find(ukey(u, v));
    if (it != crossingOf.end()) return it->second;
    GNode n;
    n.face = f;
    n.corner = i;
    const Vec3 d = wm.V[v] - wm.V[u];
    const Vec3 sa = seedPos[label[u]] - wm.V[u], sb = seedPos[label[v]] - wm.V[u];
    const double den = 2 * d.dot(sb - sa);
    double t = 0.5;
    if (std::abs(den) > 1e-300) t = (sb.squaredNorm() - sa.squaredNorm()) / den;
    if (!(t >= 0.02)) t = 0.02;
    if (!(t <= 0.98)) t = 0.98;
    Vec3 bw = Vec3::Zero();
    bw[i] = 1 - t;
    bw[(i + 1) % 3] = t;
    n.at = toInput(f, bw);
    n.pos = (1 - t) * wm.V[u] + t * wm.V[v];
    gn.push_back(n);
    return crossingOf[ukey(u, v)] = static_cast<int>(gn.size()) - 1;
  };
  auto link = [&](int x, int y) {
    gn[x].adj.push_back(y);
    gn[y].adj.push_back(x);
  };
  for (int f = 0; f < nf; ++f) {
    const Tri& t = wm.F[f];
    const int l0 = label[t[0]], l1 = label[t[1]], l2 = label[t[2]];
    if (l0 == l1 && l1 == l2) continue;
    std::vector<int> cr;
    for (int i = 0; i < 3; ++i)
      if (label[t[i]] != label[t[(i + 1) % 3]]) cr.push_back(crossing(f, i));
    if (cr.size() == 2) {
      link(cr[0], cr[1]);
    } else {
      GNode n;
      n.triple = true;
      n.face = f;
      // The point of the triangle's plane equidistant from the three seeds.
      const Vec3 p0 = wm.V[t[0]], e1 = wm.V[t[1]] - p0, e2 = wm.V[t[2]] - p0;
      const Vec3 s0 = seedPos[l0] - p0, s1 = seedPos[l1] - p0, s2 = seedPos[l2] - p0;
      Eigen::Matrix2d A;
      Eigen::Vector2d rhs;
      A << 2 * e1.dot(s1 - s0), 2 * e2.dot(s1 - s0), 2 * e1.dot(s2 - s0), 2 * e2.dot(s2 - s0);
      rhs << s1.squaredNorm() - s0.squaredNorm(), s2.squaredNorm() - s0.squaredNorm();
      Vec3 bw(1.0 / 3, 1.0 / 3, 1.0 / 3);
      if (std::abs(A.determinant()) > 1e-12 * A.squaredNorm()) {
        const Eigen::Vector2d lam = A.partialPivLu().solve(rhs);
        Vec3 b(1 - lam[0] - lam[1], lam[0], lam[1]);
        if (b.allFinite()) {
          // Clamp into the triangle (slightly inside, away from its edges).
          b = b.cwiseMax(0.05);
          bw = b / b.sum();
        }
      }
      n.at = toInput(f, bw);
      n.pos = bw[0] * wm.V[t[0]] + bw[1] * wm.V[t[1]] + bw[2] * wm.V[t[2]];
      gn.push_back(n);
      const int id = static_cast<int>(gn.size()) - 1;
      for (int c : cr) link(id, c);
    }
  }
  auto isBranch = [&](int x) { return gn[x].triple || gn[x].adj.size() != 2; };
  auto cellsOf = [&](int x) -> std::pair<int, int> {
    const Tri& t = wm.F[gn[x].face];
    return {label[t[gn[x].corner]], label[t[(gn[x].corner + 1) % 3]]};
  };

  Layout lay;
  lay.numCells = opt.cells;
  lay.cellOpen.assign(opt.cells, 0);
  lay.cellOnBoundary.assign(opt.cells, 0);
  std::vector<int> nodeOf(gn.size(), -1);
  auto layoutNode = [&](int x) {
    if (nodeOf[x] < 0) {
      LayoutNode n;
      n.at = gn[x].at;
      n.onBoundary = !gn[x].triple && gn[x].adj.size() == 1;
      lay.nodes.push_back(n);
      nodeOf[x] = static_cast<int>(lay.nodes.size()) - 1;
    }
    return nodeOf[x];
  };
  std::vector<char> visited(gn.size(), 0);
  auto addChainLink = [&](const std::vector<int>& chain) {
    // chain: graph nodes from one branch node to another, inclusive.
    LayoutLink l;
    l.a = layoutNode(chain.front());
    l.b = layoutNode(chain.back());
    int crossingNode = -1;
    for (int x : chain)
      if (!gn[x].triple) {
        crossingNode = x;
        break;
      }
    if (crossingNode >= 0) std::tie(l.cellA, l.cellB) = cellsOf(crossingNode);
    std::vector<Vec3> pts;
    for (int x : chain) pts.push_back(gn[x].pos);
    l.lengthHint = polylineLength(pts);
    for (int x : chain) l.given.push_back(gn[x].at);
    l.path = LinkPath::Geodesic;
    lay.links.push_back(std::move(l));
  };
  for (int x = 0; x < static_cast<int>(gn.size()); ++x) {
    if (!isBranch(x)) continue;
    for (int y : gn[x].adj) {
      if (isBranch(y)) {
        if (x < y) addChainLink({x, y});
        continue;
      }
      if (visited[y]) continue;
      std::vector<int> chain{x};
      int prev = x, cur = y;
      while (!isBranch(cur)) {
        visited[cur] = 1;
        chain.push_back(cur);
        const int nxt = gn[cur].adj[0] == prev ? gn[cur].adj[1] : gn[cur].adj[0];
        prev = cur;
        cur = nxt;
      }
      chain.push_back(cur);
      addChainLink(chain);
    }
  }
  // Closed cell boundaries without any junction (a cell enclosed by another,
  // or a band around a handle): split each loop with two valence-2 nodes.
  for (int x = 0; x < static_cast<int>(gn.size()); ++x) {
    if (isBranch(x) || visited[x]) continue;
    std::vector<int> cycle{x};
    visited[x] = 1;
    int prev = x, cur = gn[x].adj[0];
    while (cur != x) {
      visited[cur] = 1;
      cycle.push_back(cur);
      const int nxt = gn[cur].adj[0] == prev ? gn[cur].adj[1] : gn[cur].adj[0];
      prev = cur;
      cur = nxt;
    }
    if (cycle.size() < 4) continue;
    const std::size_t h = cycle.size() / 2;
    std::vector<int> c1(cycle.begin(), cycle.begin() + h + 1);
    std::vector<int> c2(cycle.begin() + h, cycle.end());
    c2.push_back(cycle.front());
    addChainLink(c1);
    addChainLink(c2);
  }

  // ---- 5. open surfaces
  for (const auto& loop : wtopo.boundaryLoops) {
    const int n = static_cast<int>(loop.size());
    for (int v : loop) {
      lay.cellOpen[label[v]] = opt.boundary == BoundaryMode::Free;
      lay.cellOnBoundary[label[v]] = 1;
    }
    if (opt.boundary == BoundaryMode::Free) continue;
    std::vector<int> cuts;  // edge indices i (loop[i] -> loop[i+1]) crossed by a cell boundary
    for (int i = 0; i < n; ++i)
      if (label[loop[i]] != label[loop[(i + 1) % n]]) cuts.push_back(i);
    auto vertexNode = [&](int v) {
      LayoutNode nd;
      nd.at = vloc[v];
      nd.onBoundary = true;
      lay.nodes.push_back(nd);
      return static_cast<int>(lay.nodes.size()) - 1;
    };
    auto crossingNodeOf = [&](int i) {
      return layoutNode(crossingOf.at(ukey(loop[i], loop[(i + 1) % n])));
    };
    // Node ids and positions at the cut points along the loop, in order.
    struct Cut {
      int node;
      int edge;       // cut on edge `edge`, or at vertex loop[vertex]
      int vertex;
    };
    std::vector<Cut> cutList;
    for (int i : cuts) cutList.push_back({crossingNodeOf(i), i, -1});
    if (cutList.size() < 2) {
      // Add nodes at loop vertices so that the rim has at least two rods.
      const int base = cutList.empty() ? 0 : (cutList[0].edge + 1) % n;
      const int first = cutList.empty() ? base : (cutList[0].edge + 1 + n / 2) % n;
      cutList.push_back({vertexNode(loop[first]), -1, first});
      if (cutList.size() < 2) cutList.push_back({vertexNode(loop[(first + n / 2) % n]), -1, (first + n / 2) % n});
      auto pos = [&](const Cut& c) { return c.edge >= 0 ? c.edge + 0.5 : static_cast<double>(c.vertex); };
      std::sort(cutList.begin(), cutList.end(), [&](const Cut& a, const Cut& b) { return pos(a) < pos(b); });
    }
    const int nc = static_cast<int>(cutList.size());
    for (int k = 0; k < nc; ++k) {
      const Cut& c0 = cutList[k];
      const Cut& c1 = cutList[(k + 1) % nc];
      LayoutLink l;
      l.a = c0.node;
      l.b = c1.node;
      l.path = LinkPath::Given;
      l.given.push_back(lay.nodes[c0.node].at);
      std::vector<Vec3> pts{evalPoint(surface, lay.nodes[c0.node].at)};
      // Loop vertices strictly after c0 up to (and including) the last before c1.
      int v = c0.edge >= 0 ? (c0.edge + 1) % n : (c0.vertex + 1) % n;
      const int stop = c1.edge >= 0 ? (c1.edge + 1) % n : c1.vertex;
      int cell = label[loop[v]];
      for (int guard = 0; v != stop && guard < n; ++guard, v = (v + 1) % n) {
        l.given.push_back(vloc[loop[v]]);
        pts.push_back(wm.V[loop[v]]);
      }
      l.given.push_back(lay.nodes[c1.node].at);
      pts.push_back(evalPoint(surface, lay.nodes[c1.node].at));
      l.cellA = cell;
      l.lengthHint = polylineLength(pts);
      lay.links.push_back(std::move(l));
    }
  }

  // ---- 6. contract very short Voronoi edges
  int merged = 0;
  if (opt.mergeFraction > 0 && !lay.links.empty()) {
    std::vector<double> lens;
    for (const auto& l : lay.links) lens.push_back(l.lengthHint);
    std::vector<double> sorted = lens;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double thr = opt.mergeFraction * sorted[sorted.size() / 2];
    std::vector<int> rep(lay.nodes.size());
    std::iota(rep.begin(), rep.end(), 0);
    std::function<int(int)> find = [&](int x) { return rep[x] == x ? x : rep[x] = find(rep[x]); };
    std::vector<int> order(lay.links.size());
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](int a, int b) { return lens[a] < lens[b]; });
    for (int k : order) {
      const LayoutLink& l = lay.links[k];
      if (l.path != LinkPath::Geodesic || lens[k] >= thr) continue;
      int a = find(l.a), b = find(l.b);
      if (a == b) continue;
      if (lay.nodes[a].onBoundary && lay.nodes[b].onBoundary) continue;
      if (lay.nodes[a].onBoundary) std::swap(a, b);  // keep the boundary node
      rep[a] = b;
      ++merged;
    }
    std::set<std::pair<int, int>> seen;
    std::vector<LayoutLink> kept;
    for (std::size_t k = 0; k < lay.links.size(); ++k) {
      LayoutLink l = lay.links[k];
      const bool moved = find(l.a) != l.a || find(l.b) != l.b;
      l.a = find(l.a);
      l.b = find(l.b);
      if (l.a == l.b) continue;
      if (l.path == LinkPath::Geodesic) {
        auto key = std::minmax(l.a, l.b);
        if (!seen.insert(key).second) continue;
        if (moved) l.lengthHint += 4 * thr;
      }
      kept.push_back(std::move(l));
    }
    lay.links = std::move(kept);
  }
  // Compact: keep only nodes used by links.
  {
    std::vector<int> newId(lay.nodes.size(), -1);
    std::vector<LayoutNode> nodes;
    for (auto& l : lay.links)
      for (int* e : {&l.a, &l.b}) {
        if (newId[*e] < 0) {
          newId[*e] = static_cast<int>(nodes.size());
          nodes.push_back(lay.nodes[*e]);
        }
        *e = newId[*e];
      }
    lay.nodes = std::move(nodes);
    for (auto& l : lay.links)
      if (l.path == LinkPath::Given) {
        l.given.front() = lay.nodes[l.a].at;
        l.given.back() = lay.nodes[l.b].at;
      }
  }
  if (report) {
    report->workVertices = usedCount;
    report->workFaces = nf;
    report->iterations = it;
    report->converged = converged;
    report->mergedLinks = merged;
  }
  (void)topo;
  return lay;
}

}  // namespace rodmesh::meshing
