#include "model/effects.hh"

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include <cmath>
#include <sstream>

namespace rodmesh {

std::string EffectSet::list() const {
  std::string s;
  for (int k = 0; k < kEffectCount; ++k)
    if (on[k]) s += (s.empty() ? "" : ",") + std::string(effectName(static_cast<Effect>(k)));
  return s;
}

std::string EffectSet::explain() const {
  std::ostringstream os;
  for (int k = 0; k < kEffectCount; ++k)
    os << effectName(static_cast<Effect>(k)) << ": " << (on[k] ? "on" : "off") << " (" << reason[k] << "); ";
  os << "unknowns: " << (planar ? "in-plane (2 per vertex)" : "3D (3 per vertex)") << " (" << planarReason << ")";
  return os.str();
}

namespace {

// Finds a plane containing every point (relative to origin) and direction of
// the scene. Returns false if none exists.
bool findPlane(const Scene& scene, const RodNetwork& net, Eigen::Vector3d& normal, std::string& why) {
  const Eigen::Vector3d o = scene.vertices[0];
  double extent = 0.0;
  for (const Vec3& p : scene.vertices) extent = std::max(extent, (p - o).norm());
  std::vector<Eigen::Vector3d> dirs;  // unit directions that must lie in the plane
  auto addPoint = [&](const Vec3& p) {
    Vec3 d = p - o;
    if (d.norm() > 1e-12 * extent) dirs.push_back(d / extent);
  };
  // stableNorm: a load of 1e200 N (or 1e-200 N) must not overflow (underflow)
  // to a zero direction and be projected out of the problem.
  auto addDir = [&](const Vec3& v) {
    if (v.stableNorm() > 0) dirs.push_back(v.stableNormalized());
  };
  for (const Pose& pose : scene.poses)
    if (!pose.twistingMoments.empty()) {
      why = "pose '" + pose.name + "' applies twisting moments";
      return false;
    }
  for (const Vec3& p : scene.vertices) addPoint(p);
  if (scene.gravity) addDir(*scene.gravity);
  for (const Pose& pose : scene.poses) {
    for (const PointForce& f : pose.forces) addDir(f.force);
    for (const FixedVertex& f : pose.fixed)
      if (f.position) addPoint(*f.position);
    for (const Vec3& t : pose.target) addPoint(t);
  }
  Eigen::MatrixXd M(dirs.size(), 3);
  for (std::size_t i = 0; i < dirs.size(); ++i) M.row(i) = dirs[i].transpose();
  const double tol = 1e-9;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(M, Eigen::ComputeFullV);
  Eigen::Vector3d sv = Eigen::Vector3d::Zero();
  for (int i = 0; i < std::min<int>(3, svd.singularValues().size()); ++i) sv[i] = svd.singularValues()[i];
  if (sv[2] > tol * std::max(1.0, sv[0])) {
    why = "the scene is not planar";
    return false;
  }
  if (sv[1] > tol * std::max(1.0, sv[0])) {
    normal = svd.matrixV().col(2);
  } else {
    // Everything on one line: any plane through it will do; take the one whose
    // normal is the reference normal of the first vertex (so in-plane bending
    // is bending within the tangent plane).
    Eigen::Vector3d line = svd.matrixV().col(0);
    Eigen::Vector3d n = net.vertexNormals()[0];
    n -= n.dot(line) * line;
    if (n.norm() < 1e-6) n = svd.matrixV().col(2);
    normal = n.normalized();
  }
  // Reference normals must be perpendicular to the plane or lie in it.
  for (std::size_t v = 0; v < net.vertexNormals().size(); ++v) {
    const double c = std::abs(net.vertexNormals()[v].dot(normal));
    if (c > 1e-9 && c < 1.0 - 1e-9) {
      why = "the scene is planar but reference normal " + std::to_string(v) + " is oblique to its plane";
      return false;
    }
  }
  why = "all vertices, loads, fixed positions and targets lie in one plane";
  return true;
}

}  // namespace

bool connectionModelAvailable() { return true; }

EffectSet resolveEffects(const Scene& scene, const RodNetwork& net) {
  EffectSet fx;
  auto set = [&](Effect e, bool v, const std::string& why) {
    fx.on[static_cast<int>(e)] = v;
    fx.reason[static_cast<int>(e)] = why;
  };
  const bool hasGravity = scene.gravity && scene.gravity->norm() > 0;
  Eigen::Vector3d normal;
  std::string planeWhy;
  const bool geometricPlane = findPlane(scene, net, normal, planeWhy);

  if (scene.effects) {
    std::array<bool, kEffectCount> listed{};
    for (Effect e : *scene.effects) listed[static_cast<int>(e)] = true;
    for (int k = 0; k < kEffectCount; ++k) set(static_cast<Effect>(k), listed[k], listed[k] ? "listed in the scene" : "not listed in the scene");
    if (listed[static_cast<int>(Effect::Gravity)] && !hasGravity) set(Effect::Gravity, false, "listed, but the gravity vector is zero");
  } else {
    set(Effect::Stretch, true, "always");
    set(Effect::Bend, true, "always");
    set(Effect::Gravity, hasGravity, hasGravity ? "gravity vector given" : "no gravity vector in the scene");
    set(Effect::Connections, net.numConnections() > 0,
        net.numConnections() > 0 ? std::to_string(net.numConnections()) + " connections in the mesh" : "the mesh has no connections");
    set(Effect::Twist, !geometricPlane, geometricPlane ? "planar scene: nothing can twist" : "the scene is not planar");
  }
  if (fx.has(Effect::Connections) && !connectionModelAvailable())
    set(Effect::Connections, false, "connection model not available in this build; rods are pinned at shared vertices");

  fx.planar = geometricPlane && !fx.has(Effect::Twist);
  if (fx.planar) {
    fx.planarReason = planeWhy;
  } else if (!geometricPlane) {
    fx.planarReason = planeWhy;
  } else {
    fx.planarReason = "twist was asked for, which needs 3D unknowns";
  }
  fx.planeNormal = normal;
  fx.planeOrigin = scene.vertices[0];
  if (fx.planar) {
    // Orthonormal in-plane basis, deterministic.
    Eigen::Vector3d a = std::abs(normal.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    a = (a - a.dot(normal) * normal).normalized();
    fx.planeBasis.col(0) = a;
    fx.planeBasis.col(1) = normal.cross(a);
  }
  return fx;
}

EffectSet spatialVariant(const EffectSet& planar) {
  EffectSet full = planar;
  full.planar = false;
  full.on[static_cast<int>(Effect::Twist)] = true;
  return full;
}

}  // namespace rodmesh
