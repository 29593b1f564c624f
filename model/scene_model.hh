// A scene prepared for solving: its network, resolved effects and one pose
// model per pose, all built once and read-only afterwards (solvers keep their
// states and workspaces themselves).
#pragma once

#include "model/effects.hh"
#include "model/network.hh"
#include "model/pose_system.hh"
#include "model/scene.hh"

#include <memory>
#include <vector>

namespace rodmesh {

class SceneModel {
 public:
  explicit SceneModel(const Scene& scene);
  const Scene& scene() const { return scene_; }
  const RodNetwork& network() const { return network_; }
  const EffectSet& effects() const { return effects_; }
  const PoseSystem& pose(int i) const { return *poses_[i]; }
  int numPoses() const { return static_cast<int>(poses_.size()); }

 private:
  const Scene& scene_;
  RodNetwork network_;
  EffectSet effects_;
  std::vector<std::unique_ptr<const PoseSystem>> poses_;
};

}  // namespace rodmesh
