// Issue 23: `optimize` (and `simulate` where the same keys apply) under bad
// and extreme input. Every unusable input is exit 2 before any work, with
// one message naming the file or flag, the key path and the value as typed,
// and nothing written; every long phase answers its limits.
//
// Scenes are tests/cli/optimize_small.json (a 58-vertex sheet with two
// posed targets) edited with nlohmann::json, so a value "as typed" is the
// text nlohmann writes into the file (9.2e18 is written 9.2e+18).
#include "tests/cli/cli_util.hh"

#include "io/archive.hh"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdlib>
#include <fcntl.h>
#include <functional>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

namespace rodmesh {
namespace {

const std::string kExe = RODMESH_EXE;
const std::string kSourceDir = RODMESH_SOURCE_DIR;

class RobustCli : public ::testing::Test {
 protected:
  void SetUp() override {
    char t[] = "/tmp/rodmesh_robust_test_XXXXXX";
    ASSERT_NE(mkdtemp(t), nullptr);
    dir_ = t;
    sceneText_ = clitest::readText(kSourceDir + "/tests/cli/optimize_small.json");
    clitest::writeText(path("scene.json"), sceneText_);
  }
  void TearDown() override { std::system(("rm -rf " + clitest::shellQuote(dir_)).c_str()); }
  std::string path(const std::string& n) const { return dir_ + "/" + n; }
  // Runs rodmesh with `args` (already shell-quoted where needed) in the test
  // directory under `timeout`; the exit status (124: timed out), stderr in err_.
  int run(const std::string& args, int timeoutSeconds = 120, const std::string& prefix = "") {
    const std::string cmd = "cd " + clitest::shellQuote(dir_) + " && " + prefix + "timeout -s KILL " +
                            std::to_string(timeoutSeconds) + " " + clitest::shellQuote(kExe) + " " + args +
                            " >/dev/null 2>" + clitest::shellQuote(dir_ + "/.err") + " </dev/null";
    const int raw = std::system(cmd.c_str());
    err_ = clitest::readText(dir_ + "/.err");
    std::remove((dir_ + "/.err").c_str());
    if (raw == -1 || !WIFEXITED(raw)) return -1;
    const int status = WEXITSTATUS(raw);
    return status == 137 ? 124 : status;  // timeout -s KILL
  }
  std::vector<std::string> files() const { return clitest::listFiles(dir_); }
  nlohmann::json scene() const { return nlohmann::json::parse(sceneText_); }

  // Exit 2, one message line naming every fragment, no CLI11 or std::
  // wording, nothing written (the directory as before, the scene unchanged).
  void expectRefused(const std::string& args, const std::vector<std::string>& fragments, int timeoutSeconds = 60) {
    SCOPED_TRACE(args);
    const std::vector<std::string> before = files();
    const int status = run(args, timeoutSeconds);
    ASSERT_NE(status, 124) << "timed out";
    EXPECT_EQ(status, 2) << err_;
    EXPECT_EQ(err_.rfind("rodmesh: error: ", 0), 0u) << err_;
    EXPECT_EQ(std::count(err_.begin(), err_.end(), '\n'), 1) << "one message line expected:\n" << err_;
    for (const std::string& f : fragments) EXPECT_NE(err_.find(f), std::string::npos) << "'" << f << "' not in " << err_;
    for (const char* word : {"Could not convert", "not expected", "std::", "bad_alloc", "-0.000000"})
      EXPECT_EQ(err_.find(word), std::string::npos) << word << " in " << err_;
    EXPECT_LT(err_.size(), 400u) << err_;
    EXPECT_EQ(files(), before) << "something was written";
    EXPECT_EQ(clitest::readText(path("scene.json")), sceneText_) << "the input scene was changed";
  }

