// Which physics a scene is solved with (contract §1 "effects"), and why.
//
// Explicit "effects" lists are honoured; otherwise effects are inferred:
// stretch and bend always; gravity only if a non-zero gravity vector is given;
// connections only if the mesh has any; twist (and out-of-plane motion) only if
// the scene is not planar. A scene is planar when all rest vertices, point
// forces, gravity, fixed positions and targets lie in one plane and every
// reference normal is perpendicular to it or lies in it (then the plane is a
// mirror plane of the whole problem, so the full 3D model has an equilibrium in
// it with zero twist). A planar scene without twist is solved with two
// in-plane unknowns per vertex.
#pragma once

#include "model/network.hh"
#include "model/scene.hh"

#include <Eigen/Core>
#include <array>
#include <string>

namespace rodmesh {

struct EffectSet {
  std::array<bool, kEffectCount> on{};
  std::array<std::string, kEffectCount> reason;  // one phrase per effect
  bool planar = false;                           // solved with in-plane unknowns
  std::string planarReason;
  Eigen::Vector3d planeOrigin = Eigen::Vector3d::Zero();
  Eigen::Vector3d planeNormal = Eigen::Vector3d::UnitZ();
  Eigen::Matrix<double, 3, 2> planeBasis = Eigen::Matrix<double, 3, 2>::Zero();  // orthonormal in-plane axes

  bool has(Effect e) const { return on[static_cast<int>(e)]; }
  std::string list() const;     // "stretch,bend,gravity"
  std::string explain() const;  // "stretch: always; twist: off (planar scene); ..."
};

// Whether a connection model is compiled into this build (the connection
// energy arrives with the rod-network work).
bool connectionModelAvailable();

EffectSet resolveEffects(const Scene& scene, const RodNetwork& network);

// The full 3D variant of a planar effect set: the same effects with
// out-of-plane motion and twist (to judge an in-plane equilibrium's stability
// against leaving the plane).
EffectSet spatialVariant(const EffectSet& planar);

}  // namespace rodmesh
