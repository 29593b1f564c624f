// End-to-end tests of `rodmesh simulate --dynamic` (frames in the archive)
// and `rodmesh simulate --static-solver relaxation`, through the real binary
// in a fresh temporary directory (helpers as in cli_test.cc).
#include <dirent.h>
#include "tests/cli/cli_util.hh"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "io/archive.hh"

namespace rodmesh {
namespace {

const std::string kExe = RODMESH_EXE;
const std::string kSourceDir = RODMESH_SOURCE_DIR;

using clitest::readText;

using clitest::writeText;

using clitest::shellQuote;

int lineCount(const std::string& text) {
  int n = 0;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) n += !line.empty();
  return n;
}

struct RunOutcome {
  int status = -1;
  std::string out, err;
};

class DynamicsCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char t[] = "/tmp/rodmesh_dyn_cli_XXXXXX";
    ASSERT_NE(mkdtemp(t), nullptr);
    dir_ = t;
    logDir_ = dir_ + ".log";
    ASSERT_EQ(mkdir(logDir_.c_str(), 0755), 0);
  }
  void TearDown() override { std::system(("rm -rf " + shellQuote(dir_) + " " + shellQuote(logDir_)).c_str()); }

  std::string path(const std::string& name) const { return dir_ + "/" + name; }

  void copySource(const std::string& name) {
    const std::string text = readText(kSourceDir + "/tests/cli/" + name);
    ASSERT_FALSE(text.empty()) << "cannot read tests/cli/" << name;
    writeText(path(name), text);
  }

  RunOutcome run(const std::string& args) {
    const std::string cmd = "cd " + shellQuote(dir_) + " && " + shellQuote(kExe) + " " + args + " >" +
                            shellQuote(logDir_ + "/out") + " 2>" + shellQuote(logDir_ + "/err");
    const int raw = std::system(cmd.c_str());
    RunOutcome r;
    r.status = (raw != -1 && WIFEXITED(raw)) ? WEXITSTATUS(raw) : -1;
    r.out = readText(logDir_ + "/out");
    r.err = readText(logDir_ + "/err");
    return r;
  }

  std::vector<std::string> files() const { return clitest::listFiles(dir_); }

  std::string dir_, logDir_;
};

const ArchiveFrames* framesOf(const Archive& a, const std::string& name) {
  for (const ArchiveFrames& f : a.frames)
    if (f.name == name) return &f;
  return nullptr;
}

const ArchivePose* poseOf(const Archive& a, const std::string& name) {
  for (const ArchivePose& p : a.poses)
    if (p.name == name) return &p;
  return nullptr;
}

TEST_F(DynamicsCliTest, DynamicRunStoresTimeMajorFramesPerPose) {
  copySource("cantilever.json");
  const RunOutcome r = run("simulate cantilever.json -o out.h5 --dynamic --duration 0.1 --fps 50");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(r.out.empty());
  EXPECT_FALSE(r.err.empty()) << "progress goes to stderr";
  EXPECT_EQ(files(), (std::vector<std::string>{"cantilever.json", "out.h5"}));

  const Archive a = readArchive(path("out.h5"));
  EXPECT_EQ(a.command, "simulate");
  EXPECT_EQ(a.status, "converged");
  ASSERT_EQ(a.frames.size(), 2u) << "one frame group per pose";
  ASSERT_EQ(a.poses.size(), 2u);
  for (const std::string name : {"small", "large"}) {
    SCOPED_TRACE(name);
    const ArchiveFrames* f = framesOf(a, name);
    const ArchivePose* p = poseOf(a, name);
    ASSERT_NE(f, nullptr);
    ASSERT_NE(p, nullptr);
    ASSERT_EQ(f->time.size(), 6) << "t = 0, 0.02, ..., 0.1";
    ASSERT_EQ(f->positions.size(), 6u);
    for (int k = 0; k < 6; ++k) {
      EXPECT_NEAR(f->time[k], 0.02 * k, 1e-12);
      ASSERT_EQ(f->positions[k].rows(), 6);
      EXPECT_TRUE(f->positions[k].allFinite());
      EXPECT_EQ(f->positions[k].row(0).norm(), 0.0) << "the clamped vertex stays put";
      EXPECT_NEAR(f->positions[k].col(2).norm(), 0.0, 1e-12) << "in-plane load, in-plane motion";
    }
    EXPECT_EQ(f->positions.front(), a.restPositions) << "frame 0 is the rest state";
    EXPECT_EQ(f->positions.back(), p->positions) << "the last frame is the pose's result";
    EXPECT_LT(f->positions.back()(5, 1), 0.0) << "the tip moves along the load";
    EXPECT_EQ(p->status, "converged");
    EXPECT_GT(p->iterations, 0);
  }
  // Under the larger load the tip has moved further.
  EXPECT_LT(framesOf(a, "large")->positions[1](5, 1), framesOf(a, "small")->positions[1](5, 1));
}