  // Writes `scene` edited by `edit` to bad.json and expects optimize (and,
  // with `simulate`, simulate) to refuse it naming bad.json and `fragments`.
  void expectSceneRefused(const std::function<void(nlohmann::json&)>& edit, const std::vector<std::string>& fragments,
                          bool simulateToo) {
    nlohmann::json j = scene();
    edit(j);
    clitest::writeText(path("bad.json"), j.dump());
    std::vector<std::string> f = fragments;
    f.push_back("bad.json");
    expectRefused("optimize bad.json -o out.h5 --method reduced", f);
    if (simulateToo) expectRefused("simulate bad.json -o out.h5", f);
    std::remove(path("bad.json").c_str());
  }

  std::string dir_, err_, sceneText_;
};

// ---- Scenes: plausible ranges (model/limits.hh, docs/formats.md).

TEST_F(RobustCli, ControlPointsPerRodBeyond1000IsExit2) {
  for (long long n : {1001LL, 1030LL, 100000LL, 2147483647LL})
    expectSceneRefused([n](nlohmann::json& j) { j["design"]["control_points_per_rod"] = n; },
                       {"design.control_points_per_rod", std::to_string(n), "1000"}, false);
}

TEST_F(RobustCli, TargetCoordinateBeyondItsRangeIsExit2) {
  expectSceneRefused([](nlohmann::json& j) { j["poses"][1]["target"][3][2] = 1e154; },
                     {"poses[1].target[3][2]", "1e+154"}, false);
  expectSceneRefused([](nlohmann::json& j) { j["poses"][0]["target"][0][0] = -2e6; },
                     {"poses[0].target[0][0]", "-2000000"}, false);
}

TEST_F(RobustCli, ImplausibleMaterialIsExit2ForOptimizeAndSimulate) {
  expectSceneRefused([](nlohmann::json& j) { j["material"]["density"] = 9.2e18; },
                     {"material.density", "9.2e+18", "kg/m^3"}, true);
  expectSceneRefused([](nlohmann::json& j) { j["material"]["young_modulus"] = 1e20; },
                     {"material.young_modulus", "1e+20", "Pa"}, true);
  expectSceneRefused([](nlohmann::json& j) { j["material"]["young_modulus"] = 1e-300; },
                     {"material.young_modulus", "1e-300", "Pa"}, true);
  expectSceneRefused([](nlohmann::json& j) { j["material"]["density"] = 1e-300; },
                     {"material.density", "1e-300", "kg/m^3"}, true);
}

TEST_F(RobustCli, ImplausibleRadiiAndBoundsAreExit2) {
  expectSceneRefused(
      [](nlohmann::json& j) {
        j["design"]["radius_bounds"] = {1e100, 1e101};
        j["radius"] = {1e100, 1e100};
      },
      {"1e+100"}, false);
  expectSceneRefused([](nlohmann::json& j) { j["design"]["radius_bounds"] = {0.001, 1e101}; },
                     {"design.radius_bounds[1]", "1e+101"}, false);
  expectSceneRefused([](nlohmann::json& j) { j["radius"] = {0.002, 101.0}; }, {"radius[1]", "101"}, true);
  expectSceneRefused(
      [](nlohmann::json& j) {
        j["radius"] = {1e-300, 1e-300};
        j["design"].erase("radius_bounds");
      },
      {"radius[0]", "1e-300"}, true);
  expectSceneRefused([](nlohmann::json& j) { j["design"]["radius_bounds"] = {1e-9, 0.004}; },
                     {"design.radius_bounds[0]", "1e-09"}, false);
}

TEST_F(RobustCli, ImplausibleLoadsGravityPositionsAndWeightsAreExit2) {
  expectSceneRefused([](nlohmann::json& j) { j["poses"][1]["forces"][0]["force"][1] = 1e300; },
                     {"poses[1].forces[0].force[1]", "1e+300", "N"}, true);
  expectSceneRefused([](nlohmann::json& j) { j["gravity"] = {0.0, 0.0, -1e5}; }, {"gravity[2]", "-100000"}, true);
  expectSceneRefused([](nlohmann::json& j) { j["vertices"][12][1] = 5e6; }, {"vertices[12][1]", "5000000"}, true);
  expectSceneRefused([](nlohmann::json& j) { j["poses"][0]["weight"] = 1e300; }, {"poses[0].weight", "1e+300"},
                     true);
}

TEST_F(RobustCli, PoseNamesThatCannotNameAnArchiveGroupAreExit2) {
  for (const std::string& name : {std::string("a\0b", 3), std::string("a\nb"), std::string("a/b"), std::string(""),
                                  std::string(300, 'p')})
    expectSceneRefused([&](nlohmann::json& j) { j["poses"][0]["name"] = name; }, {"poses[0].name"}, true);
}

// ---- Output paths.

TEST_F(RobustCli, OutputPathsThatCannotBeWrittenAreExit2BeforeAnyWork) {
  ASSERT_EQ(mkdir(path("sub").c_str(), 0755), 0);
  const std::string longName(300, 'n');
  const std::string nearlyLongName(250, 'n');  // fits NAME_MAX, not with ".tmp.PID"
  for (const std::string verb : {"optimize", "simulate"}) {
    const std::string method = verb == std::string("optimize") ? " --method reduced" : "";
    expectRefused(std::string(verb) + " scene.json -o ." + method, {"-o", "directory"});
    expectRefused(std::string(verb) + " scene.json -o sub" + method, {"-o", "sub", "directory"});
    expectRefused(std::string(verb) + " scene.json -o sub/" + method, {"-o", "sub/", "directory"});
    expectRefused(std::string(verb) + " scene.json -o scene.json" + method, {"-o", "scene.json", "input"});
    expectRefused(std::string(verb) + " scene.json -o ./sub/../scene.json" + method, {"-o", "input"});
    expectRefused(std::string(verb) + " scene.json -o missing/out.h5" + method, {"-o", "missing"});
    expectRefused(std::string(verb) + " scene.json -o " + longName + ".h5" + method, {"-o", "bytes"});
    expectRefused(std::string(verb) + " scene.json -o " + nearlyLongName + ".h5" + method, {"-o", "bytes"});
    if (::access("/proc/self", F_OK) == 0)
      expectRefused(std::string(verb) + " scene.json -o /proc/x.h5" + method, {"-o", "/proc/x.h5"});
  }
}

// ---- Scene inputs.

TEST_F(RobustCli, SceneLargerThanTheLimitIsRefusedByItsSize) {
  // A sparse file of 257 MiB: refused by stat(), the message giving its size
  // in bytes, which only the size check knows before reading.
  const int fd = ::open(path("huge.json").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::ftruncate(fd, (257LL << 20)), 0);
  ::close(fd);
  const auto t0 = std::chrono::steady_clock::now();
  expectRefused("optimize huge.json -o out.h5 --method reduced", {"huge.json", "256 MiB", "269484032 bytes"});
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 20.0);
}

TEST_F(RobustCli, FifoSceneIsRefusedWithoutBlocking) {
  ASSERT_EQ(mkfifo(path("scene.fifo").c_str(), 0644), 0);
  expectRefused("optimize scene.fifo -o out.h5 --method reduced", {"scene.fifo", "FIFO"}, 20);
  expectRefused("simulate scene.fifo -o out.h5", {"scene.fifo", "FIFO"}, 20);
}

// ---- Flags: one message naming the flag, its range and the text as typed.

TEST_F(RobustCli, OptimizeFlagsNameFlagRangeAndTextAsTyped) {
  const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
      {"--max-iter 1e12", {"--max-iter", "'1e12'", "[0, 1000000]"}},
      {"--max-iter 0.5", {"--max-iter", "'0.5'"}},
      {"--max-iter ''", {"--max-iter", "''"}},
      {"--max-iter 99999999999999999999999", {"--max-iter", "'99999999999999999999999'"}},
      {"--time-limit ''", {"--time-limit", "''"}},
      {"--time-limit -1e-9", {"--time-limit", "'-1e-9'", "[0, 1e+09]"}},
      {"--time-limit nan", {"--time-limit", "'nan'"}},
      {"--time-limit -inf", {"--time-limit", "'-inf'"}},
      {"--tol 1e300", {"--tol", "'1e300'", "(0, 1)"}},
      {"--tol abc", {"--tol", "'abc'"}},
      {"--threads 1e3", {"--threads", "'1e3'", "[1, 256]"}},
  };
  for (const auto& [flags, fragments] : cases)
    expectRefused("optimize scene.json -o out.h5 --method reduced " + flags, fragments);
}

