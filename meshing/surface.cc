#include "meshing/surface.hh"

#include "io/scene_reader.hh"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <numeric>
#include <sstream>
#include <unordered_map>

namespace rodmesh::meshing {
namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw InputError(path + ": " + what);
}

std::string lowerExtension(const std::string& path) {
  auto dot = path.find_last_of('.');
  auto slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string e = path.substr(dot + 1);
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

std::string readAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open surface file");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) fail(path, "cannot read surface file");
  return ss.str();
}

// ---------------------------------------------------------------- OBJ
PolygonSoup parseObj(const std::string& text, const std::string& path) {
  PolygonSoup soup;
  std::istringstream in(text);
  std::string line;
  int lineNo = 0;
  while (std::getline(in, line)) {
    ++lineNo;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ls(line);
    std::string tag;
    if (!(ls >> tag) || tag[0] == '#') continue;
    if (tag == "v") {
      double x, y, z;
      if (!(ls >> x >> y >> z))
        fail(path, "line " + std::to_string(lineNo) + ": vertex needs three coordinates: '" + line + "'");
      soup.vertices.emplace_back(x, y, z);
    } else if (tag == "f") {
      std::vector<int> face;
      std::string tok;
      while (ls >> tok) {
        const std::string idx = tok.substr(0, tok.find('/'));
        char* end = nullptr;
        long v = std::strtol(idx.c_str(), &end, 10);
        if (idx.empty() || *end != '\0' || v == 0)
          fail(path, "line " + std::to_string(lineNo) + ": bad face index '" + tok + "'");
        // OBJ indices are 1-based; negative ones count back from the last vertex.
        long i = v > 0 ? v - 1 : static_cast<long>(soup.vertices.size()) + v;
        face.push_back(static_cast<int>(i));
      }
      soup.faces.push_back(std::move(face));
    }
    // vn, vt, g, o, s, usemtl, mtllib, l, ...: ignored.
  }
  return soup;
}

// ---------------------------------------------------------------- OFF
PolygonSoup parseOff(const std::string& text, const std::string& path) {
  // Strip comments, then read tokens.
  std::string clean;
  clean.reserve(text.size());
  bool comment = false;
  for (char c : text) {
    if (c == '#') comment = true;
    if (c == '\n') comment = false;
    clean.push_back(comment ? ' ' : c);
  }
  std::istringstream in(clean);
  std::string head;
  in >> head;
  if (head.size() < 3 || head.substr(head.size() - 3) != "OFF")
    fail(path, "not an OFF file (first token '" + head + "', expected 'OFF')");
  if (head != "OFF")
    fail(path, "OFF variant '" + head + "' is not supported (plain OFF only)");
  long nv = -1, nf = -1, ne = -1;
  if (!(in >> nv >> nf >> ne) || nv < 0 || nf < 0) fail(path, "bad OFF header counts");
  PolygonSoup soup;
  for (long i = 0; i < nv; ++i) {
    double x, y, z;
    if (!(in >> x >> y >> z)) fail(path, "vertex " + std::to_string(i) + ": cannot read three coordinates");
    soup.vertices.emplace_back(x, y, z);
  }
  std::string rest;
  std::getline(in, rest);  // end of the last vertex line
  for (long f = 0; f < nf; ++f) {
    std::string line;
    do {
      if (!std::getline(in, line)) fail(path, "face " + std::to_string(f) + ": unexpected end of file");
    } while (line.find_first_not_of(" \t\r") == std::string::npos);
    std::istringstream ls(line);
    long n;
    if (!(ls >> n) || n < 0) fail(path, "face " + std::to_string(f) + ": bad corner count");
    std::vector<int> face;
    for (long k = 0; k < n; ++k) {
      long v;
      if (!(ls >> v)) fail(path, "face " + std::to_string(f) + ": cannot read " + std::to_string(n) + " indices");
      face.push_back(static_cast<int>(v));
    }
    soup.faces.push_back(std::move(face));
  }
  return soup;
}

// ---------------------------------------------------------------- PLY
enum class PlyType { I8, U8, I16, U16, I32, U32, F32, F64 };