TEST_F(DynamicsCliTest, LastFrameIsAtTheDuration) {
  copySource("cantilever.json");
  ASSERT_EQ(run("simulate cantilever.json -o out.h5 -q --dynamic --duration 0.06 --fps 40").status, 0);
  const Archive a = readArchive(path("out.h5"));
  const ArchiveFrames* f = framesOf(a, "small");
  ASSERT_NE(f, nullptr);
  ASSERT_EQ(f->time.size(), 4) << "0, 0.025, 0.05 and the end, 0.06";
  EXPECT_NEAR(f->time[2], 0.05, 1e-12);
  EXPECT_DOUBLE_EQ(f->time[3], 0.06);
}

TEST_F(DynamicsCliTest, QuietDynamicRunPrintsNothing) {
  copySource("bent_3d.json");
  const RunOutcome r = run("simulate bent_3d.json -o out.h5 --dynamic --duration 0.02 --fps 100 --quiet");
  EXPECT_EQ(r.status, 0);
  EXPECT_EQ(r.err, "");
  EXPECT_EQ(r.out, "");
  const Archive a = readArchive(path("out.h5"));
  ASSERT_EQ(a.poses.size(), 1u);
  EXPECT_EQ(a.poses[0].twist.size(), a.nEdges) << "3D scene: twist of the last frame";
  ASSERT_EQ(a.frames.size(), 1u);
  EXPECT_EQ(a.frames[0].time.size(), 3);
}

TEST_F(DynamicsCliTest, DynamicStopAtTimeLimitExitsOneAndKeepsTheFramesReached) {
  // One Newton iteration per step against a 1e-12 tolerance: the large load
  // is integrated in small steps (0.1 s of motion take a few tenths of a
  // second of wall clock on a 2-core EPYC); 10 s of motion would take
  // about a minute, and --time-limit stops it long before the end.
  copySource("cantilever.json");
  const RunOutcome r = run(
      "simulate cantilever.json -o out.h5 --dynamic --duration 10 --fps 50 --max-iter 1 --tol 1e-12 --time-limit 0.3");
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE((r.out + r.err).find("the time limit of 0.3 s (wall clock) is reached"), std::string::npos)
      << r.out << r.err;
  EXPECT_EQ(files(), (std::vector<std::string>{"cantilever.json", "out.h5"}));
  const Archive a = readArchive(path("out.h5"));
  EXPECT_EQ(a.status, "not_converged");
  const ArchivePose* p = poseOf(a, "large");
  ASSERT_NE(p, nullptr);
  EXPECT_EQ(p->status, "not_converged");
  EXPECT_TRUE(p->positions.allFinite());
  const ArchiveFrames* f = framesOf(a, "large");
  ASSERT_NE(f, nullptr);
  ASSERT_GE(f->positions.size(), 2u) << "t = 0 and the state reached";
  EXPECT_GT(f->time[f->time.size() - 1], 0.0) << "the run moved";
  EXPECT_LT(f->time[f->time.size() - 1], 10.0) << "the run stopped early";
  EXPECT_EQ(f->positions.back(), p->positions);
}