TEST_F(RobustCli, SimulateFlagsNameFlagRangeAndTextAsTyped) {
  const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
      {"--dynamic --duration 1 --max-step abc", {"--max-step", "'abc'"}},
      {"--dynamic --duration 1 --fps abc", {"--fps", "'abc'"}},
      {"--dynamic --duration ''", {"--duration", "''"}},
      {"--dynamic --duration 1 --ramp -1e-9", {"--ramp", "'-1e-9'"}},
      {"--time-limit -1e-9", {"--time-limit", "'-1e-9'"}},
      {"--time-limit ''", {"--time-limit", "''"}},
      {"--tol 1e300", {"--tol", "'1e300'"}},
      {"--max-iter 1e12", {"--max-iter", "'1e12'"}},
      {"--max-iter ''", {"--max-iter", "''"}},
  };
  for (const auto& [flags, fragments] : cases) expectRefused("simulate scene.json -o out.h5 " + flags, fragments);
}

// ---- Memory.

TEST_F(RobustCli, DesignTooLargeForMemoryIsExit2BeforeAllocating) {
#if defined(__SANITIZE_ADDRESS__)
  // AddressSanitizer reserves terabytes of shadow address space at start-up:
  // an instrumented rodmesh cannot start under `ulimit -v` at all. The
  // Release suite runs this case.
  GTEST_SKIP() << "an AddressSanitizer build cannot run under an address-space limit";
#endif
  // 200 control points per rod (2,983 in all) with radii and rest shape
  // free: 14,915 design values, under the dense limit of 20,000, a dense BFGS
  // matrix of 1.8 GB, under an address-space limit of 2 GiB.
  nlohmann::json j = scene();
  j["design"]["parameters"] = {"radii", "rest_shape"};
  j["design"]["control_points_per_rod"] = 200;
  clitest::writeText(path("big.json"), j.dump());
  const std::vector<std::string> before = files();
  const int status = run("optimize big.json -o out.h5 --method reduced", 60, "ulimit -v 2097152 && ");
  ASSERT_NE(status, 124) << "timed out";
  EXPECT_EQ(status, 2) << err_;
  EXPECT_NE(err_.find("design.control_points_per_rod"), std::string::npos) << err_;
  EXPECT_NE(err_.find("GiB"), std::string::npos) << err_;
  EXPECT_EQ(err_.find("std::"), std::string::npos) << err_;
  EXPECT_EQ(files(), before);
}

