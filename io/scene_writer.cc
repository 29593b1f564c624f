#include "io/scene_writer.hh"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <unistd.h>

namespace rodmesh {
namespace {
using json = nlohmann::json;
json vec(const Vec3& v) { return json::array({v.x(), v.y(), v.z()}); }
}  // namespace

std::string sceneToJson(const Scene& s, int indent) {
  json j;
  j["format"] = "rodmesh-scene/1";
  j["material"] = {{"young_modulus", s.material.youngModulus},
                   {"poisson_ratio", s.material.poissonRatio},
                   {"density", s.material.density}};
  json vs = json::array();
  for (const Vec3& v : s.vertices) vs.push_back(vec(v));
  j["vertices"] = std::move(vs);
  if (!s.normals.empty()) {
    json ns = json::array();
    for (const Vec3& n : s.normals) ns.push_back(vec(n));
    j["normals"] = std::move(ns);
  }
  json rods = json::array();
  for (const Rod& r : s.rods) {
    json rj = {{"vertices", r.vertices}};
    if (r.normal) rj["normal"] = vec(*r.normal);
    rods.push_back(std::move(rj));
  }
  j["rods"] = std::move(rods);
  bool uniform = !s.radii.empty();
  for (const Vec2& r : s.radii) uniform = uniform && r == s.radii.front();
  if (uniform) {
    j["radius"] = {s.radii.front()[0], s.radii.front()[1]};
  } else {
    json rs = json::array();
    for (const Vec2& r : s.radii) rs.push_back({r[0], r[1]});
    j["radii"] = std::move(rs);
  }
  if (s.gravity) j["gravity"] = vec(*s.gravity);
  if (s.effects) {
    json e = json::array();
    for (Effect x : *s.effects) e.push_back(effectName(x));
    j["effects"] = std::move(e);
  }
  json poses = json::array();
  for (const Pose& p : s.poses) {
    json pj;
    pj["name"] = p.name;
    pj["weight"] = p.weight;
    json fixed = json::array();
    for (const FixedVertex& f : p.fixed) {
      json fj = {{"vertex", f.vertex}};
      if (f.position) fj["position"] = vec(*f.position);
      fixed.push_back(std::move(fj));
    }
    if (!fixed.empty()) pj["fixed"] = std::move(fixed);
    json clamped = json::array();
    for (const ClampedVertex& c : p.clamped) clamped.push_back({{"vertex", c.vertex}});
    if (!clamped.empty()) pj["clamped"] = std::move(clamped);
    json forces = json::array();
    for (const PointForce& f : p.forces) forces.push_back({{"vertex", f.vertex}, {"force", vec(f.force)}});
    if (!forces.empty()) pj["forces"] = std::move(forces);
    json moments = json::array();
    for (const TwistingMoment& m : p.twistingMoments) moments.push_back({{"vertex", m.vertex}, {"moment", m.moment}});
    if (!moments.empty()) pj["twisting_moments"] = std::move(moments);
    json contacts = json::array();
    for (const VertexContact& c : p.contacts)
      contacts.push_back({{"vertices", {c.a, c.b}}, {"distance", c.distance}, {"stiffness", c.stiffness}});
    if (!contacts.empty()) pj["contacts"] = std::move(contacts);
    json ties = json::array();
    for (const VertexTie& t : p.ties)
      ties.push_back({{"vertices", {t.a, t.b}}, {"stiffness", t.stiffness}, {"yield_force", t.yieldForce}});
    if (!ties.empty()) pj["ties"] = std::move(ties);
    if (!p.target.empty()) {
      json t = json::array();
      for (const Vec3& v : p.target) t.push_back(vec(v));
      pj["target"] = std::move(t);
    }
    poses.push_back(std::move(pj));
  }
  j["poses"] = std::move(poses);
  if (s.design.present) {
    json d;
    json params = json::array();
    if (s.design.radii) params.push_back("radii");
    if (s.design.restShape) params.push_back("rest_shape");
    d["parameters"] = std::move(params);
    if (s.design.hasRadiusBounds) d["radius_bounds"] = {s.design.radiusMin, s.design.radiusMax};
    d["control_points_per_rod"] = s.design.controlPointsPerRod;
    j["design"] = std::move(d);
  }
  return j.dump(indent);
}

void writeSceneFile(const Scene& s, const std::string& path) {
  const std::string text = sceneToJson(s);
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw std::runtime_error("cannot write " + tmp);
    out << text << "\n";
    if (!out) { std::remove(tmp.c_str()); throw std::runtime_error("cannot write " + tmp); }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error("cannot move " + tmp + " to " + path);
  }
}

}  // namespace rodmesh
