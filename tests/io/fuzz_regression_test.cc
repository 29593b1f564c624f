// Inputs found by fuzzing (scripts/fuzz.sh) and by the black-box
// runs, kept in fuzz/regressions/{scene,archive}/, read by the normal readers
// in the default suite (no clang needed): each is answered within seconds by
// a scene or archive, or by one InputError line that starts with the file
// name, never by a crash or a hang. The surface inputs are read by
// tests/meshing/surface_fuzz_regression_test.cc.
#include "io/archive.hh"
#include "io/scene_reader.hh"

#include <gtest/gtest.h>

#include <chrono>
#include <dirent.h>
#include <string>
#include <vector>

namespace rodmesh {
namespace {

const std::string kRegressions = std::string(RODMESH_SOURCE_DIR) + "/fuzz/regressions/";

std::vector<std::string> inputsOf(const std::string& target) {
  std::vector<std::string> out;
  if (DIR* d = opendir((kRegressions + target).c_str())) {
    while (dirent* e = readdir(d))
      if (e->d_name[0] != '.') out.push_back(kRegressions + target + "/" + e->d_name);
    closedir(d);
  }
  return out;
}

// Runs `read` on every input of `target`; returns how many were rejected.
template <class Read>
int readAll(const std::string& target, Read read) {
  const std::vector<std::string> inputs = inputsOf(target);
  EXPECT_FALSE(inputs.empty()) << "no inputs in fuzz/regressions/" << target;
  int rejected = 0;
  for (const std::string& path : inputs) {
    SCOPED_TRACE(path);
    const auto t0 = std::chrono::steady_clock::now();
    try {
      read(path);
    } catch (const InputError& e) {
      const std::string msg = e.what();
      EXPECT_EQ(msg.rfind(path + ":", 0), 0u) << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
      ++rejected;
    }
    // A contained HDF5 loop takes 4 s (io/archive.hh: readArchiveIsolated).
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 20.0);
  }
  return rejected;
}

TEST(FuzzRegressions, SceneInputs) {
  const int rejected = readAll("scene", [](const std::string& p) { readSceneFile(p); });
  EXPECT_EQ(rejected, static_cast<int>(inputsOf("scene").size())) << "every kept scene input is invalid";
}

TEST(FuzzRegressions, ArchiveInputs) {
  const int rejected = readAll("archive", [](const std::string& p) { loadArchive(p); });
  EXPECT_EQ(rejected, static_cast<int>(inputsOf("archive").size())) << "every kept archive input is invalid";
}

}  // namespace
}  // namespace rodmesh