// ---- Bounds to the last digit.

TEST_F(RobustCli, ReducedMethodKeepsEveryArchivedRadiusWithinItsBounds) {
  // The scene's radii (2 mm) on the lower bound: the optimizer thins rods
  // onto it, where interpolated radii used to fall one rounding below it.
  nlohmann::json j = scene();
  j["design"]["radius_bounds"] = {0.002, 0.004};
  j["design"]["control_points_per_rod"] = 5;
  clitest::writeText(path("onbound.json"), j.dump());
  const int status = run("-q optimize onbound.json -o out.h5 --method reduced --max-iter 30");
  ASSERT_TRUE(status == 0 || status == 1) << err_;
  const Archive a = readArchive(path("out.h5"));
  for (Eigen::Index v = 0; v < a.radii.rows(); ++v)
    for (int k = 0; k < 2; ++k) {
      EXPECT_GE(a.radii(v, k), 0.002) << "vertex " << v;
      EXPECT_LE(a.radii(v, k), 0.004) << "vertex " << v;
    }
}

// ---- Limits.

// The run stopped by its own time limit within `slack` seconds of it (the
// optimizer's time in the archive), not by the watchdog 3 s later.
void expectTimeLimitAnswered(const Archive& a, double limit, double slack) {
  EXPECT_EQ(a.status, "not_converged");
  ASSERT_TRUE(a.optimize.has_value());
  EXPECT_EQ(a.optimize->message.find("did not stop"), std::string::npos) << a.optimize->message;
  EXPECT_NE(a.optimize->message.find("time limit"), std::string::npos) << a.optimize->message;
  EXPECT_LT(a.optimize->timeSeconds, limit + slack) << a.optimize->message;
}

