// Helpers of the hard-case suite (tests/hard): every case writes its scene to
// a fresh temporary directory, runs the real `rodmesh` executable on it (as a
// user and the acceptance checks do) and reads back the archive.
#pragma once

#include <gtest/gtest.h>
#include <hdf5.h>
#include <stdlib.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "io/archive.hh"
#include "io/scene_writer.hh"
#include "model/scene.hh"
#include "tests/cli/cli_util.hh"

namespace rodmesh::hardtest {

struct RunResult {
  int status = -1;  // exit status of rodmesh
  std::string err;  // its stderr
  std::string out;  // its stdout
};

class HardCase : public ::testing::Test {
 public:
  void SetUp() override {
    char t[] = "/tmp/rodmesh_hard_XXXXXX";
    ASSERT_NE(mkdtemp(t), nullptr);
    dir_ = t;
  }
  void TearDown() override { std::system(("rm -rf " + clitest::shellQuote(dir_)).c_str()); }

  std::string path(const std::string& name) const { return dir_ + "/" + name; }

  // rodmesh ARGS, run in the case's directory. RODMESH_HARD_EXE, when set,
  // names another executable to hold to the same cases (e.g. an older build).
  RunResult run(const std::string& args) const {
    const char* other = std::getenv("RODMESH_HARD_EXE");
    const std::string exe = other && *other ? other : RODMESH_EXE;
    const std::string cmd = "cd " + clitest::shellQuote(dir_) + " && " + clitest::shellQuote(exe) + " " + args +
                            " >" + clitest::shellQuote(path("stdout.txt")) + " 2>" + clitest::shellQuote(path("stderr.txt"));
    const int rc = std::system(cmd.c_str());
    RunResult r;
    r.status = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
    r.err = clitest::readText(path("stderr.txt"));
    r.out = clitest::readText(path("stdout.txt"));
    return r;
  }

  // Writes the scene and runs `simulate scene.json -o out.h5 FLAGS`.
  RunResult simulate(const Scene& s, const std::string& flags = "") const {
    writeSceneFile(s, path("scene.json"));
    return run("simulate scene.json -o out.h5 " + flags);
  }

  Archive archive() const { return readArchive(path("out.h5")); }
  bool archiveExists() const { return !clitest::readText(path("out.h5")).empty(); }

  // The root attribute "message" (why poses did not converge), empty if absent.
  std::string rootMessage() const {
    std::string out;
    const hid_t f = H5Fopen(path("out.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) return out;
    if (H5Aexists(f, "message") > 0) {
      const hid_t a = H5Aopen(f, "message", H5P_DEFAULT);
      const hid_t t = H5Aget_type(a);
      if (H5Tis_variable_str(t) > 0) {
        char* s = nullptr;
        const hid_t mt = H5Tcopy(H5T_C_S1);
        H5Tset_size(mt, H5T_VARIABLE);
        if (H5Aread(a, mt, &s) >= 0 && s) {
          out = s;
          H5free_memory(s);
        }
        H5Tclose(mt);
      } else {
        std::vector<char> buf(H5Tget_size(t) + 1, '\0');
        if (H5Aread(a, t, buf.data()) >= 0) out = buf.data();
      }
      H5Tclose(t);
      H5Aclose(a);
    }
    H5Fclose(f);
    return out;
  }

  std::string dir_;
};

// Every number an archive holds for its poses and frames is finite.
inline ::testing::AssertionResult archiveFinite(const Archive& a) {
  for (const ArchivePose& p : a.poses) {
    if (!p.positions.allFinite()) return ::testing::AssertionFailure() << "pose " << p.name << ": positions";
    if (p.twist.size() > 0 && !p.twist.allFinite())
      return ::testing::AssertionFailure() << "pose " << p.name << ": twist";
    if (!std::isfinite(p.residualNorm)) return ::testing::AssertionFailure() << "pose " << p.name << ": residual_norm";
  }
  for (const ArchiveFrames& f : a.frames) {
    if (!f.time.allFinite()) return ::testing::AssertionFailure() << "frames " << f.name << ": time";
    for (const MatX3& x : f.positions)
      if (!x.allFinite()) return ::testing::AssertionFailure() << "frames " << f.name << ": positions";
  }
  return ::testing::AssertionSuccess();
}

inline const ArchivePose& onlyPose(const Archive& a) { return a.poses.at(0); }

inline Vec3 row(const MatX3& m, int i) { return m.row(i).transpose(); }

// A straight rod of `vertices` vertices from `origin` along unit `dir` over
// `length`, uniform radii, one pose "p" without supports or loads.
inline Scene straightRod(int vertices, double length, double radius, const Material& m, const Vec3& dir = Vec3::UnitX(),
                         const Vec3& origin = Vec3::Zero()) {
  Scene s;
  s.sourcePath = "<hard case>";
  s.material = m;
  Rod rod;
  for (int i = 0; i < vertices; ++i) {
    s.vertices.push_back(origin + dir * (length * i / (vertices - 1)));
    rod.vertices.push_back(i);
  }
  s.rods.push_back(rod);
  s.radii.assign(s.vertices.size(), Vec2(radius, radius));
  Pose p;
  p.name = "p";
  s.poses.push_back(p);
  return s;
}

}  // namespace rodmesh::hardtest
