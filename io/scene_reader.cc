#include "io/scene_reader.hh"

#include "io/json_text.hh"
#include "model/limits.hh"

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <cstdint>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>

namespace rodmesh {
namespace {

using limits::kNormalAlongEdgeSine;

using json = nlohmann::json;

thread_local std::vector<std::string> g_warnings;

// A JSON node together with its key path ("poses[1].fixed[0].vertex"), so that
// every error can say exactly where it is.
struct Node {
  const json* j;
  std::string path;
  const std::string* file;

  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(*file + ": " + (path.empty() ? std::string("<root>") : path) + ": " + what);
  }
  bool has(const char* key) const { return j->is_object() && j->contains(key); }
  Node operator[](const char* key) const {
    if (!j->is_object()) fail("expected an object with key \"" + std::string(key) + "\", got " + typeName());
    auto it = j->find(key);
    if (it == j->end()) {
      Node missing{j, withKey(path, key), file};
      missing.fail("missing required key");
    }
    return Node{&*it, withKey(path, key), file};
  }
  Node at(std::size_t i) const { return Node{&(*j)[i], path + "[" + std::to_string(i) + "]", file}; }
  std::size_t arraySize() const {
    if (!j->is_array()) fail("expected an array, got " + typeName());
    return j->size();
  }
  std::string typeName() const { return std::string(j->type_name()) + " " + shortDump(); }
  // Bounded in length and cost whatever the size of the value.
  std::string shortDump() const { return shortJson(*j); }
  double number() const {
    if (!j->is_number()) fail("expected a number, got " + typeName());
    double v = j->get<double>();
    if (!std::isfinite(v)) fail("expected a finite number, got " + shortDump());
    return v;
  }
  // True if the node is an integer in [lo, hi]; compares without converting
  // (a conversion to a narrower type would wrap large values around).
  bool integerWithin(long long lo, long long hi) const {
    if (j->is_number_unsigned()) {
      const std::uint64_t u = j->get<std::uint64_t>();
      return hi >= 0 && u <= static_cast<std::uint64_t>(hi) && (lo <= 0 || u >= static_cast<std::uint64_t>(lo));
    }
    if (!j->is_number_integer()) return false;
    const long long v = j->get<long long>();
    return v >= lo && v <= hi;
  }
  int index(std::size_t count, const char* what) const {
    if (!j->is_number_integer() && !j->is_number_unsigned()) fail("expected an integer " + std::string(what) + " index, got " + typeName());
    if (!integerWithin(0, static_cast<long long>(count) - 1))
      fail(std::string(what) + " index " + shortDump() + " out of range [0, " + std::to_string(count) + ")");
    return static_cast<int>(j->get<long long>());
  }
  std::string string() const {
    if (!j->is_string()) fail("expected a string, got " + typeName());
    return j->get<std::string>();
  }
  Vec3 vec3() const {
    if (!j->is_array() || j->size() != 3) fail("expected an array of 3 numbers, got " + shortDump());
    return Vec3(at(0).number(), at(1).number(), at(2).number());
  }
  // A number in [lo, hi] (its plausible range, model/limits.hh); the message
  // gives the range, the unit and the value as written in the file.
  double numberWithin(double lo, double hi, const char* unit, bool openLow = false) const {
    const double v = number();
    if (!((openLow ? v > lo : v >= lo) && v <= hi))
      fail(std::string("outside its plausible range ") + (openLow ? "(" : "[") + fmtRange(lo) + ", " + fmtRange(hi) +
           "] " + unit + " (docs/formats.md, \"Plausible ranges\"), got " + shortDump());
    return v;
  }
  // Three numbers, each in [-bound, bound].
  Vec3 vec3Within(double bound, const char* unit) const {
    if (!j->is_array() || j->size() != 3) fail("expected an array of 3 numbers, got " + shortDump());
    return Vec3(at(0).numberWithin(-bound, bound, unit), at(1).numberWithin(-bound, bound, unit),
                at(2).numberWithin(-bound, bound, unit));
  }
  static std::string fmtRange(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
  }
  Vec2 vec2() const {
    if (!j->is_array() || j->size() != 2) fail("expected an array of 2 numbers, got " + shortDump());
    return Vec2(at(0).number(), at(1).number());
  }
};

std::string fmt(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

void warnUnknownKeys(const Node& n, std::initializer_list<const char*> known) {
  if (!n.j->is_object()) return;
  std::set<std::string> k(known.begin(), known.end());
  for (auto it = n.j->begin(); it != n.j->end(); ++it)
    if (!k.count(it.key())) g_warnings.push_back(*n.file + ": " + withKey(n.path, it.key()) + ": unknown key ignored");
}

// `bound`: each coordinate in [-bound, bound] (0: any finite number, e.g. normals).
std::vector<Vec3> readVec3List(const Node& n, std::size_t expected, const char* what, double bound = 0.0) {
  std::size_t size = n.arraySize();
  if (expected != 0 && size != expected)
    n.fail("expected " + std::to_string(expected) + " " + what + " (one per vertex), got " + std::to_string(size));
  std::vector<Vec3> out;
  out.reserve(size);
  for (std::size_t i = 0; i < size; ++i) out.push_back(bound > 0 ? n.at(i).vec3Within(bound, "m") : n.at(i).vec3());
  return out;
}

void readRadiusPair(const Node& n, Vec2& r) {
  r = n.vec2();
  for (int k = 0; k < 2; ++k)
    if (!(r[k] > 0.0)) n.at(k).fail("radius must be positive, got " + fmt(r[k]));
  for (int k = 0; k < 2; ++k) n.at(k).numberWithin(limits::kMinRadius, limits::kMaxRadius, "m");
}

// Pose names become HDF5 group names (/poses/NAME) and file names in exports:
// no '/', not "." or "..", no control characters (a NUL would cut the name
// short), at most 255 bytes.
void checkPoseName(const Node& at, const std::string& name) {
  std::string why;
  if (name.empty()) why = "must be non-empty";
  else if (name.find('/') != std::string::npos) why = "must contain no '/'";
  else if (name == "." || name == "..") why = "must not be \".\" or \"..\"";
  else if (name.size() > 255) why = "must be at most 255 bytes long";
  else
    for (unsigned char c : name)
      if (c < 0x20 || c == 0x7f) {
        why = "must contain no control characters (NUL, newline, escape ...)";
        break;
      }
  if (!why.empty()) at.fail("pose name " + why + ", got " + printableText(quotedText(name), 80));
}

}  // namespace

const std::vector<std::string>& lastSceneWarnings() { return g_warnings; }

std::string printableText(const std::string& text, std::size_t limit) {
  std::string out;
  auto escape = [&](unsigned char c) {
    char buf[8];
    std::snprintf(buf, sizeof buf, "\\x%02x", c);
    out += buf;
  };
  const std::size_t end = std::min(text.size(), limit);
  for (std::size_t i = 0; i < end; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 || c == 0x7f) {
      escape(c);
      continue;
    }
    if (c < 0x80) {
      out.push_back(static_cast<char>(c));
      continue;
    }
    // A whole UTF-8 sequence is kept (messages stay valid UTF-8 for
    // terminals and logs); a byte that starts none (binary input, e.g. an
    // archive given as a scene) is escaped.
    const std::size_t len = (c & 0xE0) == 0xC0 && c >= 0xC2 ? 2 : (c & 0xF0) == 0xE0 ? 3 : (c & 0xF8) == 0xF0 && c <= 0xF4 ? 4 : 0;
    bool whole = len > 0 && i + len <= end;
    for (std::size_t k = 1; whole && k < len; ++k) whole = (static_cast<unsigned char>(text[i + k]) & 0xC0) == 0x80;
    if (!whole) {
      escape(c);
      continue;
    }
    out.append(text, i, len);
    i += len - 1;
  }
  return text.size() > limit ? out + "..." : out;
}

