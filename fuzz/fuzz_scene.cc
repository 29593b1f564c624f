// libFuzzer harness: the scene reader (io/scene_reader.hh) on arbitrary text.
// Accepted scenes must survive the way out and back (sceneToJson, parseScene)
// unchanged in size, build a rod network, and pass or fail the optimize checks
// with an InputError; rejections must be one line naming the file.
#include "fuzz/fuzz_check.hh"
#include "io/scene_reader.hh"
#include "io/scene_writer.hh"
#include "model/network.hh"

#include <cstddef>
#include <cstdint>
#include <string>

using namespace rodmesh;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string file = "fuzz.json";
  Scene s;
  try {
    s = parseScene(text, file);
  } catch (const InputError& e) {
    fuzz::checkMessage(e.what(), file);
    return 0;
  }
  try {
    validateForOptimize(s);
  } catch (const InputError& e) {
    fuzz::checkMessage(e.what(), file);
  }
  // What the writer makes of an accepted scene is accepted again, the same size.
  const std::string again = sceneToJson(s);
  Scene t;
  try {
    t = parseScene(again, "again.json");
  } catch (const InputError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    fuzz::require(false, "a scene written by sceneToJson is rejected");
  }
  fuzz::require(
      t.vertices.size() == s.vertices.size() && t.rods.size() == s.rods.size() && t.poses.size() == s.poses.size(),
      "sceneToJson changes the scene");
  // Everything the model relies on was checked by the reader.
  const RodNetwork net(s);
  fuzz::require(net.numVertices() == static_cast<int>(s.vertices.size()), "the network lost vertices");
  return 0;
}
