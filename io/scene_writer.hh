// Writes a Scene as "rodmesh-scene/1" JSON (docs/formats.md §1).
#pragma once

#include "model/scene.hh"

#include <string>

namespace rodmesh {

// Serialises the scene; parseScene(sceneToJson(s)) reproduces s. Radii are
// written as "radius" when uniform, else as "radii".
std::string sceneToJson(const Scene& s, int indent = 1);

// Writes atomically (temporary file, then rename). Throws std::runtime_error.
void writeSceneFile(const Scene& s, const std::string& path);

}  // namespace rodmesh