PlyType plyType(const std::string& t, const std::string& path) {
  if (t == "char" || t == "int8") return PlyType::I8;
  if (t == "uchar" || t == "uint8") return PlyType::U8;
  if (t == "short" || t == "int16") return PlyType::I16;
  if (t == "ushort" || t == "uint16") return PlyType::U16;
  if (t == "int" || t == "int32") return PlyType::I32;
  if (t == "uint" || t == "uint32") return PlyType::U32;
  if (t == "float" || t == "float32") return PlyType::F32;
  if (t == "double" || t == "float64") return PlyType::F64;
  fail(path, "unknown PLY property type '" + t + "'");
}

int plySize(PlyType t) {
  switch (t) {
    case PlyType::I8: case PlyType::U8: return 1;
    case PlyType::I16: case PlyType::U16: return 2;
    case PlyType::I32: case PlyType::U32: case PlyType::F32: return 4;
    case PlyType::F64: return 8;
  }
  return 0;
}

struct PlyProperty {
  std::string name;
  bool isList = false;
  PlyType countType = PlyType::U8, type = PlyType::F32;
};
struct PlyElement {
  std::string name;
  long count = 0;
  std::vector<PlyProperty> props;
};

class PlyValueReader {
 public:
  PlyValueReader(const std::string& data, std::size_t pos, int format, const std::string& path)
      : data_(data), pos_(pos), format_(format), path_(path) {
    if (format_ == 0) text_.str(data.substr(pos));
  }
  double read(PlyType t) {
    if (format_ == 0) {
      double v;
      if (!(text_ >> v)) fail(path_, "PLY: unexpected end of data or bad number");
      return v;
    }
    const int n = plySize(t);
    if (pos_ + n > data_.size()) fail(path_, "PLY: binary data ends early");
    unsigned char b[8];
    std::memcpy(b, data_.data() + pos_, n);
    pos_ += n;
    if (format_ == 2) std::reverse(b, b + n);  // big endian -> little (x86 host)
    switch (t) {
      case PlyType::I8: { int8_t v; std::memcpy(&v, b, 1); return v; }
      case PlyType::U8: { uint8_t v; std::memcpy(&v, b, 1); return v; }
      case PlyType::I16: { int16_t v; std::memcpy(&v, b, 2); return v; }
      case PlyType::U16: { uint16_t v; std::memcpy(&v, b, 2); return v; }
      case PlyType::I32: { int32_t v; std::memcpy(&v, b, 4); return v; }
      case PlyType::U32: { uint32_t v; std::memcpy(&v, b, 4); return v; }
      case PlyType::F32: { float v; std::memcpy(&v, b, 4); return v; }
      case PlyType::F64: { double v; std::memcpy(&v, b, 8); return v; }
    }
    return 0;
  }

 private:
  const std::string& data_;
  std::size_t pos_;
  int format_;  // 0 ascii, 1 little endian, 2 big endian
  std::string path_;
  std::istringstream text_;
};

