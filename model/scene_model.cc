#include "model/scene_model.hh"

namespace rodmesh {

SceneModel::SceneModel(const Scene& scene) : scene_(scene), network_(scene), effects_(resolveEffects(scene, network_)) {
  for (int p = 0; p < static_cast<int>(scene.poses.size()); ++p)
    poses_.push_back(std::make_unique<const PoseSystem>(scene_, network_, effects_, p));
}

}  // namespace rodmesh
