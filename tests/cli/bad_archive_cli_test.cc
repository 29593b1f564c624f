// Archives are untrusted input (issue 9, item 4): `inspect` and every kind of
// `export` (printable solid, .vtp, .pvd collection, XDMF) answer a damaged
// archive with exit status 2 and one message naming the file and the dataset
// or attribute, and write nothing. The damage is done with h5py by
// tests/cli/corrupt_archive.py: missing parts, wrong shapes and types, links,
// declared sizes far beyond the file, non-finite and out-of-range values,
// disagreement with the scene, truncated and overwritten bytes. Inputs found
// by fuzzing (fuzz/regressions/archive/) get the same treatment. Every command
// runs under timeout(1), so a hang fails instead of stalling the suite. Built
// only with the meshing module, which brings the export verb (tests/CMakeLists.txt).
#include "tests/cli/cli_util.hh"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <string>
#include <vector>

namespace rodmesh {
namespace {

using clitest::readText;
using clitest::shellQuote;
using clitest::writeText;

const std::string kExe = RODMESH_EXE;
const std::string kSourceDir = RODMESH_SOURCE_DIR;
const std::string kPython = "/usr/bin/python3";
constexpr int kTimeoutSeconds = 30;  // a contained HDF5 hang takes about 4 s
constexpr int kTimedOut = 124;

struct Damage {
  std::string mode;                 // corrupt_archive.py MODE
  std::string object;               // must appear in the message
  std::vector<std::string> values;  // so must these
};

// Every mode of corrupt_archive.py, with the dataset or attribute the message must name.
const std::vector<Damage> kDamage = {
    {"no_scene", "/scene: missing", {}},
    {"no_rest", "/rest/positions: missing", {}},
    {"no_radii", "/design/radii: missing", {}},
    {"no_pose_positions", "/poses/small/positions: missing", {}},
    {"no_poses", "/poses: missing", {}},
    {"empty_poses", "/poses: holds no pose", {}},
    {"no_status", "/ attribute status: missing", {}},
    {"no_n_vertices", "/model attribute n_vertices: missing", {}},
    {"no_residual", "/poses/large attribute residual_norm: missing", {}},
    {"rest_two_columns", "/rest/positions: has shape 6 x 2", {"V x 3"}},
    {"rest_one_dimensional", "/rest/positions: has shape 18", {}},
    {"pose_short", "/poses/large/positions: has shape 5 x 3", {"expected 6 x 3"}},
    {"target_long", "/poses/small/target: has shape 12 x 3", {"expected 6 x 3"}},
    {"radii_three_columns", "/design/radii: has shape 6 x 3", {"expected 6 x 2"}},
    {"twist_wrong_length", "/poses/large/twist: has shape 2", {"expected 5", "n_edges"}},
    {"scalar_rest", "/rest/positions: has shape 1 (a scalar)", {}},
    {"empty_rest", "/rest/positions: has no rows", {}},
    {"rest_strings", "/rest/positions: holds strings, expected numbers", {}},
    {"rest_compound", "/rest/positions: holds compound records", {}},
    {"scene_numbers", "/scene: holds floating-point numbers, expected a string", {}},
    {"status_number", "/ attribute status: holds integers, expected a string", {}},
    {"n_vertices_string", "/model attribute n_vertices: holds strings, expected numbers", {}},
    {"n_vertices_fraction", "/model attribute n_vertices: expected a whole number", {"6.5"}},
    {"residual_string", "/poses/large attribute residual_norm: holds strings", {}},
    {"rest_is_group", "/rest/positions: is a group, expected a dataset", {}},
    {"poses_is_dataset", "/poses: is a dataset, expected a group", {}},
    {"rest_soft_link", "/rest/positions: is a soft link", {}},
    {"rest_external_link", "/rest/positions: is an external link", {}},
    {"huge_rest", "/rest/positions: declares 3298534883328 values", {}},
    {"huge_twist", "/poses/large/twist: declares 2147483647 values", {}},
    {"huge_string", "/scene: declares 2147483646-byte strings", {}},
    {"nan_pose", "/poses/large/positions: entry [2][1] is not finite", {"nan"}},
    {"nan_pose_named_with_escapes", "/poses/lar\\x0age\\x1b[2J/positions: entry [2][1] is not finite", {}},
    {"inf_rest", "/rest/positions: entry [0][0] is not finite", {"inf"}},
    {"negative_radius", "/design/radii: entry [3][1]", {"positive", "-0.001"}},
    {"nan_residual_converged", "/poses/large attribute residual_norm: is not finite", {"nan"}},
    {"status_unknown", "/ attribute status", {"\"maybe\""}},
    {"n_vertices_mismatch", "/model attribute n_vertices: is 7", {"6 rows"}},
    {"n_edges_mismatch", "/model attribute n_edges: is 9", {"5 edges"}},
    {"scene_not_json", "bad.h5:/scene: not valid JSON (line", {}},
    {"scene_other_vertices", "/rest/positions: has 6 rows, but /scene has 7 vertices", {}},
    {"scene_deep", "bad.h5:/scene: line 1, column 65: arrays and objects nested deeper than 64", {}},
    {"history_mismatch", "/history/objective: has shape 2", {"expected 3"}},
    {"control_rod_out_of_range", "/design/control_points/rod: entry [1] names rod 5", {}},
    {"control_arc_fraction", "/design/control_points/arc_fraction: entry [1]", {"[0, 1]", "2"}},
    {"control_bound_counts", "/design/control_points attribute radii_at_max: is 2 with radii_at_min 3", {"4"}},
    {"control_bound_elasticity", "/design/control_points attribute elasticity_min: must be finite", {"nan"}},
    {"frames_time_short", "/frames/small/positions: has shape 6 x 6 x 3", {"expected 5 x 6 x 3"}},
    {"frames_two_columns", "/frames/small/positions: has shape 6 x 6 x 2", {}},
    {"frames_time_backwards", "/frames/small/time: entry [1] = -1", {}},
    {"frames_unknown_pose", "/frames/nope: names no pose", {}},
    {"heap_object_huge", "bad.h5: the global heap collection at byte", {"1099511627776 bytes", "does not fit"}},
    {"heap_free_space_zero", "bad.h5: the global heap collection at byte", {"free space of 0 bytes"}},
    {"truncated_half", "bad.h5: cannot open archive", {"truncated"}},
    {"truncated_header", "bad.h5: ", {}},
    {"empty", "bad.h5: not an HDF5 file", {}},
    {"superblock_zeroed", "bad.h5: ", {}},
};

// The verbs that read archives; each must reject every damaged archive.
const std::vector<std::string> kReaders = {
    "inspect bad.h5",
    "export bad.h5 -o out.stl",
    "export bad.h5 -o out.vtp",
    "export bad.h5 -o all.pvd --all-poses",
    "export bad.h5 --xdmf -o out.xmf",
};

class BadArchiveCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    char t[] = "/tmp/rodmesh_bad_archive_XXXXXX";
    ASSERT_NE(mkdtemp(t), nullptr);
    sources_ = t;
    writeText(sources_ + "/cantilever.json", readText(kSourceDir + "/tests/cli/cantilever.json"));
    const std::string cd = "cd " + shellQuote(sources_) + " && " + shellQuote(kExe);
    ASSERT_EQ(std::system((cd + " -q simulate cantilever.json -o c.h5 >/dev/null 2>&1").c_str()), 0);
    ASSERT_EQ(std::system((cd + " -q simulate cantilever.json -o d.h5 --dynamic --duration 0.05 --fps 100 "
                                ">/dev/null 2>&1")
                              .c_str()),
              0);
  }
  static void TearDownTestSuite() { std::system(("rm -rf " + shellQuote(sources_)).c_str()); }