Scene parseScene(const std::string& text, const std::string& path) {
  g_warnings.clear();
  // Syntax errors, numbers beyond the double range and absurd nesting are
  // reported with line, column and key path (io/json_text.hh).
  const json doc = parseJsonText(text, path);

  Scene s;
  s.sourcePath = path;
  s.sourceText = text;
  Node root{&doc, "", &s.sourcePath};
  if (!doc.is_object()) root.fail("expected a JSON object at the top level, got " + root.typeName());
  warnUnknownKeys(root, {"format", "material", "vertices", "normals", "rods", "radius", "radii", "gravity", "effects",
                         "poses", "design", "name", "description", "units"});

  {
    Node f = root["format"];
    std::string v = f.string();
    if (v != "rodmesh-scene/1") f.fail("unsupported format " + quotedText(v) + " (expected \"rodmesh-scene/1\")");
  }

  // Material.
  {
    Node m = root["material"];
    if (!m.j->is_object()) m.fail("expected an object, got " + m.typeName());
    warnUnknownKeys(m, {"young_modulus", "poisson_ratio", "density"});
    Node e = m["young_modulus"];
    s.material.youngModulus = e.number();
    if (!(s.material.youngModulus > 0)) e.fail("Young's modulus must be positive, got " + fmt(s.material.youngModulus));
    Node nu = m["poisson_ratio"];
    s.material.poissonRatio = nu.number();
    // The rods use the shear modulus E / (2 (1 + nu)) only: finite and
    // positive on (-1, 0.5], the incompressible 0.5 (rubber, TPU modelled as
    // such, other rod codes' G = E/3) included.
    if (!(s.material.poissonRatio > -1.0 && s.material.poissonRatio <= 0.5))
      nu.fail("Poisson ratio must lie in (-1, 0.5], got " + fmt(s.material.poissonRatio));
    Node rho = m["density"];
    s.material.density = rho.number();
    if (!(s.material.density > 0)) rho.fail("density must be positive, got " + fmt(s.material.density));
    e.numberWithin(limits::kMinYoungModulus, limits::kMaxYoungModulus, "Pa");
    rho.numberWithin(limits::kMinDensity, limits::kMaxDensity, "kg/m^3");
  }

  // Vertices.
  s.vertices = readVec3List(root["vertices"], 0, "positions", limits::kMaxCoordinate);
  const std::size_t nv = s.vertices.size();
  if (nv < 2) root["vertices"].fail("need at least 2 vertices, got " + std::to_string(nv));

  if (root.has("normals")) {
    Node nn = root["normals"];
    s.normals = readVec3List(nn, nv, "normals");
    for (std::size_t i = 0; i < nv; ++i) {
      double len = s.normals[i].norm();
      if (!(len > 1e-12)) nn.at(i).fail("normal must be non-zero, got " + nn.at(i).shortDump());
      s.normals[i] /= len;
    }
  }

  // Rods, and the rule that rods meet only at their end vertices.
  std::vector<int> endCount(nv, 0), useCount(nv, 0);
  {
    Node rods = root["rods"];
    std::size_t nr = rods.arraySize();
    if (nr == 0) rods.fail("need at least one rod, got []");
    std::vector<int> interiorUse(nv, -1);  // rod using the vertex as an interior node
    std::vector<int> endUse(nv, -1);       // some rod ending at the vertex
    for (std::size_t r = 0; r < nr; ++r) {
      Node rn = rods.at(r);
      if (!rn.j->is_object()) rn.fail("expected an object with key \"vertices\", got " + rn.typeName());
      warnUnknownKeys(rn, {"vertices", "normal", "name"});
      Node vs = rn["vertices"];
      std::size_t k = vs.arraySize();
      if (k < 2) vs.fail("a rod needs at least 2 vertices (one edge), got " + std::to_string(k));
      Rod rod;
      std::set<int> seen;
      for (std::size_t i = 0; i < k; ++i) {
        int v = vs.at(i).index(nv, "vertex");
        if (!seen.insert(v).second) vs.at(i).fail("vertex " + std::to_string(v) + " appears twice in the same rod");
        rod.vertices.push_back(v);
      }
      for (std::size_t i = 0; i + 1 < k; ++i) {
        double len = (s.vertices[rod.vertices[i + 1]] - s.vertices[rod.vertices[i]]).norm();
        if (!(len > 0.0))
          vs.at(i + 1).fail("zero-length edge between vertices " + std::to_string(rod.vertices[i]) + " and " +
                            std::to_string(rod.vertices[i + 1]) + ", both at " +
                            root["vertices"].at(rod.vertices[i]).shortDump());
        if (len < limits::kMinEdgeLength)
          vs.at(i + 1).fail("edge between vertices " + std::to_string(rod.vertices[i]) + " and " +
                            std::to_string(rod.vertices[i + 1]) + " is " + fmt(len) +
                            " m long, below the plausible minimum of " + fmt(limits::kMinEdgeLength) + " m");
      }
      for (std::size_t i = 0; i < k; ++i) {
        int v = rod.vertices[i];
        bool end = (i == 0 || i + 1 == k);
        if (end) {
          if (interiorUse[v] >= 0)
            vs.at(i).fail("vertex " + std::to_string(v) + " ends this rod but is an interior node of rods[" +
                          std::to_string(interiorUse[v]) + "]; rods meet only at their end vertices");
          endUse[v] = static_cast<int>(r);
        } else {
          if (interiorUse[v] >= 0 || endUse[v] >= 0)
            vs.at(i).fail("vertex " + std::to_string(v) + " is an interior node of this rod and is also used by rods[" +
                          std::to_string(interiorUse[v] >= 0 ? interiorUse[v] : endUse[v]) +
                          "]; rods meet only at their end vertices");
          interiorUse[v] = static_cast<int>(r);
        }
      }
      if (rn.has("normal")) {
        Node nn = rn["normal"];
        Vec3 n = nn.vec3();
        if (!(n.norm() > 1e-12)) nn.fail("normal must be non-zero, got " + nn.shortDump());
        rod.normal = n.normalized();
      }
      s.rods.push_back(std::move(rod));
    }
    for (const Rod& rod : s.rods) {
      for (int v : rod.vertices) useCount[v]++;
      endCount[rod.vertices.front()]++;
      endCount[rod.vertices.back()]++;
    }
    for (std::size_t v = 0; v < nv; ++v)
      if (interiorUse[v] < 0 && endUse[v] < 0)
        root["vertices"].at(v).fail("vertex " + std::to_string(v) + " belongs to no rod");
    // A reference normal orients the cross section in the plane
    // perpendicular to the rod: along an edge it leaves that plane
    // undefined (the edge's normal is the mean of its ends', as in
    // model/network.cc).
    auto alongEdge = [&](const Vec3& n, int a, int b) {
      const Vec3 t = (s.vertices[b] - s.vertices[a]).normalized();
      return n.cross(t).norm() < kNormalAlongEdgeSine;
    };
    auto edgeText = [&](std::size_t r, int a, int b) {
      return "edge " + std::to_string(a) + "-" + std::to_string(b) + " of rods[" + std::to_string(r) + "]";
    };
    for (std::size_t r = 0; r < s.rods.size(); ++r) {
      const std::vector<int>& vs = s.rods[r].vertices;
      for (std::size_t i = 0; i + 1 < vs.size(); ++i) {
        const int a = vs[i], b = vs[i + 1];
        if (!s.normals.empty()) {
          Vec3 na = s.normals[a], nb = s.normals[b];
          if (na.dot(nb) < 0) nb = -nb;
          const Vec3 n = (na + nb).norm() > 1e-12 ? Vec3((na + nb).normalized()) : na;
          if (alongEdge(n, a, b)) {
            const int v = alongEdge(na, a, b) ? a : b;
            Node bad = root["normals"].at(static_cast<std::size_t>(v));
            bad.fail("normal " + bad.shortDump() + " of vertex " + std::to_string(v) + " lies along " +
                     edgeText(r, a, b) +
                     "; a reference normal must point away from its rods (it orients their cross sections)");
          }
        } else if (s.rods[r].normal && alongEdge(*s.rods[r].normal, a, b)) {
          Node bad = root["rods"].at(r)["normal"];
          bad.fail("normal " + bad.shortDump() + " lies along " + edgeText(r, a, b) +
                                             "; a reference normal must point away from its rod (it orients its "
                                             "cross sections)");
        }
      }
    }
  }

  // Cross sections.
  {
    bool hasRadius = root.has("radius"), hasRadii = root.has("radii");
    if (!hasRadius && !hasRadii) root["radius"];  // throws "missing required key"
    Vec2 uniform(0, 0);
    if (hasRadius) readRadiusPair(root["radius"], uniform);
    s.radii.assign(nv, uniform);
    if (hasRadii) {
      Node rr = root["radii"];
      std::size_t n = rr.arraySize();
      if (n != nv) rr.fail("expected " + std::to_string(nv) + " radius pairs (one per vertex), got " + std::to_string(n));
      for (std::size_t i = 0; i < nv; ++i) readRadiusPair(rr.at(i), s.radii[i]);
    }
  }

  if (root.has("gravity")) s.gravity = root["gravity"].vec3Within(limits::kMaxGravity, "m/s^2");

  if (root.has("effects")) {
    Node ef = root["effects"];
    std::size_t n = ef.arraySize();
    std::vector<Effect> list;
    for (std::size_t i = 0; i < n; ++i) {
      std::string name = ef.at(i).string();
      bool found = false;
      for (int k = 0; k < kEffectCount; ++k)
        if (name == effectName(static_cast<Effect>(k))) { list.push_back(static_cast<Effect>(k)); found = true; }
      if (!found)
        ef.at(i).fail("unknown effect " + quotedText(name) +
                      " (expected one of stretch, bend, twist, connections, gravity)");
    }
    bool hasStretch = false, hasGravity = false;
    for (Effect e : list) { hasStretch |= e == Effect::Stretch; hasGravity |= e == Effect::Gravity; }
    if (!hasStretch)
      ef.fail(
          "\"stretch\" cannot be left out: inextensible rods would need constraints this model does not have, got " +
          ef.shortDump());
    if (hasGravity && !s.gravity)
      ef.fail("\"gravity\" is listed but the scene has no \"gravity\" vector, got " + ef.shortDump());
    s.effects = list;
  }

  // Poses.
  {
    Node poses = root["poses"];
    std::size_t np = poses.arraySize();
    if (np == 0) poses.fail("need at least one pose, got []");
    std::map<std::string, std::size_t> names;  // pose name -> index
    for (std::size_t p = 0; p < np; ++p) {
      Node pn = poses.at(p);
      if (!pn.j->is_object()) pn.fail("expected an object, got " + pn.typeName());
      warnUnknownKeys(pn, {"name", "weight", "fixed", "clamped", "forces", "twisting_moments", "contacts",
                               "ties", "target"});
      Pose pose;
      pose.name = pn.has("name") ? pn["name"].string() : "pose" + std::to_string(p);
      if (pn.has("name")) checkPoseName(pn["name"], pose.name);
      if (!names.emplace(pose.name, p).second) {
        const std::string other = "poses[" + std::to_string(names[pose.name]) + "]";
        if (!pn.has("name"))
          pn.fail("this pose has no \"name\", and its default name " + quotedText(pose.name) + " is already used by " +
                  other);
        pn["name"].fail("duplicate pose name " + quotedText(pose.name) + " (also " + other + ")");
      }
      if (pn.has("weight")) {
        Node w = pn["weight"];
        pose.weight = w.number();
        if (pose.weight < 0) w.fail("weight must be non-negative, got " + fmt(pose.weight));
        w.numberWithin(0.0, limits::kMaxWeight, "");
      }
      std::map<int, std::string> held;  // vertex -> where it was held
      if (pn.has("fixed")) {
        Node fx = pn["fixed"];
        std::size_t n = fx.arraySize();
        for (std::size_t i = 0; i < n; ++i) {
          Node e = fx.at(i);
          if (!e.j->is_object()) e.fail("expected an object with key \"vertex\", got " + e.typeName());
          FixedVertex f;
          f.vertex = e["vertex"].index(nv, "vertex");
          if (e.has("position")) f.position = e["position"].vec3Within(limits::kMaxCoordinate, "m");
          if (held.count(f.vertex)) e["vertex"].fail("vertex " + std::to_string(f.vertex) + " is already held by " + held[f.vertex]);
          held[f.vertex] = e.path;
          pose.fixed.push_back(f);
        }
      }
      if (pn.has("clamped")) {
        Node cl = pn["clamped"];
        std::size_t n = cl.arraySize();
        std::set<int> clampedHere;
        for (std::size_t i = 0; i < n; ++i) {
          Node e = cl.at(i);
          if (!e.j->is_object()) e.fail("expected an object with key \"vertex\", got " + e.typeName());
          ClampedVertex c;
          c.vertex = e["vertex"].index(nv, "vertex");
          if (!clampedHere.insert(c.vertex).second) e["vertex"].fail("vertex " + std::to_string(c.vertex) + " is clamped twice");
          // A clamped vertex stays at its rest position (and orientation): a
          // position prescribed elsewhere by `fixed` would be dropped.
          for (std::size_t k = 0; k < pose.fixed.size(); ++k)
            if (pose.fixed[k].vertex == c.vertex && pose.fixed[k].position &&
                *pose.fixed[k].position != s.vertices[static_cast<std::size_t>(c.vertex)])
              e["vertex"].fail("vertex " + std::to_string(c.vertex) + " is also held at another position than its "
                               "rest position by " + held[c.vertex] + "; a clamped vertex stays at its rest position "
                               "and orientation (prescribe a position with `fixed` alone)");
          pose.clamped.push_back(c);
        }
      }
      if (pn.has("forces")) {
        Node fs = pn["forces"];
        std::size_t n = fs.arraySize();
        for (std::size_t i = 0; i < n; ++i) {
          Node e = fs.at(i);
          if (!e.j->is_object()) e.fail("expected an object with keys \"vertex\" and \"force\", got " + e.typeName());
          PointForce f;
          f.vertex = e["vertex"].index(nv, "vertex");
          f.force = e["force"].vec3Within(limits::kMaxForce, "N");
          pose.forces.push_back(f);
        }
      }
      if (pn.has("twisting_moments")) {
        Node ms = pn["twisting_moments"];
        std::size_t n = ms.arraySize();
        for (std::size_t i = 0; i < n; ++i) {
          Node e = ms.at(i);
          if (!e.j->is_object()) e.fail("expected an object with keys \"vertex\" and \"moment\", got " + e.typeName());
          TwistingMoment m;
          m.vertex = e["vertex"].index(nv, "vertex");
          if (endCount[m.vertex] != 1 || useCount[m.vertex] != 1)
            e["vertex"].fail("vertex " + std::to_string(m.vertex) + " is not the free end of a rod; twisting moments act on free ends");
          m.moment = e["moment"].numberWithin(-limits::kMaxMoment, limits::kMaxMoment, "N m");
          pose.twistingMoments.push_back(m);
        }
      }
      // Terms between two vertices (contacts, ties): an array of objects
      // with "vertices": [a, b] and the keys the term reads (read(e, vs, a, b)).
      auto readPairs = [&](const char* key, const char* keys, auto read) {
        if (!pn.has(key)) return;
        Node list = pn[key];
        const std::size_t n = list.arraySize();
        for (std::size_t i = 0; i < n; ++i) {
          Node e = list.at(i);
          if (!e.j->is_object())
            e.fail(std::string("expected an object with keys \"vertices\", ") + keys + ", got " + e.typeName());
          Node vs = e["vertices"];
          if (vs.arraySize() != 2) vs.fail("expected two vertex indices");
          const int a = vs.at(0).index(nv, "vertex");  // a's error first
          const int b = vs.at(1).index(nv, "vertex");
          read(e, vs, a, b);
        }
      };
      readPairs("contacts", "\"distance\" and \"stiffness\"", [&](Node& e, Node& vs, int a, int b) {
        if (a == b) vs.fail("a contact joins two different vertices, got " + std::to_string(a) + " twice");
        const double distance = e["distance"].numberWithin(limits::kMinEdgeLength, limits::kMaxCoordinate, "m");
        const double stiffness = e["stiffness"].numberWithin(0.0, limits::kMaxForce, "N", true);
        pose.contacts.push_back({a, b, distance, stiffness});
      });
      readPairs("ties", "\"stiffness\" and \"yield_force\"", [&](Node& e, Node& vs, int a, int b) {
        const double length = (s.vertices[b] - s.vertices[a]).norm();
        if (!(length >= limits::kMinEdgeLength))
          vs.fail("a tie joins two vertices at least 1e-08 m apart in the scene, got vertices " + std::to_string(a) +
                  " and " + std::to_string(b) + " at distance " + Node::fmtRange(length) + " m");
        const double stiffness = e["stiffness"].numberWithin(0.0, limits::kMaxTieStiffness, "N/m", true);
        const double yieldForce = e["yield_force"].numberWithin(0.0, limits::kMaxForce, "N", true);
        pose.ties.push_back({a, b, stiffness, yieldForce});
      });
      if (pn.has("target"))
        pose.target = readVec3List(pn["target"], nv, "target positions", limits::kMaxCoordinate);
      s.poses.push_back(std::move(pose));
    }
  }

  // Design.
  if (root.has("design")) {
    Node d = root["design"];
    if (!d.j->is_object()) d.fail("expected an object, got " + d.typeName());
    warnUnknownKeys(d, {"parameters", "radius_bounds", "control_points_per_rod"});
    s.design.present = true;
    if (d.has("parameters")) {
      Node ps = d["parameters"];
      std::size_t n = ps.arraySize();
      for (std::size_t i = 0; i < n; ++i) {
        std::string p = ps.at(i).string();
        if (p == "radii") s.design.radii = true;
        else if (p == "rest_shape") s.design.restShape = true;
        else
          ps.at(i).fail("unknown design parameter " + quotedText(p) + " (expected radii or rest_shape)");
      }
    }
    if (d.has("radius_bounds")) {
      Node b = d["radius_bounds"];
      Vec2 v = b.vec2();
      if (!(v[0] > 0)) b.at(0).fail("minimum radius must be positive, got " + fmt(v[0]));
      if (!(v[1] > 0)) b.at(1).fail("maximum radius must be positive, got " + fmt(v[1]));
      if (v[0] > v[1]) b.fail("bounds with min > max: [" + fmt(v[0]) + ", " + fmt(v[1]) + "]");
      for (int k = 0; k < 2; ++k) b.at(k).numberWithin(limits::kMinRadius, limits::kMaxRadius, "m");
      s.design.radiusMin = v[0];
      s.design.radiusMax = v[1];
      s.design.hasRadiusBounds = true;
    }
    if (d.has("control_points_per_rod")) {
      Node c = d["control_points_per_rod"];
      if (!c.j->is_number_integer()) c.fail("expected an integer, got " + c.typeName());
      if (!c.integerWithin(2, limits::kMaxControlPoints))
        c.fail("need at least 2 and at most " + std::to_string(limits::kMaxControlPoints) +
               " control points per rod (docs/formats.md, \"Plausible ranges\"), got " + c.shortDump());
      s.design.controlPointsPerRod = c.j->get<int>();
    }
  }
  return s;
}