TEST_F(RobustCli, FdResolveAnswersTheTimeLimitBetweenReSolves) {
  // Every control point free at once (--schedule joint, 290 design values):
  // one fd-resolve gradient is 580 probes of both poses, seconds of work.
  nlohmann::json j = scene();
  j["design"]["parameters"] = {"radii", "rest_shape"};
  j["design"]["control_points_per_rod"] = 5;
  clitest::writeText(path("fd.json"), j.dump());
  const int status = run(
      "-q optimize fd.json -o out.h5 --method reduced --design-derivatives fd-resolve --schedule joint --max-iter 12 "
      "--time-limit 1");
  ASSERT_NE(status, 124) << "timed out";
  EXPECT_EQ(status, 1) << err_;
  expectTimeLimitAnswered(readArchive(path("out.h5")), 1.0, 0.5);
}

}  // namespace
}  // namespace rodmesh

#ifdef RODMESH_HAVE_NLP
namespace rodmesh {
namespace {

TEST_F(RobustCli, LinearSolversOtherThanMumpsAreExit2NamingOptionAndValue) {
  for (const std::string solver : {"ma27", "ma57", "ma77", "ma86", "ma97", "pardiso", "wsmp"})
    expectRefused("optimize scene.json -o out.h5 --ipopt linear_solver=" + solver, {"linear_solver", solver});
  expectRefused("optimize scene.json -o out.h5 --ipopt linear_system_scaling=mc19", {"linear_system_scaling", "mc19"});
}

TEST_F(RobustCli, BrokenIpoptOptFileIsExit2NamingLineKeyAndValue) {
  clitest::writeText(path("ipopt.opt"), "# options\nmax_iter\n");
  expectRefused("optimize scene.json -o out.h5", {"ipopt.opt", "line 2", "max_iter"});
  clitest::writeText(path("ipopt.opt"), "tol 1e-8\nlinear_solver ma27\n");
  expectRefused("optimize scene.json -o out.h5", {"ipopt.opt", "line 2", "linear_solver", "ma27"});
  clitest::writeText(path("ipopt.opt"), "max_iter many\n");
  expectRefused("optimize scene.json -o out.h5", {"ipopt.opt", "line 1", "max_iter", "many"});
  clitest::writeText(path("ipopt.opt"), "no_such_option 3\n");
  expectRefused("optimize scene.json -o out.h5", {"ipopt.opt", "no_such_option"});
}

TEST_F(RobustCli, IpoptDerivativeCheckerAnswersTheTimeLimit) {
  // The checker calls no intermediate callback: the evaluations themselves
  // stop once the limit passed (the watchdog, 3 s later, is the last resort).
  const int status = run("-q optimize scene.json -o out.h5 --ipopt derivative_test=second-order --time-limit 1");
  ASSERT_NE(status, 124) << "timed out";
  EXPECT_EQ(status, 1) << err_;
  expectTimeLimitAnswered(readArchive(path("out.h5")), 1.0, 1.0);
}

}  // namespace
}  // namespace rodmesh
#endif
