// Surface inputs found by fuzzing (scripts/fuzz.sh) or reported in issues,
// kept in fuzz/regressions/surface/ with the extension that selects their
// reader, read by readSurface: each is answered within seconds by a surface
// or by one InputError line that starts with the file name, never by a crash
// or a hang. Scene and archive inputs: tests/io/fuzz_regression_test.cc.
#include "io/scene_reader.hh"
#include "meshing/surface.hh"

#include <gtest/gtest.h>

#include <chrono>
#include <dirent.h>
#include <string>
#include <vector>

namespace rodmesh::meshing {
namespace {

TEST(FuzzRegressions, SurfaceInputs) {
  const std::string dir = std::string(RODMESH_SOURCE_DIR) + "/fuzz/regressions/surface/";
  std::vector<std::string> inputs;
  if (DIR* d = opendir(dir.c_str())) {
    while (dirent* e = readdir(d))
      if (e->d_name[0] != '.') inputs.push_back(dir + e->d_name);
    closedir(d);
  }
  ASSERT_FALSE(inputs.empty()) << "no inputs in " << dir;
  for (const std::string& path : inputs) {
    SCOPED_TRACE(path);
    const auto t0 = std::chrono::steady_clock::now();
    try {
      const TriSurface s = readSurface(path);
      EXPECT_FALSE(s.faces.empty());
    } catch (const InputError& e) {
      const std::string msg = e.what();
      EXPECT_EQ(msg.rfind(path + ":", 0), 0u) << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    }
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 10.0);
  }
}

}  // namespace
}  // namespace rodmesh::meshing
