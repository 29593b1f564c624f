#include "model/scene.hh"

namespace rodmesh {

const char* effectName(Effect e) {
  switch (e) {
    case Effect::Stretch: return "stretch";
    case Effect::Bend: return "bend";
    case Effect::Twist: return "twist";
    case Effect::Connections: return "connections";
    case Effect::Gravity: return "gravity";
  }
  return "?";
}

}  // namespace rodmesh