PolygonSoup parsePly(const std::string& data, const std::string& path) {
  std::size_t pos = 0;
  auto nextLine = [&](std::string& line) {
    if (pos >= data.size()) return false;
    std::size_t e = data.find('\n', pos);
    if (e == std::string::npos) e = data.size();
    line = data.substr(pos, e - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = std::min(e + 1, data.size());
    return true;
  };
  std::string line;
  if (!nextLine(line) || line != "ply") fail(path, "not a PLY file (missing 'ply' magic line)");
  int format = -1;
  std::vector<PlyElement> elements;
  bool ended = false;
  while (nextLine(line)) {
    std::istringstream ls(line);
    std::string kw;
    ls >> kw;
    if (kw == "format") {
      std::string f;
      ls >> f;
      if (f == "ascii") format = 0;
      else if (f == "binary_little_endian") format = 1;
      else if (f == "binary_big_endian") format = 2;
      else fail(path, "unknown PLY format '" + f + "'");
    } else if (kw == "element") {
      PlyElement e;
      if (!(ls >> e.name >> e.count) || e.count < 0) fail(path, "bad PLY element line '" + line + "'");
      elements.push_back(e);
    } else if (kw == "property") {
      if (elements.empty()) fail(path, "PLY property before any element");
      PlyProperty p;
      std::string t;
      ls >> t;
      if (t == "list") {
        std::string ct, it;
        ls >> ct >> it >> p.name;
        p.isList = true;
        p.countType = plyType(ct, path);
        p.type = plyType(it, path);
      } else {
        p.type = plyType(t, path);
        ls >> p.name;
      }
      elements.back().props.push_back(p);
    } else if (kw == "end_header") {
      ended = true;
      break;
    }
  }
  if (!ended) fail(path, "PLY header has no 'end_header'");
  if (format < 0) fail(path, "PLY header has no 'format' line");
  PlyValueReader rd(data, pos, format, path);
  PolygonSoup soup;
  for (const PlyElement& e : elements) {
    const bool isVertex = e.name == "vertex";
    const bool isFace = e.name == "face";
    int ix = -1, iy = -1, iz = -1, iface = -1;
    for (int k = 0; k < static_cast<int>(e.props.size()); ++k) {
      const auto& n = e.props[k].name;
      if (n == "x") ix = k;
      if (n == "y") iy = k;
      if (n == "z") iz = k;
      if ((n == "vertex_indices" || n == "vertex_index") && e.props[k].isList) iface = k;
    }
    if (isVertex && (ix < 0 || iy < 0 || iz < 0)) fail(path, "PLY vertex element lacks x, y or z");
    if (isFace && iface < 0) fail(path, "PLY face element lacks a vertex_indices list");
    for (long i = 0; i < e.count; ++i) {
      Vec3 p = Vec3::Zero();
      std::vector<int> face;
      for (int k = 0; k < static_cast<int>(e.props.size()); ++k) {
        const PlyProperty& pr = e.props[k];
        if (pr.isList) {
          const double n = rd.read(pr.countType);
          if (n < 0 || n > 1e6) fail(path, "PLY element '" + e.name + "' " + std::to_string(i) + ": bad list size");
          for (int j = 0; j < static_cast<int>(n); ++j) {
            double v = rd.read(pr.type);
            if (isFace && k == iface) face.push_back(static_cast<int>(v));
          }
        } else {
          double v = rd.read(pr.type);
          if (k == ix) p.x() = v;
          if (k == iy) p.y() = v;
          if (k == iz) p.z() = v;
        }
      }
      if (isVertex) soup.vertices.push_back(p);
      if (isFace) soup.faces.push_back(std::move(face));
    }
  }
  return soup;
}

std::uint64_t edgeKey(int a, int b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b);
}

}  // namespace

PolygonSoup readPolygonFile(const std::string& path) {
  const std::string ext = lowerExtension(path);
  if (ext != "obj" && ext != "off" && ext != "ply")
    fail(path, "unsupported surface format '." + ext + "' (expected .obj, .off or .ply)");
  const std::string data = readAll(path);
  if (ext == "obj") return parseObj(data, path);
  if (ext == "off") return parseOff(data, path);
  return parsePly(data, path);
}