TEST_F(DynamicsCliTest, DynamicFailureExitsOneAndKeepsTheStateReached) {
  // A tip force of 1e9 N, the largest a scene may hold (docs/formats.md,
  // "Plausible ranges"; 1e300 N is refused before any work, issue 23), and
  // one Newton iteration per step to a tolerance no single iteration meets:
  // every step is rejected until it falls below its minimum at t = 0.
  writeText(path("absurd.json"), R"({
    "format": "rodmesh-scene/1",
    "material": {"young_modulus": 1e7, "poisson_ratio": 0.4, "density": 1000},
    "vertices": [[0, 0, 0], [0.02, 0, 0], [0.04, 0, 0], [0.06, 0, 0], [0.08, 0, 0]],
    "rods": [{"vertices": [0, 1, 2, 3, 4]}],
    "radius": [0.002, 0.001],
    "poses": [{"name": "large", "clamped": [{"vertex": 0}], "forces": [{"vertex": 4, "force": [0, -1e9, 0]}]}]
  })");
  const RunOutcome r = run("simulate absurd.json -o out.h5 --dynamic --duration 0.1 --fps 50 --max-iter 1 --tol 1e-16");
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(files(), (std::vector<std::string>{"absurd.json", "out.h5"}));
  const Archive a = readArchive(path("out.h5"));
  EXPECT_EQ(a.status, "failed");
  const ArchivePose* p = poseOf(a, "large");
  ASSERT_NE(p, nullptr);
  EXPECT_EQ(p->status, "failed");
  EXPECT_TRUE(p->positions.allFinite());
  EXPECT_TRUE(std::isfinite(p->residualNorm));
  const ArchiveFrames* f = framesOf(a, "large");
  ASSERT_NE(f, nullptr);
  ASSERT_GE(f->positions.size(), 1u);
  EXPECT_LT(f->time[f->time.size() - 1], 10.0) << "the run stopped early";
  EXPECT_EQ(f->positions.back(), p->positions);
}

TEST_F(DynamicsCliTest, DisplacedHeldVerticesAreRampedIn) {
  // A rod clamped at vertex 0 whose other end is held 5 mm above its rest
  // position: it cannot jump there, so by default it moves there linearly
  // over a tenth of the duration (--ramp overrides).
  writeText(path("pull.json"), R"({
    "format": "rodmesh-scene/1",
    "material": {"young_modulus": 1e7, "poisson_ratio": 0.4, "density": 1000},
    "vertices": [[0, 0, 0], [0.02, 0, 0], [0.04, 0, 0], [0.06, 0, 0], [0.08, 0, 0]],
    "rods": [{"vertices": [0, 1, 2, 3, 4]}],
    "radius": [0.002, 0.001],
    "poses": [{"name": "lift", "clamped": [{"vertex": 0}], "fixed": [{"vertex": 4, "position": [0.08, 0, 0.005]}]}]
  })");
  for (const std::string ramp : {"", "0.05"}) {
    SCOPED_TRACE("ramp '" + ramp + "'");
    const RunOutcome r = run("simulate pull.json -o out.h5 -q --dynamic --duration 0.1 --fps 100" +
                             (ramp.empty() ? std::string() : " --ramp " + ramp));
    ASSERT_EQ(r.status, 0) << r.err;
    const Archive a = readArchive(path("out.h5"));
    ASSERT_EQ(a.frames.size(), 1u);
    const ArchiveFrames& f = a.frames[0];
    ASSERT_EQ(f.time.size(), 11);
    const double T = ramp.empty() ? 0.01 : 0.05;
    for (int k = 0; k < 11; ++k) {
      const double lam = std::min(1.0, f.time[k] / T);
      EXPECT_NEAR(f.positions[k](4, 2), 0.005 * lam, 1e-15) << "frame " << k;
      EXPECT_NEAR(f.positions[k](4, 0), 0.08, 1e-15);
    }
    EXPECT_GT(f.positions.back()(2, 2), 0.0) << "the rod follows its lifted end";
  }
  const RunOutcome bad = run("simulate pull.json -o bad.h5 --dynamic --duration 0.1 --ramp -1");
  EXPECT_EQ(bad.status, 2);
  EXPECT_EQ(lineCount(bad.err), 1) << bad.err;
}

TEST_F(DynamicsCliTest, RelaxationReachesTheNewtonEquilibrium) {
  copySource("bent_3d.json");
  copySource("cantilever.json");
  for (const std::string scene : {"cantilever.json", "bent_3d.json"}) {
    SCOPED_TRACE(scene);
    const RunOutcome rn = run("simulate " + scene + " -o newton.h5 -q");
    const RunOutcome rr = run("simulate " + scene + " -o relax.h5 --static-solver relaxation");
    ASSERT_EQ(rn.status, 0) << rn.err;
    ASSERT_EQ(rr.status, 0) << rr.err;
    const Archive n = readArchive(path("newton.h5"));
    const Archive x = readArchive(path("relax.h5"));
    EXPECT_EQ(x.status, "converged");
    ASSERT_EQ(n.poses.size(), x.poses.size());
    for (std::size_t p = 0; p < n.poses.size(); ++p) {
      SCOPED_TRACE(n.poses[p].name);
      const double moved = (n.poses[p].positions - n.restPositions).rowwise().norm().maxCoeff();
      const double diff = (n.poses[p].positions - x.poses[p].positions).rowwise().norm().maxCoeff();
      // Both stop at a relative force residual of 1e-9 (or at round-off);
      // on these rods that is a position error far below 1e-5 of the motion.
      EXPECT_LT(diff, 1e-5 * moved) << "Newton and relaxation disagree by " << diff << " m";
      EXPECT_EQ(x.poses[p].status, "converged");
      EXPECT_GT(x.poses[p].iterations, n.poses[p].iterations) << "relaxation needs many more (cheaper) iterations";
    }
  }
}

