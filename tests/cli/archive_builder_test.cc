// The archive builders of apps/cli_common.hh (setRestAndRadii,
// makeArchivePose, setOptimizeResult, overallRmsError), checked against what
// `rodmesh simulate` writes; and the optimize parts of an archive as the
// other tools see them: `rodmesh inspect` and h5py.
#include "apps/cli_common.hh"
#include "io/archive.hh"
#include "io/scene_reader.hh"

#include "tests/cli/cli_util.hh"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <string>
#include <sys/wait.h>
#include <vector>

namespace rodmesh {
namespace {

const std::string kExe = RODMESH_EXE;
const std::string kSourceDir = RODMESH_SOURCE_DIR;

std::vector<Vec3> rows3(const MatX3& m) {
  std::vector<Vec3> v;
  for (Eigen::Index i = 0; i < m.rows(); ++i) v.push_back(m.row(i).transpose());
  return v;
}
std::vector<Vec2> rows2(const MatX2& m) {
  std::vector<Vec2> v;
  for (Eigen::Index i = 0; i < m.rows(); ++i) v.push_back(m.row(i).transpose());
  return v;
}

class ArchiveBuilderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char t[] = "/tmp/rodmesh_builder_test_XXXXXX";
    ASSERT_NE(mkdtemp(t), nullptr);
    dir_ = t;
  }
  void TearDown() override { std::system(("rm -rf " + clitest::shellQuote(dir_)).c_str()); }

  std::string path(const std::string& name) const { return dir_ + "/" + name; }

  void copySource(const std::string& name) const {
    const std::string text = clitest::readText(kSourceDir + "/tests/cli/" + name);
    ASSERT_FALSE(text.empty());
    clitest::writeText(path(name), text);
  }

  // Runs `rodmesh ARGS` in the working directory; returns the exit status, stdout in `out`.
  int run(const std::string& args, std::string* out = nullptr) const {
    const std::string cmd = "cd " + clitest::shellQuote(dir_) + " && " + clitest::shellQuote(kExe) + " " + args + " >" +
                            clitest::shellQuote(dir_ + ".out") + " 2>/dev/null";
    const int raw = std::system(cmd.c_str());
    if (out) *out = clitest::readText(dir_ + ".out");
    std::remove((dir_ + ".out").c_str());
    return (raw != -1 && WIFEXITED(raw)) ? WEXITSTATUS(raw) : -1;
  }

  // Simulates `scene` and returns the archive.
  Archive simulate(const std::string& scene) const {
    EXPECT_EQ(run("simulate " + scene + " -o sim.h5 -q"), 0);
    return readArchive(path("sim.h5"));
  }

  // The archive `sim` rebuilt with the builders from its own data and the scene's targets.
  static Archive rebuild(const Archive& sim, const Scene& scene) {
    Archive b;
    b.version = sim.version;
    b.command = sim.command;
    b.status = sim.status;
    b.sceneJson = sim.sceneJson;
    cli::setRestAndRadii(b, rows3(sim.restPositions), rows2(sim.radii));
    for (std::size_t p = 0; p < sim.poses.size(); ++p) {
      const ArchivePose& s = sim.poses[p];
      cli::PoseSolveSummary solve;
      if (!s.status.empty()) {
        // An outcome that archiveStatus maps to the archived status.
        SolveSummary sum;
        sum.outcome = s.status == "converged"       ? Outcome::Converged
                      : s.status == "not_converged" ? Outcome::MaxIterations
                                                    : Outcome::NumericalFailure;
        sum.residualNorm = s.residualNorm;
        sum.iterations = s.iterations;
        sum.timeSeconds = s.timeSeconds;
        solve.solve = sum;
      }
      solve.outOfPlaneStable = s.outOfPlaneStable;
      b.poses.push_back(cli::makeArchivePose(s.name, rows3(s.positions), s.twist.size() ? &s.twist : nullptr,
                                             scene.poses[p].target, solve));
    }
    return b;
  }

  std::string dir_;
};