TriSurface validateSurface(const PolygonSoup& soup, const std::string& path, std::vector<char>* flippedOut) {
  TriSurface s;
  s.sourcePath = path;
  if (soup.faces.empty()) fail(path, "the surface is empty (no faces)");
  const int nv = static_cast<int>(soup.vertices.size());
  for (int i = 0; i < nv; ++i)
    if (!soup.vertices[i].allFinite()) fail(path, "vertex " + std::to_string(i) + " has a non-finite coordinate");
  s.vertices = soup.vertices;
  double diag = 0;
  {
    Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
    for (const auto& f : soup.faces)
      for (int v : f)
        if (v >= 0 && v < nv) {
          lo = lo.cwiseMin(soup.vertices[v]);
          hi = hi.cwiseMax(soup.vertices[v]);
        }
    diag = (hi - lo).norm();
  }
  for (std::size_t f = 0; f < soup.faces.size(); ++f) {
    const auto& face = soup.faces[f];
    const std::string fn = "face " + std::to_string(f);
    if (face.size() != 3)
      fail(path, fn + " has " + std::to_string(face.size()) +
                     " corners; only triangle meshes are supported (triangulate the surface first)");
    for (int v : face)
      if (v < 0 || v >= nv)
        fail(path, fn + " refers to vertex " + std::to_string(v) + " (the file has " + std::to_string(nv) + " vertices)");
    if (face[0] == face[1] || face[1] == face[2] || face[0] == face[2])
      fail(path, fn + " is degenerate (it repeats a vertex)");
    const Vec3 &a = s.vertices[face[0]], &b = s.vertices[face[1]], &c = s.vertices[face[2]];
    const double lmax = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    const double twiceArea = (b - a).cross(c - a).norm();
    if (!(lmax > 1e-12 * diag) || !(twiceArea > 1e-10 * lmax * lmax))
      fail(path, fn + " is degenerate (zero area: its corners are coincident or collinear)");
    s.faces.push_back({face[0], face[1], face[2]});
  }
  const int nf = static_cast<int>(s.faces.size());
  // Duplicate faces and edges with more than two faces.
  {
    std::map<std::array<int, 3>, int> seen;
    for (int f = 0; f < nf; ++f) {
      auto k = s.faces[f];
      std::sort(k.begin(), k.end());
      auto [it, fresh] = seen.emplace(k, f);
      if (!fresh) fail(path, "face " + std::to_string(f) + " duplicates face " + std::to_string(it->second));
    }
  }
  std::unordered_map<std::uint64_t, std::vector<int>> edgeFaces;
  for (int f = 0; f < nf; ++f)
    for (int i = 0; i < 3; ++i) {
      auto& v = edgeFaces[edgeKey(s.faces[f][i], s.faces[f][(i + 1) % 3])];
      v.push_back(f);
      if (v.size() > 2) {
        fail(path, "non-manifold edge between vertices " + std::to_string(s.faces[f][i]) + " and " +
                       std::to_string(s.faces[f][(i + 1) % 3]) + ": shared by " + std::to_string(v.size()) +
                       " faces (" + std::to_string(v[0]) + ", " + std::to_string(v[1]) + ", " + std::to_string(f) +
                       ")");
      }
    }
  // Orientation: breadth-first over faces, flipping to agree with neighbours.
  std::vector<char> flipped(nf, 0), visited(nf, 0);
  auto hasDirected = [&](int f, int a, int b) {
    const Tri& t = s.faces[f];
    for (int i = 0; i < 3; ++i)
      if (t[i] == a && t[(i + 1) % 3] == b) return true;
    return false;
  };
  for (int start = 0; start < nf; ++start) {
    if (visited[start]) continue;
    visited[start] = 1;
    std::vector<int> queue{start};
    for (std::size_t qi = 0; qi < queue.size(); ++qi) {
      const int f = queue[qi];
      for (int i = 0; i < 3; ++i) {
        const int a = s.faces[f][i], b = s.faces[f][(i + 1) % 3];
        for (int g : edgeFaces[edgeKey(a, b)]) {
          if (g == f) continue;
          // Consistent orientation: g traverses the edge as (b, a).
          const bool consistent = hasDirected(g, b, a);
          if (!visited[g]) {
            visited[g] = 1;
            if (!consistent) {
              std::swap(s.faces[g][1], s.faces[g][2]);
              flipped[g] = 1;
            }
            queue.push_back(g);
          } else if (!consistent) {
            fail(path, "the surface is not orientable (faces " + std::to_string(f) + " and " + std::to_string(g) +
                           " cannot be oriented consistently)");
          }
        }
      }
    }
  }
  // Non-manifold vertices: the faces around each vertex must form one fan.
  std::vector<std::vector<int>> vf(nv);
  for (int f = 0; f < nf; ++f)
    for (int v : s.faces[f]) vf[v].push_back(f);
  for (int v = 0; v < nv; ++v) {
    if (vf[v].empty()) continue;
    // Union faces around v that share an edge incident to v.
    std::vector<int> comp(vf[v].size());
    std::iota(comp.begin(), comp.end(), 0);
    std::function<int(int)> find = [&](int x) { return comp[x] == x ? x : comp[x] = find(comp[x]); };
    std::map<int, int> otherToLocal;
    for (int k = 0; k < static_cast<int>(vf[v].size()); ++k) {
      for (int w : s.faces[vf[v][k]]) {
        if (w == v) continue;
        auto [it, fresh] = otherToLocal.emplace(w, k);
        if (!fresh) comp[find(k)] = find(it->second);
      }
    }
    int fans = 0;
    for (int k = 0; k < static_cast<int>(vf[v].size()); ++k)
      if (find(k) == k) ++fans;
    if (fans > 1)
      fail(path, "non-manifold vertex " + std::to_string(v) + ": its faces form " + std::to_string(fans) +
                     " separate fans");
  }
  if (flippedOut) *flippedOut = flipped;
  return s;
}