void validateForOptimize(const Scene& s) {
  const std::string file = s.sourcePath.empty() ? std::string("<scene>") : s.sourcePath;
  auto fail = [&](const std::string& keyPath, const std::string& what) {
    throw InputError(file + ": " + keyPath + ": " + what);
  };
  // What the user wrote, where the Scene no longer tells: "radius" or "radii",
  // a missing or an empty "parameters".
  json doc;
  try {
    if (!s.sourceText.empty()) doc = parseJsonText(s.sourceText, file);
  } catch (const std::exception&) {
    doc = json();
  }
  const bool haveDoc = doc.is_object();
  const bool wroteRadii = !haveDoc || doc.contains("radii");

  const DesignSpec& d = s.design;
  if (!d.present) fail("design", "missing; optimize needs a \"design\" block with \"parameters\" (radii, rest_shape)");
  if (!d.radii && !d.restShape) {
    const bool missing = haveDoc && doc["design"].is_object() && !doc["design"].contains("parameters");
    if (missing) fail("design.parameters", "missing; optimize needs at least one free parameter (radii, rest_shape)");
    fail("design.parameters", "no free parameters; optimize needs at least one of radii, rest_shape, got []");
  }
  if (d.hasRadiusBounds) {
    if (!(d.radiusMin > 0)) fail("design.radius_bounds[0]", "minimum radius must be positive, got " + fmt(d.radiusMin));
    if (!(d.radiusMax > 0)) fail("design.radius_bounds[1]", "maximum radius must be positive, got " + fmt(d.radiusMax));
    if (!(d.radiusMin >= limits::kMinRadius))
      fail("design.radius_bounds[0]", "outside its plausible range [" + fmt(limits::kMinRadius) + ", " +
                                          fmt(limits::kMaxRadius) + "] m, got " + fmt(d.radiusMin));
    if (!(d.radiusMax <= limits::kMaxRadius))
      fail("design.radius_bounds[1]", "outside its plausible range [" + fmt(limits::kMinRadius) + ", " +
                                          fmt(limits::kMaxRadius) + "] m, got " + fmt(d.radiusMax));
    if (d.radiusMin > d.radiusMax)
      fail("design.radius_bounds", "bounds with min > max, got [" + fmt(d.radiusMin) + ", " + fmt(d.radiusMax) + "]");
  }
  if (d.controlPointsPerRod < 2 || d.controlPointsPerRod > limits::kMaxControlPoints)
    fail("design.control_points_per_rod", "need at least 2 and at most " + std::to_string(limits::kMaxControlPoints) +
                                              " control points per rod, got " +
                                              std::to_string(d.controlPointsPerRod));

  bool anyPositive = false;
  for (std::size_t p = 0; p < s.poses.size(); ++p) {
    const Pose& pose = s.poses[p];
    const std::string at = "poses[" + std::to_string(p) + "]";
    if (pose.target.empty())
      fail(at + ".target", "missing; optimize needs a target for every pose, got pose " + std::to_string(p) + " " +
                               quotedText(pose.name) + " without one");
    if (pose.target.size() != s.vertices.size())
      fail(at + ".target", "expected " + std::to_string(s.vertices.size()) +
                               " target positions (one per vertex), got " + std::to_string(pose.target.size()));
    if (!(pose.weight >= 0)) fail(at + ".weight", "weight must be non-negative, got " + fmt(pose.weight));
    if (!(pose.weight <= limits::kMaxWeight))
      fail(at + ".weight", "outside its plausible range [0, " + fmt(limits::kMaxWeight) + "], got " + fmt(pose.weight));
    for (std::size_t v = 0; v < pose.target.size(); ++v)
      for (int k = 0; k < 3; ++k)
        if (!(std::abs(pose.target[v][k]) <= limits::kMaxCoordinate))
          fail(at + ".target[" + std::to_string(v) + "][" + std::to_string(k) + "]",
               "outside its plausible range [-" + fmt(limits::kMaxCoordinate) + ", " + fmt(limits::kMaxCoordinate) +
                   "] m, got " + fmt(pose.target[v][k]));
    anyPositive = anyPositive || pose.weight > 0;
  }
  if (!s.poses.empty() && !anyPositive) {
    std::string got;
    for (std::size_t p = 0; p < s.poses.size() && p < 4; ++p)
      got += (p ? ", " : "") + std::string("poses[") + std::to_string(p) + "].weight = " + fmt(s.poses[p].weight);
    if (s.poses.size() > 4) got += ", ...";
    fail("poses", "every pose weight is zero; optimize needs at least one positive weight, got " + got);
  }

  if (d.hasRadiusBounds) {
    static const char* kAxis[2] = {"r_t", "r_n"};
    const std::string bounds = "design.radius_bounds [" + fmt(d.radiusMin) + ", " + fmt(d.radiusMax) + "]";
    for (std::size_t v = 0; v < s.radii.size(); ++v) {
      for (int k = 0; k < 2; ++k) {
        const double r = s.radii[v][k];
        if (r >= d.radiusMin && r <= d.radiusMax) continue;
        if (wroteRadii)
          fail("radii[" + std::to_string(v) + "][" + std::to_string(k) + "]",
               std::string("initial ") + kAxis[k] + " of vertex " + std::to_string(v) + " lies outside " + bounds +
                   ", got " + fmt(r));
        fail("radius[" + std::to_string(k) + "]",
             std::string("initial ") + kAxis[k] + " of every vertex (\"radius\" sets vertices 0 to " +
                 std::to_string(s.radii.size() - 1) + ") lies outside " + bounds + ", got " + fmt(r));
      }
    }
  }
}

