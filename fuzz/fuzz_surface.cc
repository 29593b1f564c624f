// libFuzzer harness: the OBJ, OFF and PLY readers (meshing/surface.hh) on
// arbitrary bytes. The format follows the first bytes as a user's file
// extension would: "ply" -> PLY, "OFF" -> OFF, anything else OBJ. Accepted
// polygon soups go through validateSurface and the surface topology;
// rejections must be one line naming the file.
#include "fuzz/fuzz_check.hh"
#include "io/scene_reader.hh"
#include "meshing/surface.hh"

#include <cstddef>
#include <cstdint>
#include <string>

using namespace rodmesh;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  const std::string format = bytes.rfind("ply", 0) == 0 ? "ply" : bytes.rfind("OFF", 0) == 0 ? "off" : "obj";
  const std::string file = "fuzz." + format;
  try {
    const meshing::PolygonSoup soup = meshing::parsePolygonText(bytes, format, file);
    std::vector<char> flips;
    const meshing::TriSurface s = meshing::validateSurface(soup, file, &flips);
    fuzz::require(flips.size() == s.faces.size(), "one flip flag per face");
    const meshing::SurfaceTopology topo(s);
    fuzz::require(topo.faceNeighbours.size() == s.faces.size(), "one neighbour triple per face");
  } catch (const InputError& e) {
    fuzz::checkMessage(e.what(), file);
  }
  return 0;
}
