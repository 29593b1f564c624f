// libFuzzer harness: the archive reader used by `inspect` and `export`
// (io/archive.hh) on arbitrary bytes, as an HDF5 file image in memory: the
// structure checks of readArchiveImage, then the scene and validateArchive,
// as loadArchive does (without its child process, so that libFuzzer sees the
// coverage). Rejections must be one line naming the file. Findings inside
// the HDF5 library itself (loops, crashes) are what loadArchive's child
// process contains; see docs/fuzzing.md.
#include "fuzz/fuzz_check.hh"
#include "io/archive.hh"
#include "io/scene_reader.hh"

#include <cstddef>
#include <cstdint>
#include <string>

using namespace rodmesh;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string file = "fuzz.h5";
  try {
    const Archive a = readArchiveImage(data, size, file);
    const Scene s = parseScene(a.sceneJson, file + ":/scene");
    validateArchive(a, s, file);
    // A valid archive is written back and read back alike.
    const std::string image = writeArchiveImage(a);
    const Archive b = readArchiveImage(image.data(), image.size(), file);
    fuzz::require(b.poses.size() == a.poses.size() && b.restPositions == a.restPositions,
                  "the archive changes on a round trip");
  } catch (const InputError& e) {
    fuzz::checkMessage(e.what(), file);
  }
  return 0;
}