TEST_F(ArchiveBuilderTest, RebuildsWhatSimulateWrites) {
  for (const std::string scene : {"cantilever.json", "bent_3d.json"}) {
    SCOPED_TRACE(scene);
    copySource(scene);
    const Archive sim = simulate(scene);
    const Archive b = rebuild(sim, readSceneFile(path(scene)));
    EXPECT_EQ(b.restPositions, sim.restPositions);
    EXPECT_EQ(b.radii, sim.radii);
    ASSERT_EQ(b.poses.size(), sim.poses.size());
    for (std::size_t p = 0; p < b.poses.size(); ++p) {
      const ArchivePose &x = sim.poses[p], &y = b.poses[p];
      SCOPED_TRACE(x.name);
      EXPECT_EQ(y.name, x.name);
      EXPECT_EQ(y.positions, x.positions);
      ASSERT_EQ(y.twist.size(), x.twist.size());
      EXPECT_EQ(y.twist, x.twist);
      ASSERT_EQ(y.target.rows(), x.target.rows());
      EXPECT_EQ(y.target, x.target);
      EXPECT_EQ(y.rmsError, x.rmsError) << "same RMS definition as simulate";
      EXPECT_EQ(y.status, x.status);
      EXPECT_EQ(y.residualNorm, x.residualNorm);
      EXPECT_EQ(y.iterations, x.iterations);
      EXPECT_EQ(y.outOfPlaneStable, x.outOfPlaneStable);
      EXPECT_EQ(y.initialPositions.rows(), 0) << "no optimize parts";
      EXPECT_FALSE(y.equilibriumGap.has_value());
    }
    EXPECT_TRUE(sim.poses.size() < 2 || sim.poses[0].rmsError.has_value()) << "cantilever's first pose has a target";
  }
}

TEST_F(ArchiveBuilderTest, RejectsATargetOfTheWrongSize) {
  const std::vector<Vec3> x(3, Vec3::Zero()), target(2, Vec3::Zero());
  EXPECT_THROW(cli::makeArchivePose("p", x, nullptr, target), std::invalid_argument);
  ArchivePose p = cli::makeArchivePose("p", x, nullptr, {});
  EXPECT_THROW(cli::setOptimizeResult(p, target, x), std::invalid_argument);
}

TEST_F(ArchiveBuilderTest, EquilibriumGapAndOverallRms) {
  const std::vector<Vec3> x = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0)};
  std::vector<Vec3> optimizer = x, target = x;
  optimizer[1].y() += 3e-6;
  optimizer[2].z() -= 1e-6;
  target[2].y() += 0.3;
  Archive a;
  a.poses.push_back(cli::makeArchivePose("a", x, nullptr, target));
  cli::setOptimizeResult(a.poses[0], target, optimizer);
  EXPECT_DOUBLE_EQ(*a.poses[0].equilibriumGap, 3e-6);
  EXPECT_EQ(a.poses[0].initialPositions.row(2), target[2].transpose());
  EXPECT_DOUBLE_EQ(*a.poses[0].rmsError, std::sqrt(0.09 / 3));
  a.poses.push_back(cli::makeArchivePose("b", x, nullptr, x));  // exact: RMS 0
  EXPECT_DOUBLE_EQ(*cli::overallRmsError(a), std::sqrt(0.09 / 6)) << "sum over poses and vertices / (poses * vertices)";
  a.poses.push_back(cli::makeArchivePose("c", x, nullptr, {}));
  EXPECT_FALSE(cli::overallRmsError(a).has_value()) << "a pose without target";
}