  void SetUp() override {
    // scripts/install-deps.sh installs python3-h5py: its absence is a broken setup.
    ASSERT_EQ(std::system((kPython + " -c 'import h5py, numpy' >/dev/null 2>&1").c_str()), 0)
        << kPython << " cannot import h5py and numpy (run scripts/install-deps.sh)";
    char t[] = "/tmp/rodmesh_bad_archive_run_XXXXXX";
    ASSERT_NE(mkdtemp(t), nullptr);
    dir_ = t;
    log_ = dir_ + ".log";
    ASSERT_EQ(mkdir(log_.c_str(), 0755), 0);
  }
  void TearDown() override { std::system(("rm -rf " + shellQuote(dir_) + " " + shellQuote(log_)).c_str()); }

  // Exit status of a shell command run in the working directory (124 on timeout); stderr in err_.
  int shell(const std::string& cmd) {
    const std::string full =
        "cd " + shellQuote(dir_) + " && " + cmd + " >" + shellQuote(log_ + "/out") + " 2>" + shellQuote(log_ + "/err");
    const int raw = std::system(full.c_str());
    err_ = readText(log_ + "/err");
    if (raw == -1 || !WIFEXITED(raw)) return -1;
    const int status = WEXITSTATUS(raw);
    return status == 128 + 9 ? kTimedOut : status;
  }