TriSurface readSurface(const std::string& path) { return validateSurface(readPolygonFile(path), path); }

TriSurface readDeformedCopy(const std::string& path, const TriSurface& rest, const std::vector<char>& restFlips) {
  PolygonSoup soup = readPolygonFile(path);
  if (soup.vertices.size() != rest.vertices.size())
    fail(path, "a deformed copy must have the input surface's connectivity: it has " +
                   std::to_string(soup.vertices.size()) + " vertices, the input surface " +
                   std::to_string(rest.vertices.size()));
  if (soup.faces.size() != rest.faces.size())
    fail(path, "a deformed copy must have the input surface's connectivity: it has " +
                   std::to_string(soup.faces.size()) + " faces, the input surface " +
                   std::to_string(rest.faces.size()));
  TriSurface d;
  d.sourcePath = path;
  d.vertices = soup.vertices;
  for (std::size_t i = 0; i < d.vertices.size(); ++i)
    if (!d.vertices[i].allFinite()) fail(path, "vertex " + std::to_string(i) + " has a non-finite coordinate");
  d.faces.resize(rest.faces.size());
  for (std::size_t f = 0; f < rest.faces.size(); ++f) {
    const auto& face = soup.faces[f];
    Tri t = rest.faces[f];
    if (!restFlips.empty() && restFlips[f]) std::swap(t[1], t[2]);  // undo the flip to compare as read
    if (face.size() != 3 || face[0] != t[0] || face[1] != t[1] || face[2] != t[2])
      fail(path, "a deformed copy must have the input surface's connectivity: face " + std::to_string(f) +
                     " differs from the input surface's face " + std::to_string(f));
    d.faces[f] = rest.faces[f];
  }
  return d;
}

Vec3 evalPoint(const TriSurface& s, const SurfacePoint& p) {
  const Tri& t = s.faces[p.face];
  return p.bary[0] * s.vertices[t[0]] + p.bary[1] * s.vertices[t[1]] + p.bary[2] * s.vertices[t[2]];
}

std::vector<Vec3> vertexNormals(const TriSurface& s) {
  std::vector<Vec3> n(s.vertices.size(), Vec3::Zero());
  for (const Tri& t : s.faces) {
    const Vec3 fn = (s.vertices[t[1]] - s.vertices[t[0]]).cross(s.vertices[t[2]] - s.vertices[t[0]]).normalized();
    for (int i = 0; i < 3; ++i) {
      const Vec3 e1 = (s.vertices[t[(i + 1) % 3]] - s.vertices[t[i]]).normalized();
      const Vec3 e2 = (s.vertices[t[(i + 2) % 3]] - s.vertices[t[i]]).normalized();
      const double angle = std::acos(std::clamp(e1.dot(e2), -1.0, 1.0));
      n[t[i]] += angle * fn;
    }
  }
  for (Vec3& v : n)
    if (v.norm() > 0) v.normalize();
  return n;
}

Vec3 evalNormal(const TriSurface& s, const std::vector<Vec3>& vn, const SurfacePoint& p) {
  const Tri& t = s.faces[p.face];
  Vec3 n = p.bary[0] * vn[t[0]] + p.bary[1] * vn[t[1]] + p.bary[2] * vn[t[2]];
  if (n.norm() < 1e-9) {
    n = (s.vertices[t[1]] - s.vertices[t[0]]).cross(s.vertices[t[2]] - s.vertices[t[0]]);
  }
  return n.normalized();
}

double faceArea(const TriSurface& s, int f) {
  const Tri& t = s.faces[f];
  return 0.5 * (s.vertices[t[1]] - s.vertices[t[0]]).cross(s.vertices[t[2]] - s.vertices[t[0]]).norm();
}

