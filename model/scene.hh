// Scene: the in-memory form of a "rodmesh-scene/1" file (docs/formats.md §1).
//
// Plain data, SI units throughout (metres, pascals, kg/m^3, newtons). The scene
// reader (io/scene_reader.hh) fills it and validates everything a user can get
// wrong; code downstream may assume a Scene satisfies the contract.
#pragma once

#include <Eigen/Core>

#include <optional>
#include <string>
#include <vector>

namespace rodmesh {

using Vec3 = Eigen::Vector3d;
using Vec2 = Eigen::Vector2d;

struct Material {
  double youngModulus = 0.0;  // E [Pa]
  double poissonRatio = 0.0;  // nu [-]
  double density = 0.0;       // rho [kg/m^3]
  double shearModulus() const { return youngModulus / (2.0 * (1.0 + poissonRatio)); }
};

struct Rod {
  std::vector<int> vertices;   // polyline through scene vertices, at least one edge
  std::optional<Vec3> normal;  // optional rod-level reference normal
};

struct FixedVertex {
  int vertex = -1;
  std::optional<Vec3> position;  // default: rest position
};

struct ClampedVertex {
  int vertex = -1;
};

struct PointForce {
  int vertex = -1;
  Vec3 force = Vec3::Zero();
};

// Extension: a twisting moment [N m] about the tangent of the end edge of a
// rod at a free end vertex, right-handed about the direction pointing out of
// the rod through that vertex.
struct TwistingMoment {
  int vertex = -1;
  double moment = 0.0;
};

// Extension: a soft contact that keeps vertices a and b at least `distance`
// [m] apart, pushing with up to `stiffness` [N] (model/terms/contact.hh).
struct VertexContact {
  int a = -1, b = -1;
  double distance = 0.0;
  double stiffness = 0.0;
};

// Extension: an elastic-perfectly-plastic tie between vertices a and b:
// tension stiffness * (distance - rest length), at most yieldForce in
// magnitude, beyond which the rest length follows (model/terms/tie.hh).
struct VertexTie {
  int a = -1, b = -1;
  double stiffness = 0.0;   // N/m
  double yieldForce = 0.0;  // N
};

struct Pose {
  std::string name;
  double weight = 1.0;
  std::vector<FixedVertex> fixed;
  std::vector<ClampedVertex> clamped;
  std::vector<PointForce> forces;
  std::vector<TwistingMoment> twistingMoments;  // extension "twisting_moments"
  std::vector<VertexContact> contacts;          // extension "contacts"
  std::vector<VertexTie> ties;                  // extension "ties"
  std::vector<Vec3> target;  // empty when absent, else one per vertex
};

// Effects a scene may ask for (contract §1 "effects").
enum class Effect { Stretch = 0, Bend, Twist, Connections, Gravity };
constexpr int kEffectCount = 5;
const char* effectName(Effect e);

struct DesignSpec {
  bool present = false;
  bool radii = false;      // per-vertex cross-section radii are free
  bool restShape = false;  // rest positions are free
  double radiusMin = 0.0, radiusMax = 0.0;
  bool hasRadiusBounds = false;
  int controlPointsPerRod = 4;
};

struct Scene {
  std::string sourcePath;  // file the scene came from (for messages)
  std::string sourceText;  // verbatim JSON (stored in the archive)

  Material material;
  std::vector<Vec3> vertices;      // rest centreline nodes
  std::vector<Vec3> normals;       // empty, or one unit normal per vertex
  std::vector<Rod> rods;
  std::vector<Vec2> radii;         // [r_t, r_n] per vertex (radius/radii resolved)
  std::optional<Vec3> gravity;
  std::optional<std::vector<Effect>> effects;  // explicit list, if given
  std::vector<Pose> poses;
  DesignSpec design;
};

}  // namespace rodmesh