Scene readSceneFile(const std::string& path) { return parseScene(readInputFile(path, "scene file"), path); }

std::string readInputFile(const std::string& path, const std::string& what) {
  // stat() first: a FIFO without a writer would block open() and read(), a
  // device or socket could be endless, and a file over the limit is refused
  // by its size before a byte of it is read.
  struct stat st;
  if (::stat(path.c_str(), &st) != 0)
    throw InputError(path + ": cannot open " + what + " (" + std::strerror(errno) + ")");
  if (S_ISDIR(st.st_mode)) throw InputError(path + ": is a directory, not a " + what);
  auto notRegular = [&](const struct stat& t) {
    const char* kind = S_ISFIFO(t.st_mode)                        ? "a FIFO (named pipe)"
                       : S_ISSOCK(t.st_mode)                      ? "a socket"
                       : S_ISCHR(t.st_mode) || S_ISBLK(t.st_mode) ? "a device"
                                                                  : "a special file";
    return InputError(path + ": not a regular file (" + kind + "), not read as a " + what);
  };
  auto tooLarge = [&](long long bytes) {
    return InputError(path + ": " + what + " is larger than " + std::to_string(kMaxInputFileBytes >> 20) +
                      " MiB (" + std::to_string(bytes) + " bytes); not read");
  };
  if (!S_ISREG(st.st_mode)) throw notRegular(st);
  if (static_cast<unsigned long long>(st.st_size) > kMaxInputFileBytes) throw tooLarge(st.st_size);
  // O_NONBLOCK: should the path have been replaced by a FIFO since stat(),
  // open() does not wait for a writer; fstat() then sees what was opened.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw InputError(path + ": cannot open " + what + " (" + std::strerror(errno) + ")");
  struct FdCloser {
    int fd;
    ~FdCloser() { ::close(fd); }
  } closer{fd};
  if (::fstat(fd, &st) != 0) throw InputError(path + ": cannot read " + what + " (" + std::strerror(errno) + ")");
  if (!S_ISREG(st.st_mode)) throw notRegular(st);
  if (static_cast<unsigned long long>(st.st_size) > kMaxInputFileBytes) throw tooLarge(st.st_size);
  // Read in blocks up to the limit (a file may grow while it is read).
  std::string text;
  text.reserve(static_cast<std::size_t>(st.st_size));
  char buf[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw InputError(path + ": cannot read " + what + " (" + std::strerror(errno) + ")");
    if (n == 0) break;
    text.append(buf, static_cast<std::size_t>(n));
    if (text.size() > kMaxInputFileBytes) throw tooLarge(static_cast<long long>(text.size()));
  }
  return text;
}

}  // namespace rodmesh