// An optimize archive built like `rodmesh optimize` will build it: the
// cantilever's simulate result as "final design", with initial radii, control
// points, history and the optimize root attributes.
Archive optimizeArchive(const Archive& sim, const Scene& scene) {
  Archive a;
  a.version = sim.version;
  a.command = "optimize";
  a.status = "not_converged";
  a.sceneJson = sim.sceneJson;
  a.effects = sim.effects;
  a.nVertices = sim.nVertices;
  a.nEdges = sim.nEdges;
  a.nRods = sim.nRods;
  cli::setRestAndRadii(a, rows3(sim.restPositions), rows2(sim.radii));
  a.initialRadii = sim.radii * 1.5;
  for (std::size_t p = 0; p < sim.poses.size(); ++p) {
    const std::vector<Vec3> x = rows3(sim.poses[p].positions);
    // Every pose of an optimize scene has a target; the cantilever's second has none, use the rest shape.
    const std::vector<Vec3> target = scene.poses[p].target.empty() ? scene.vertices : scene.poses[p].target;
    ArchivePose pose = cli::makeArchivePose(sim.poses[p].name, x, nullptr, target);
    std::vector<Vec3> optimizer = x;
    optimizer.back().y() += 2e-9;
    cli::setOptimizeResult(pose, scene.vertices, optimizer);
    a.poses.push_back(std::move(pose));
  }
  ArchiveControlPoints c;
  c.radii = MatX2::Constant(4, 2, 1e-3);
  c.restDisplacement = MatX3::Zero(4, 3);
  c.rod = {-1, 0, 0, -1};
  c.arcFraction = {0.0, 1.0 / 3.0, 2.0 / 3.0, 0.0};
  c.vertex = {0, -1, -1, 5};
  a.controlPoints = c;
  ArchiveHistory h;
  h.iteration = {0, 1, 2};
  h.timeSeconds = {0.0, 0.5, 1.25};
  h.objective = {10.0, 5.0, 4.5};
  h.rmsError = {1e-3, 5e-4, 4e-4};
  h.level = {0, 1, 2};
  h.constraintViolation = {0.0, 0.0, 0.0};
  h.gradientNorm = {3.0, 0.5, 1e-4};
  h.phase = {"radii", "radii", "rest_shape"};
  a.history = h;
  a.optimize = ArchiveOptimizeSummary{"reduced", 42, 12.5, "stopped at --max-iter 42"};
  return a;
}

bool contains(const std::string& s, const std::string& sub) { return s.find(sub) != std::string::npos; }

TEST_F(ArchiveBuilderTest, InspectShowsTheOptimizeParts) {
  copySource("cantilever.json");
  const Archive sim = simulate("cantilever.json");
  writeArchive(optimizeArchive(sim, readSceneFile(path("cantilever.json"))), path("opt.h5"));
  std::string out;
  ASSERT_EQ(run("inspect opt.h5", &out), 0);
  SCOPED_TRACE(out);
  EXPECT_TRUE(contains(out, "method reduced, 42 iterations in 12.50 s"));
  EXPECT_TRUE(contains(out, "stopped at --max-iter 42"));
  EXPECT_TRUE(contains(out, "equilibrium gap 2.000e-06 mm"));
  EXPECT_TRUE(contains(out, "history   3 iterations, objective 1.0000e+01 -> 4.5000e+00"));
  EXPECT_TRUE(contains(out, "control   4 points (2 shared ends, 2 interior)"));
  EXPECT_TRUE(contains(out, "over all poses"));

  // Radii held at one bound only: only that bound's gain is named, with
  // its sign as the optimizer's message gives it (no "-0%", no "--").
  Archive held = optimizeArchive(sim, readSceneFile(path("cantilever.json")));
  held.controlPoints->radiusBounds = ArchiveControlPoints::RadiusBounds{1e-3, 5e-3, 3, 0, 0.013, -0.0};
  writeArchive(held, path("held.h5"));
  ASSERT_EQ(run("inspect held.h5", &out), 0);
  EXPECT_TRUE(contains(out, "(3 at the minimum, 0 at the maximum); to first order the objective falls by 0.013% "
                            "per 1% lower minimum\n"));
  EXPECT_FALSE(contains(out, "higher maximum"));
  EXPECT_FALSE(contains(out, "-0%"));
  held.controlPoints->radiusBounds = ArchiveControlPoints::RadiusBounds{1e-3, 5e-3, 2, 4, 0.5, -1.25};
  writeArchive(held, path("held.h5"));
  ASSERT_EQ(run("inspect held.h5", &out), 0);
  EXPECT_TRUE(contains(out, "falls by 0.5% per 1% lower minimum and by 1.2% per 1% higher maximum\n"));

  // A simulate archive shows none of it.
  ASSERT_EQ(run("inspect sim.h5", &out), 0);
  for (const char* s : {"method", "equilibrium gap", "history", "control", "over all poses"})
    EXPECT_FALSE(contains(out, s)) << s;
}

// h5py reads the optimize parts with their types (numbers as numbers).
const char* kH5pyOptimizeCheck = R"PY(
import sys
import h5py
import numpy as np

errors = []
def check(cond, what):
    if not cond:
        errors.append(what)

