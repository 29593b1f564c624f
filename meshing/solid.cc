#include "meshing/solid.hh"

#include "io/scene_reader.hh"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numeric>
#include <unordered_map>

namespace rodmesh::meshing {
namespace {

// Polynomial smooth minimum (Quilez): equals min(a, b) when |a - b| >= k.
inline double smin(double a, double b, double k) {
  if (k <= 0) return std::min(a, b);
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k * 0.25;
}

struct PreparedEdge {
  Vec3 p0, t, d1, d2;
  double L;
  Vec2 r0, r1;
  int rod;
  Vec3 lo, hi;  // influence box
};

inline double edgeField(const PreparedEdge& e, const Vec3& x) {
  const Vec3 y = x - e.p0;
  const double s = y.dot(e.t);
  const double sc = std::clamp(s, 0.0, e.L);
  const double w = s - sc;
  const double a = e.L > 0 ? sc / e.L : 0.0;
  const double rt = (1 - a) * e.r0[0] + a * e.r1[0];
  const double rn = (1 - a) * e.r0[1] + a * e.r1[1];
  const double c = std::max(rt, rn);
  const double u = y.dot(e.d1), v = y.dot(e.d2);
  const double q = std::sqrt((u / rt) * (u / rt) + (v / rn) * (v / rn) + (w / c) * (w / c));
  return (q - 1) * std::min(rt, rn);
}

// The six tetrahedra of the Kuhn split of the unit cube, as corner bit masks
// (bit 0: +x, bit 1: +y, bit 2: +z), each positively oriented.
struct KuhnTets {
  std::array<std::array<int, 4>, 6> tets;
  KuhnTets() {
    const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (int k = 0; k < 6; ++k) {
      const int a = 1 << perms[k][0], b = 1 << perms[k][1];
      std::array<int, 4> t{0, a, a | b, 7};
      auto corner = [](int c) { return Vec3(c & 1, (c >> 1) & 1, (c >> 2) & 1); };
      const double det = (corner(t[1]) - corner(t[0]))
                             .cross(corner(t[2]) - corner(t[0]))
                             .dot(corner(t[3]) - corner(t[0]));
      if (det < 0) std::swap(t[2], t[3]);
      tets[k] = t;
    }
  }
};

constexpr int kBlock = 40;              // grid cells per block side
constexpr double kMaxResolution = 1.0;  // [m], validateOptions

// Marching tetrahedra on the Kuhn split give about this many triangles per
// h^2 of surface (measured: 8.7 on the hat at 0.4 and 0.8 mm).
constexpr double kTrianglesPerArea = 9.0;

// Work of sampling the edges' boxes (each padded by h, the whole grid by 2h
// more) with step h.
SolidWork estimateWork(const std::vector<PreparedEdge>& edges, double tubeArea, double h) {
  SolidWork w;
  w.triangles = kTrianglesPerArea * tubeArea / (h * h);
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  double volume = 0;
  for (const PreparedEdge& p : edges) {
    volume += (p.hi - p.lo + Vec3::Constant(2 * h)).prod();
    lo = lo.cwiseMin(p.lo);
    hi = hi.cwiseMax(p.hi);
  }
  w.samples = volume / (h * h * h);
  w.blocks = 1;
  for (int d = 0; d < 3; ++d) w.blocks *= std::ceil(((hi[d] - lo[d]) / h + 7) / kBlock);
  return w;
}

std::string fmtShort(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// Up to two significant digits, rounded up (a step to suggest).
double roundUp(double v) {
  const double e = std::pow(10.0, std::floor(std::log10(v)) - 1);
  return std::ceil(v / e) * e;
}

int permutationParity(const std::array<int, 4>& p) {
  int inv = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j)
      if (p[i] > p[j]) ++inv;
  return inv & 1;
}

}  // namespace

IndexedMesh sweepRods(const std::vector<SweepEdge>& input, const SolidOptions& opt, SolidReport* reportOut) {
  const auto t0 = std::chrono::steady_clock::now();
  validateOptions(opt);
  SolidReport localReport;
  SolidReport* report = reportOut ? reportOut : &localReport;
  IndexedMesh out;
  if (input.empty()) return out;
  // ---- resolution and fillet
  std::vector<double> minor;
  double rMin = std::numeric_limits<double>::infinity(), rMax = 0;
  for (const SweepEdge& e : input)
    for (const Vec2& r : {e.r0, e.r1}) {
      minor.push_back(r.minCoeff());
      rMin = std::min(rMin, r.minCoeff());
      rMax = std::max(rMax, r.maxCoeff());
    }
  std::nth_element(minor.begin(), minor.begin() + minor.size() / 2, minor.end());
  const double rMedian = minor[minor.size() / 2];
  double h = opt.resolution > 0 ? opt.resolution : std::max(rMin / 2.5, rMedian / 4);
  const double k = opt.fillet >= 0 ? opt.fillet : 0.5 * rMedian;

  std::vector<PreparedEdge> edges;
  edges.reserve(input.size());
  double tubeArea = 0;  // lateral area of the swept edges [m^2]
  for (std::size_t i = 0; i < input.size(); ++i) {
    const SweepEdge& e = input[i];
    if (!(e.p0.allFinite() && e.p1.allFinite() && e.d1.allFinite() && e.d2.allFinite() && e.r0.allFinite() &&
          e.r1.allFinite() && e.r0.minCoeff() > 0 && e.r1.minCoeff() > 0))
      throw InputError("rod edge " + std::to_string(i) +
                       ": non-finite position or frame, or a radius that is not "
                       "positive and finite");
    PreparedEdge p;
    p.p0 = e.p0;
    const Vec3 d = e.p1 - e.p0;
    p.L = d.norm();
    p.t = p.L > 0 ? Vec3(d / p.L) : e.d1.cross(e.d2);
    p.d1 = e.d1;
    p.d2 = e.d2;
    p.r0 = e.r0;
    p.r1 = e.r1;
    p.rod = e.rod;
    const double reach = std::max(e.r0.maxCoeff(), e.r1.maxCoeff()) + k;
    p.lo = e.p0.cwiseMin(e.p1) - Vec3::Constant(reach);
    p.hi = e.p0.cwiseMax(e.p1) + Vec3::Constant(reach);
    // Ellipse perimeter ~ pi (a + b), radii averaged over the edge.
    tubeArea += M_PI * 0.5 * (e.r0.sum() + e.r1.sum()) * p.L;
    edges.push_back(p);
  }

  // ---- bound the work before allocating anything of the grid's size
  const SolidWork need = estimateWork(edges, tubeArea, h);
  report->work = need;
  if (!need.within(opt)) {
    // About the finest step within the limits: every estimate falls as h
    // grows; start from the step that meets the triangle limit exactly.
    double hMin = std::max(h, std::sqrt(kTrianglesPerArea * tubeArea / opt.maxTriangles));
    for (int i = 0; i < 1000 && !estimateWork(edges, tubeArea, hMin).within(opt); ++i) hMin *= 1.02;
    const bool reachable = hMin <= kMaxResolution && estimateWork(edges, tubeArea, hMin).within(opt);
    if (opt.resolution > 0 || !reachable) {
      std::string m = "--resolution " + fmtShort(h) + " m would need about " + fmtShort(need.triangles) +
                      " triangles, " + fmtShort(need.samples) + " grid samples and " + fmtShort(need.blocks) +
                      " grid blocks (limits " + fmtShort(opt.maxTriangles) + ", " + fmtShort(opt.maxActivePoints) +
                      " and " + fmtShort(opt.maxBlocks) + ")";
      if (reachable)
        m += ": use --resolution " + fmtShort(roundUp(hMin)) + " or coarser";
      else
        m += "; no grid step up to " + fmtShort(kMaxResolution) +
             " m is within the limits: the design is too large "
             "to export";
      throw InputError(m);
    }
    h = hMin;  // the default step, coarsened to stay within the limits
    report->coarsened = true;
    report->work = estimateWork(edges, tubeArea, h);
  }
  // Pad boxes by a grid step so the contour never reaches a box's border.
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (PreparedEdge& p : edges) {
    p.lo -= Vec3::Constant(h);
    p.hi += Vec3::Constant(h);
    lo = lo.cwiseMin(p.lo);
    hi = hi.cwiseMax(p.hi);
  }
  lo -= Vec3::Constant(2 * h);
  hi += Vec3::Constant(2 * h);
  const long long nx = static_cast<long long>(std::ceil((hi.x() - lo.x()) / h)) + 1;
  const long long ny = static_cast<long long>(std::ceil((hi.y() - lo.y()) / h)) + 1;
  const long long nz = static_cast<long long>(std::ceil((hi.z() - lo.z()) / h)) + 1;
  const double far = h + k + rMax;  // value used away from every rod (outside)

  // ---- blocks
  constexpr int B = kBlock;
  const long long bx = (nx - 1 + B - 1) / B, by = (ny - 1 + B - 1) / B, bz = (nz - 1 + B - 1) / B;
  std::vector<std::vector<int>> blockEdges(bx * by * bz);
  auto cellRange = [&](double a, double b, double o, long long n, long long& i0, long long& i1) {
    i0 = std::max<long long>(0, static_cast<long long>(std::floor((a - o) / h)));
    i1 = std::min<long long>(n - 1, static_cast<long long>(std::ceil((b - o) / h)));
  };
  for (int ei = 0; ei < static_cast<int>(edges.size()); ++ei) {
    long long x0, x1, y0, y1, z0, z1;
    cellRange(edges[ei].lo.x(), edges[ei].hi.x(), lo.x(), nx, x0, x1);
    cellRange(edges[ei].lo.y(), edges[ei].hi.y(), lo.y(), ny, y0, y1);
    cellRange(edges[ei].lo.z(), edges[ei].hi.z(), lo.z(), nz, z0, z1);
    // Block c holds points [c B, c B + B]: neighbouring blocks share a layer
    // of points and must both see every edge that reaches it.
    auto first = [](long long i0) { return i0 > 0 ? (i0 - 1) / B : 0; };
    for (long long c = first(z0); c <= std::min(bz - 1, z1 / B); ++c)
      for (long long b = first(y0); b <= std::min(by - 1, y1 / B); ++b)
        for (long long a = first(x0); a <= std::min(bx - 1, x1 / B); ++a) blockEdges[a + bx * (b + by * c)].push_back(ei);
  }

  const KuhnTets kuhn;
  std::unordered_map<long long, int> vertexOf;  // (global point index * 8 + direction) -> vertex
  long long sampled = 0;
  constexpr int P = B + 1;  // points per block side
  std::vector<double> field(P * P * P), rodField(P * P * P);

  for (long long cz = 0; cz < bz; ++cz)
    for (long long cy = 0; cy < by; ++cy)
      for (long long cx = 0; cx < bx; ++cx) {
        const auto& list = blockEdges[cx + bx * (cy + by * cz)];
        if (list.empty()) continue;
        const long long gx0 = cx * B, gy0 = cy * B, gz0 = cz * B;
        const int px = static_cast<int>(std::min<long long>(P, nx - gx0));
        const int py = static_cast<int>(std::min<long long>(P, ny - gy0));
        const int pz = static_cast<int>(std::min<long long>(P, nz - gz0));
        std::fill(field.begin(), field.end(), far);
        // Group the block's edges by rod (list is in edge order, rods contiguous).
        std::vector<int> sortedList = list;
        std::stable_sort(sortedList.begin(), sortedList.end(),
                         [&](int a, int b) { return edges[a].rod < edges[b].rod; });
        std::size_t i = 0;
        while (i < sortedList.size()) {
          std::size_t j = i;
          const int rod = edges[sortedList[i]].rod;
          // Union of this rod's edge boxes inside the block, in local point indices.
          int b0[3] = {P, P, P}, b1[3] = {-1, -1, -1};
          std::vector<std::array<int, 6>> boxes;
          for (; j < sortedList.size() && edges[sortedList[j]].rod == rod; ++j) {
            const PreparedEdge& e = edges[sortedList[j]];
            long long r[6];
            cellRange(e.lo.x(), e.hi.x(), lo.x(), nx, r[0], r[1]);
            cellRange(e.lo.y(), e.hi.y(), lo.y(), ny, r[2], r[3]);
            cellRange(e.lo.z(), e.hi.z(), lo.z(), nz, r[4], r[5]);
            std::array<int, 6> q;
            q[0] = static_cast<int>(std::max<long long>(0, r[0] - gx0));
            q[1] = static_cast<int>(std::min<long long>(px - 1, r[1] - gx0));
            q[2] = static_cast<int>(std::max<long long>(0, r[2] - gy0));
            q[3] = static_cast<int>(std::min<long long>(py - 1, r[3] - gy0));
            q[4] = static_cast<int>(std::max<long long>(0, r[4] - gz0));
            q[5] = static_cast<int>(std::min<long long>(pz - 1, r[5] - gz0));
            boxes.push_back(q);
            for (int d = 0; d < 3; ++d) {
              b0[d] = std::min(b0[d], q[2 * d]);
              b1[d] = std::max(b1[d], q[2 * d + 1]);
            }
          }
          for (int z = b0[2]; z <= b1[2]; ++z)
            for (int y = b0[1]; y <= b1[1]; ++y)
              for (int x = b0[0]; x <= b1[0]; ++x) rodField[x + P * (y + P * z)] = far;
          for (std::size_t m = i; m < j; ++m) {
            const PreparedEdge& e = edges[sortedList[m]];
            const auto& q = boxes[m - i];
            for (int z = q[4]; z <= q[5]; ++z)
              for (int y = q[2]; y <= q[3]; ++y)
                for (int x = q[0]; x <= q[1]; ++x) {
                  const Vec3 pt = lo + h * Vec3(gx0 + x, gy0 + y, gz0 + z);
                  double& f = rodField[x + P * (y + P * z)];
                  f = std::min(f, edgeField(e, pt));
                  ++sampled;
                }
          }
          for (int z = b0[2]; z <= b1[2]; ++z)
            for (int y = b0[1]; y <= b1[1]; ++y)
              for (int x = b0[0]; x <= b1[0]; ++x) {
                const int id = x + P * (y + P * z);
                // Only rods that reach this point count, so that points shared
                // by two blocks get bitwise identical values in both.
                if (rodField[id] < far) field[id] = smin(field[id], rodField[id], k);
              }
          i = j;
        }
        // A sample exactly on the level set counts as outside (never zero-area pieces).
        for (double& f : field)
          if (f == 0.0) f = 1e-12 * h;

        // ---- marching tetrahedra over the block's cells
        auto vertexOn = [&](int lx, int ly, int lz, int cbase, int cother) -> int {
          // Grid edge from corner cbase to corner cother (cbase's bits are a subset).
          const int dir = cbase ^ cother;
          const long long gx = gx0 + lx + (cbase & 1), gy = gy0 + ly + ((cbase >> 1) & 1),
                          gz = gz0 + lz + ((cbase >> 2) & 1);
          const long long key = ((gx + nx * (gy + ny * gz)) << 3) | dir;
          auto it = vertexOf.find(key);
          if (it != vertexOf.end()) return it->second;
          const int ax = lx + (cbase & 1), ay = ly + ((cbase >> 1) & 1), az = lz + ((cbase >> 2) & 1);
          const int bxl = lx + (cother & 1), byl = ly + ((cother >> 1) & 1), bzl = lz + ((cother >> 2) & 1);
          const double fa = field[ax + P * (ay + P * az)], fb = field[bxl + P * (byl + P * bzl)];
          double t = fa / (fa - fb);
          t = std::clamp(t, 0.01, 0.99);
          const Vec3 pa = lo + h * Vec3(gx, gy, gz);
          const Vec3 pb = lo + h * Vec3(gx0 + bxl, gy0 + byl, gz0 + bzl);
          out.vertices.push_back((1 - t) * pa + t * pb);
          const int id = static_cast<int>(out.vertices.size()) - 1;
          vertexOf.emplace(key, id);
          return id;
        };
        for (int z = 0; z + 1 < pz; ++z)
          for (int y = 0; y + 1 < py; ++y)
            for (int x = 0; x + 1 < px; ++x) {
              double f[8];
              int inside = 0;
              for (int c = 0; c < 8; ++c) {
                f[c] = field[(x + (c & 1)) + P * ((y + ((c >> 1) & 1)) + P * (z + ((c >> 2) & 1)))];
                inside += f[c] < 0;
              }
              if (inside == 0 || inside == 8) continue;
              for (const auto& tet : kuhn.tets) {
                std::array<int, 4> in{}, outv{};
                int ni = 0, no = 0;
                for (int m = 0; m < 4; ++m) {
                  if (f[tet[m]] < 0) in[ni++] = m;
                  else outv[no++] = m;
                }
                if (ni == 0 || ni == 4) continue;
                // An even permutation (positions in `tet`) listing the lone
                // vertex (or the inside pair) first.
                std::array<int, 4> perm;
                if (ni == 1) perm = {in[0], outv[0], outv[1], outv[2]};
                else if (ni == 3) perm = {outv[0], in[0], in[1], in[2]};
                else perm = {in[0], in[1], outv[0], outv[1]};
                if (permutationParity(perm)) std::swap(perm[2], perm[3]);
                auto ev = [&](int pi, int pj) {
                  int ci = tet[perm[pi]], cj = tet[perm[pj]];
                  if ((ci & cj) != ci) std::swap(ci, cj);  // base corner = bit subset
                  return vertexOn(x, y, z, ci, cj);
                };
                if (ni == 1) {
                  out.faces.push_back({ev(0, 1), ev(0, 2), ev(0, 3)});
                } else if (ni == 3) {
                  out.faces.push_back({ev(0, 1), ev(0, 3), ev(0, 2)});
                } else {
                  const int ac = ev(0, 2), ad = ev(0, 3), bd = ev(1, 3), bc = ev(1, 2);
                  out.faces.push_back({ac, ad, bd});
                  out.faces.push_back({ac, bd, bc});
                }
              }
            }
      }
  {
    report->resolution = h;
    report->fillet = k;
    report->sampledPoints = sampled;
    report->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  return out;
}

void validateOptions(const SolidOptions& o) {
  auto fmt = [](double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.10g", v);
    return std::string(buf);
  };
  if (!(o.resolution >= 0 && o.resolution <= kMaxResolution))
    throw InputError("--resolution must be a grid step in (0, 1] m, or 0 for the default (got " + fmt(o.resolution) +
                     ")");
  if (!(std::isfinite(o.fillet) && o.fillet <= kMaxResolution))
    throw InputError("--fillet must be a blend radius in [0, 1] m (got " + fmt(o.fillet) + ")");
}

void roundToFloat(IndexedMesh& mesh) {
  for (Vec3& v : mesh.vertices)
    for (int i = 0; i < 3; ++i) v[i] = static_cast<double>(static_cast<float>(v[i]));
}

std::string SolidCheck::problems() const {
  std::string p;
  auto add = [&](const std::string& s) { p += (p.empty() ? "" : "; ") + s; };
  if (!polygonMesh) add("the triangles do not form a manifold, orientable mesh");
  if (!closed) add("the mesh is not closed");
  if (selfIntersecting) add("the mesh intersects itself");
  if (!outward) add("the mesh is not outward oriented");
  if (degenerateFaces) add(std::to_string(degenerateFaces) + " degenerate triangles");
  if (components != 1) add(std::to_string(components) + " connected components (one piece expected)");
  if (!(volume > 0)) add("non-positive volume");
  return p;
}

}  // namespace rodmesh::meshing