TEST_F(DynamicsCliTest, BadDynamicUsageExitsTwoAndWritesNothing) {
  copySource("cantilever.json");
  const std::vector<std::string> before = {"cantilever.json"};
  // Rejected after parsing, with one error line naming the problem.
  for (const std::string args : {
           "--duration 1",                                   // --duration without --dynamic
           "--fps 30",                                       // --fps without --dynamic
           "--dynamic",                                      // no duration
           "--dynamic --duration 0",                         // non-positive duration
           "--dynamic --duration -1",                        //
           "--dynamic --duration 1 --fps 0",                 // non-positive fps
           "--dynamic --duration 1 --fps -5",                //
           "--dynamic --duration 1 --max-step 0",            // non-positive step
           "--ramp 0.1",                                     // --ramp without --dynamic
           "--dynamic --duration 1 --static-solver newton",  // static solver with dynamics
           "--static-solver relaxation --tol 0",             // invalid tolerance
       }) {
    SCOPED_TRACE(args);
    const RunOutcome r = run("simulate cantilever.json -o out.h5 " + args);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_EQ(lineCount(r.err), 1) << r.err;
    EXPECT_TRUE(r.out.empty());
    EXPECT_EQ(files(), before);
  }
  // Parse errors (CLI11): status 2, nothing written.
  for (const std::string args : {"--static-solver dynamic", "--dynamic --duration soon"}) {
    SCOPED_TRACE(args);
    const RunOutcome r = run("simulate cantilever.json -o out.h5 " + args);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_FALSE(r.err.empty());
    EXPECT_EQ(files(), before);
  }
}

// The frames as a third-party reader sees them (h5py): time-major T x V x 3.
TEST_F(DynamicsCliTest, FramesLayoutSeenByH5py) {
  ASSERT_EQ(std::system("/usr/bin/python3 -c 'import h5py, numpy' >/dev/null 2>&1"), 0)
      << "/usr/bin/python3 cannot import h5py and numpy (run scripts/install-deps.sh)";
  copySource("cantilever.json");
  ASSERT_EQ(run("simulate cantilever.json -o out.h5 -q --dynamic --duration 0.1 --fps 30").status, 0);
  const std::string script = R"PY(
import sys, h5py, numpy as np
errors = []
with h5py.File(sys.argv[1], "r") as f:
    V = int(f["model"].attrs["n_vertices"])
    if f.attrs.get("solver") != "backward_euler": errors.append("solver attribute %r" % f.attrs.get("solver"))
    for name in f["poses"]:
        g = f["frames"][name]
        pos, t = g["positions"], g["time"]
        if pos.dtype != np.float64 or t.dtype != np.float64: errors.append(name + ": not float64")
        if pos.shape != (t.shape[0], V, 3): errors.append(name + ": positions shape %s, time %s" % (pos.shape, t.shape))
        if t.shape != (4,): errors.append(name + ": expected 4 frames (0, 1/30, 2/30, 0.1), got %s" % (t.shape,))
        if not np.all(np.diff(t[()]) > 0): errors.append(name + ": times not increasing")
        if not np.array_equal(pos[-1], f["poses"][name]["positions"][()]): errors.append(name + ": last frame differs from the pose")
        if not np.array_equal(pos[0], f["rest"]["positions"][()]): errors.append(name + ": first frame is not the rest state")
for e in errors: print(e)
sys.exit(1 if errors else 0)
)PY";
  writeText(logDir_ + "/check.py", script);
  const int raw = std::system(("/usr/bin/python3 " + shellQuote(logDir_ + "/check.py") + " " +
                               shellQuote(path("out.h5")) + " >" + shellQuote(logDir_ + "/py") + " 2>&1")
                                  .c_str());
  EXPECT_EQ(raw, 0) << readText(logDir_ + "/py");
}

}  // namespace
}  // namespace rodmesh