double surfaceArea(const TriSurface& s) {
  double a = 0;
  for (int f = 0; f < static_cast<int>(s.faces.size()); ++f) a += faceArea(s, f);
  return a;
}

double bboxDiagonal(const TriSurface& s) {
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (const Tri& t : s.faces)
    for (int v : t) {
      lo = lo.cwiseMin(s.vertices[v]);
      hi = hi.cwiseMax(s.vertices[v]);
    }
  return (hi - lo).norm();
}

// Closest point on a triangle (Ericson, Real-Time Collision Detection §5.1.5).
Vec3 closestPointBary(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return Vec3(1, 0, 0);
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return Vec3(0, 1, 0);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return Vec3(1 - v, v, 0);
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return Vec3(0, 0, 1);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return Vec3(1 - w, 0, w);
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return Vec3(0, 1 - w, w);
  }
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return Vec3(1 - v - w, v, w);
}

SurfacePoint closestPoint(const TriSurface& s, const Vec3& p, const std::vector<int>& subset, double* dist) {
  SurfacePoint best;
  double bestD = 1e300;
  auto consider = [&](int f) {
    const Tri& t = s.faces[f];
    const Vec3 b = closestPointBary(p, s.vertices[t[0]], s.vertices[t[1]], s.vertices[t[2]]);
    const Vec3 q = b[0] * s.vertices[t[0]] + b[1] * s.vertices[t[1]] + b[2] * s.vertices[t[2]];
    const double d = (q - p).squaredNorm();
    if (d < bestD) {
      bestD = d;
      best.face = f;
      best.bary = b;
    }
  };
  if (subset.empty())
    for (int f = 0; f < static_cast<int>(s.faces.size()); ++f) consider(f);
  else
    for (int f : subset) consider(f);
  if (dist) *dist = std::sqrt(bestD);
  return best;
}

SurfaceTopology::SurfaceTopology(const TriSurface& s) {
  const int nv = static_cast<int>(s.vertices.size());
  const int nf = static_cast<int>(s.faces.size());
  vertexFaces.assign(nv, {});
  vertexNeighbours.assign(nv, {});
  faceNeighbours.assign(nf, {-1, -1, -1});
  std::unordered_map<std::uint64_t, std::pair<int, int>> edgeFace;  // directed edge -> (face, corner)
  edgeFace.reserve(3 * nf);
  auto dkey = [](int a, int b) { return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b); };
  for (int f = 0; f < nf; ++f)
    for (int i = 0; i < 3; ++i) {
      vertexFaces[s.faces[f][i]].push_back(f);
      edgeFace[dkey(s.faces[f][i], s.faces[f][(i + 1) % 3])] = {f, i};
    }
  std::unordered_map<int, int> nextOnBoundary;  // boundary edge a->b (as in the face) keyed by a
  for (int f = 0; f < nf; ++f)
    for (int i = 0; i < 3; ++i) {
      const int a = s.faces[f][i], b = s.faces[f][(i + 1) % 3];
      auto it = edgeFace.find(dkey(b, a));
      if (it != edgeFace.end()) faceNeighbours[f][i] = it->second.first;
      else nextOnBoundary[a] = b;
      vertexNeighbours[a].push_back(b);
      vertexNeighbours[b].push_back(a);
    }
  for (auto& n : vertexNeighbours) {
    std::sort(n.begin(), n.end());
    n.erase(std::unique(n.begin(), n.end()), n.end());
  }
  isBoundaryVertex.assign(nv, 0);
  std::vector<int> starts;
  for (const auto& kv : nextOnBoundary) {
    isBoundaryVertex[kv.first] = 1;
    starts.push_back(kv.first);
  }
  std::sort(starts.begin(), starts.end());
  std::vector<char> used(nv, 0);
  for (int st : starts) {
    if (used[st]) continue;
    std::vector<int> loop;
    int v = st;
    while (!used[v]) {
      used[v] = 1;
      loop.push_back(v);
      auto it = nextOnBoundary.find(v);
      if (it == nextOnBoundary.end()) break;
      v = it->second;
    }
    boundaryLoops.push_back(std::move(loop));
  }
}

}  // namespace rodmesh::meshing