  // Every reader rejects bad.h5: exit 2 within the time limit, one line
  // "rodmesh: error: " naming bad.h5 and containing every fragment, and no
  // file written.
  void expectRejected(const std::vector<std::string>& fragments) {
    const std::vector<std::string> before = clitest::listFiles(dir_);
    for (const std::string& args : kReaders) {
      SCOPED_TRACE(args);
      const int status = shell("timeout -k 5 " + std::to_string(kTimeoutSeconds) + " " + shellQuote(kExe) + " " + args);
      ASSERT_NE(status, kTimedOut) << "timed out after " << kTimeoutSeconds << " s";
      EXPECT_EQ(status, 2) << err_;
      EXPECT_EQ(err_.rfind("rodmesh: error: ", 0), 0u) << err_;
      EXPECT_EQ(std::count(err_.begin(), err_.end(), '\n'), 1) << "one line expected:\n" << err_;
      EXPECT_NE(err_.find("bad.h5"), std::string::npos) << err_;
      for (const std::string& f : fragments)
        EXPECT_NE(err_.find(f), std::string::npos) << "'" << f << "' not in " << err_;
      EXPECT_EQ(clitest::listFiles(dir_), before) << "something was written";
    }
  }

  static std::string sources_;
  std::string dir_, log_, err_;
};

std::string BadArchiveCli::sources_;

TEST_F(BadArchiveCli, TheUndamagedArchivesAreAccepted) {
  // The sources of the damaged copies pass every reader.
  for (const char* name : {"c.h5", "d.h5"}) {
    ASSERT_EQ(shell("cp " + shellQuote(sources_ + "/" + name) + " ok.h5"), 0);
    EXPECT_EQ(shell(shellQuote(kExe) + " inspect ok.h5"), 0) << err_;
    EXPECT_EQ(shell(shellQuote(kExe) + " -q export ok.h5 -o ok.vtp"), 0) << err_;
    EXPECT_EQ(shell(shellQuote(kExe) + " -q export ok.h5 -o all.pvd --all-poses"), 0) << err_;
    EXPECT_EQ(shell(shellQuote(kExe) + " -q export ok.h5 --xdmf -o ok.xmf"), 0) << err_;
  }
  // A failed pose may report a residual it could not compute (nan): still an archive.
  ASSERT_EQ(shell(kPython + " " + shellQuote(kSourceDir + "/tests/cli/corrupt_archive.py") +
                  " failed_pose_nan_residual " + shellQuote(sources_ + "/c.h5") + " failed.h5"),
            0)
      << err_;
  EXPECT_EQ(shell(shellQuote(kExe) + " inspect failed.h5"), 0) << err_;
  const std::string out = readText(log_ + "/out");
  EXPECT_NE(out.find("status    failed"), std::string::npos) << out;
  EXPECT_NE(out.find("residual nan N"), std::string::npos) << out;
}

TEST_F(BadArchiveCli, EveryKindOfDamageIsExit2NamingTheDatasetAndWritesNothing) {
  for (const Damage& d : kDamage) {
    SCOPED_TRACE(d.mode);
    const std::string source = sources_ + (d.mode.rfind("frames_", 0) == 0 ? "/d.h5" : "/c.h5");
    ASSERT_EQ(shell(kPython + " " + shellQuote(kSourceDir + "/tests/cli/corrupt_archive.py") + " " + d.mode + " " +
                    shellQuote(source) + " bad.h5"),
              0)
        << err_;
    std::vector<std::string> fragments = d.values;
    fragments.push_back(d.object);
    expectRejected(fragments);
    ASSERT_EQ(unlink((dir_ + "/bad.h5").c_str()), 0);
  }
}

TEST_F(BadArchiveCli, ArchivesFoundByFuzzingAreRejectedWithoutCrashOrHang) {
  // Some make the HDF5 library itself loop or crash: the reader's child
  // process contains that, and the message names what was being read.
  const std::vector<std::string> inputs = clitest::listFiles(kSourceDir + "/fuzz/regressions/archive");
  ASSERT_FALSE(inputs.empty());
  for (const std::string& name : inputs) {
    SCOPED_TRACE(name);
    ASSERT_EQ(shell("cp " + shellQuote(kSourceDir + "/fuzz/regressions/archive/" + name) + " bad.h5"), 0);
    expectRejected({});
    ASSERT_EQ(unlink((dir_ + "/bad.h5").c_str()), 0);
  }
}

}  // namespace
}  // namespace rodmesh