def integer(x):
    return np.issubdtype(np.asarray(x).dtype, np.integer)

def dataset(f, path, shape, kind):
    d = f.get(path)
    check(isinstance(d, h5py.Dataset), path + " missing")
    if isinstance(d, h5py.Dataset):
        ok = d.dtype == np.float64 if kind == "float" else np.issubdtype(d.dtype, np.integer)
        check(ok, "%s has dtype %s, expected %s" % (path, d.dtype, kind))
        check(d.shape == shape, "%s has shape %s, expected %s" % (path, d.shape, shape))

with h5py.File(sys.argv[1], "r") as f:
    a = f.attrs
    check(a.get("command") == "optimize", "command is %r" % a.get("command"))
    check(a.get("method") == "reduced", "method reads as %r" % a.get("method"))
    check(integer(a["iterations"]) and int(a["iterations"]) == 42, "iterations: %r" % a.get("iterations"))
    check(np.asarray(a["time_s"]).dtype == np.float64 and float(a["time_s"]) == 12.5, "time_s: %r" % a.get("time_s"))
    check(a.get("message") == "stopped at --max-iter 42", "message reads as %r" % a.get("message"))
    V = int(f["model"].attrs["n_vertices"])
    dataset(f, "design/initial_radii", (V, 2), "float")
    dataset(f, "design/control_points/radii", (4, 2), "float")
    dataset(f, "design/control_points/rest_displacement", (4, 3), "float")
    dataset(f, "design/control_points/rod", (4,), "int")
    dataset(f, "design/control_points/arc_fraction", (4,), "float")
    dataset(f, "design/control_points/vertex", (4,), "int")
    check(list(f["design/control_points/rod"][()]) == [-1, 0, 0, -1], "rod values")
    check(list(f["design/control_points/vertex"][()]) == [0, -1, -1, 5], "vertex values")
    for name, kind in (("iteration", "int"), ("level", "int"), ("time_s", "float"), ("objective", "float"),
                       ("rms_error", "float"), ("constraint_violation", "float"), ("gradient_norm", "float")):
        dataset(f, "history/" + name, (3,), kind)
    check(list(f["history/iteration"][()]) == [0, 1, 2], "iteration values")
    check(h5py.check_string_dtype(f["history/phase"].dtype) is not None, "history/phase is not a string dataset")
    check(list(f["history/phase"].asstr()[()]) == ["radii", "radii", "rest_shape"], "phase values")
    for name in f["poses"]:
        p = "poses/" + name
        dataset(f, p + "/initial_positions", (V, 3), "float")
        g = f[p].attrs.get("equilibrium_gap")
        check(g is not None and np.asarray(g).dtype == np.float64 and abs(float(g) - 2e-9) < 1e-15,
              p + " equilibrium_gap: %r" % g)
        check("rms_error" in f[p].attrs, p + " rms_error missing")

for e in errors:
    print(e)
sys.exit(1 if errors else 0)
)PY";

TEST_F(ArchiveBuilderTest, H5pyReadsTheOptimizeParts) {
  // scripts/install-deps.sh installs python3-h5py: its absence is a broken setup.
  ASSERT_EQ(std::system("/usr/bin/python3 -c 'import h5py, numpy' >/dev/null 2>&1"), 0)
      << "/usr/bin/python3 cannot import h5py and numpy (run scripts/install-deps.sh)";
  copySource("cantilever.json");
  const Archive sim = simulate("cantilever.json");
  writeArchive(optimizeArchive(sim, readSceneFile(path("cantilever.json"))), path("opt.h5"));
  clitest::writeText(dir_ + ".py", kH5pyOptimizeCheck);
  const std::string cmd = "/usr/bin/python3 " + clitest::shellQuote(dir_ + ".py") + " " +
                          clitest::shellQuote(path("opt.h5")) + " >" + clitest::shellQuote(dir_ + ".pyout") + " 2>&1";
  const int raw = std::system(cmd.c_str());
  const std::string report = clitest::readText(dir_ + ".pyout");
  std::remove((dir_ + ".py").c_str());
  std::remove((dir_ + ".pyout").c_str());
  EXPECT_TRUE(raw != -1 && WIFEXITED(raw) && WEXITSTATUS(raw) == 0) << report;
}

}  // namespace
}  // namespace rodmesh
