// Hard cases for `rodmesh simulate --dynamic` and for the solver flags of
// `simulate`: tiny and huge time steps, a sudden end twist, and flag values
// that would hang or make no sense (usage errors, exit 2, nothing written).
//
// References: backward Euler with a constant step h under a constant
// acceleration g gives x_n = -g h^2 n (n + 1) / 2, i.e. x(t) = -g t (t + h) / 2
// exactly; with huge steps it is a damped fixed-point iteration whose fixed
// point is the static equilibrium; the twist of a straight rod under an end
// moment is quasi-static (massless twists), M L / (G J) at once.
#include <cmath>
#include <string>
#include <vector>

#include "model/stiffness.hh"
#include "tests/hard/hard_util.hh"

namespace rodmesh::hardtest {
namespace {

constexpr double kPi = stiffness::kPi;
const Material kSoft{1e7, 0.4, 1000.0};

using HardDynamics = HardCase;

// A free rod (nothing held) falling under gravity with constant steps of
// 1e-9 s (5e4 steps; the smallest --max-step allowed for this duration is
// half that). Each step moves it by ~1e-17 m, far below the resolution of
// its x coordinates (0.1 m): before, the Newton correction counted as
// round-off and the rod never moved.
TEST_F(HardDynamics, FreeFallWithTinySteps) {
  const double T = 5e-5, h = 1e-9, g = 9.81;
  Scene s = straightRod(2, 0.1, 0.002, kSoft);
  s.gravity = Vec3(0, 0, -g);
  const RunResult run = simulate(s, "--dynamic --duration 5e-5 --max-step 1e-9");
  ASSERT_EQ(run.status, 0) << run.err;
  const Archive a = archive();
  EXPECT_TRUE(archiveFinite(a));
  ASSERT_EQ(a.frames.size(), 1u);
  EXPECT_DOUBLE_EQ(a.frames[0].time[a.frames[0].time.size() - 1], T);
  const double exact = -g * T * (T + h) / 2;
  for (int v = 0; v < 2; ++v) EXPECT_NEAR(onlyPose(a).positions(v, 2), exact, 1e-6 * std::abs(exact));
}

// A soft cantilever under gravity with --max-step far above the duration:
// backward Euler stays stable, and the motion settles on the static
// equilibrium.
TEST_F(HardDynamics, HugeStepsSettleOnTheStaticEquilibrium) {
  Scene s = straightRod(21, 0.1, 0.002, kSoft);
  s.gravity = Vec3(0, 0, -9.81);
  s.poses[0].clamped.push_back({0});
  ASSERT_EQ(simulate(s).status, 0);
  const double staticTip = onlyPose(archive()).positions(20, 2);
  const RunResult run = simulate(s, "--dynamic --duration 20 --fps 1 --max-step 1000");
  ASSERT_EQ(run.status, 0) << run.err;
  const Archive a = archive();
  EXPECT_TRUE(archiveFinite(a));
  EXPECT_EQ(a.status, "converged");
  EXPECT_NEAR(onlyPose(a).positions(20, 2), staticTip, 1e-3 * std::abs(staticTip));
}

// A clamped rod under a sudden end moment (a quarter turn's worth): before,
// every step was rejected for its twist change (which no step size makes
// smaller: the twists are massless) and the run stopped at t = 0.
TEST_F(HardDynamics, SuddenEndTwistIsIntegratedToTheEnd) {
  const double r = 0.02, L = 1.0;
  const Material m{1e8, 0.4, 500.0};
  const double GJ = stiffness::twisting(m.shearModulus(), r, r), M = 2 * kPi * 0.25 * GJ / L;
  Scene s = straightRod(101, L, r, m);
  s.poses[0].clamped.push_back({0});
  s.poses[0].twistingMoments.push_back({100, M});
  const RunResult run = simulate(s, "--dynamic --duration 0.1 --fps 20");
  ASSERT_EQ(run.status, 0) << run.err;
  const Archive a = archive();
  EXPECT_EQ(a.status, "converged");
  EXPECT_TRUE(archiveFinite(a));
  const Eigen::VectorXd& th = onlyPose(a).twist;
  ASSERT_EQ(th.size(), 100);
  const double tip = th[99] + 0.5 * (th[99] - th[98]);
  EXPECT_NEAR(tip, M * L / GJ, 1e-6 * M * L / GJ);
}

// Flag values that would hang the run or make no sense: usage errors (exit 2)
// that name the flag and its allowed range, with nothing written.
TEST_F(HardDynamics, AbsurdSolverFlagsAreUsageErrors) {
  Scene s = straightRod(6, 0.1, 0.002, kSoft);
  s.poses[0].clamped.push_back({0});
  s.poses[0].forces.push_back({5, Vec3(0, 0, -0.01)});
  writeSceneFile(s, path("scene.json"));
  struct Case {
    std::string flags, flag;
  };
  const std::vector<Case> cases = {
      {"--dynamic --duration 1 --max-step 1e-12", "--max-step"},
      {"--dynamic --duration 1 --max-step 0", "--max-step"},
      {"--dynamic --duration 1 --max-step inf", "--max-step"},
      {"--dynamic --duration 0", "--duration"},
      {"--dynamic --duration nan", "--duration"},
      {"--dynamic --duration 1e300", "--fps"},
      {"--dynamic --duration 1 --fps 0", "--fps"},
      {"--dynamic --duration 1 --fps inf", "--fps"},
      {"--dynamic --duration 1 --ramp -1", "--ramp"},
      {"--dynamic --duration 1 --max-iter 100000", "--max-iter"},
      {"--tol 0", "--tol"},
      {"--tol 1e-300", "--tol"},
      {"--tol 0.5", "--tol"},
      {"--tol nan", "--tol"},
      {"--max-iter 0", "--max-iter"},
      {"--max-iter 1000000", "--max-iter"},
      {"--time-limit 0", "--time-limit"},
      {"--time-limit inf", "--time-limit"},
      {"--static-solver relaxation --max-iter 1000000000", "--max-iter"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.flags);
    const RunResult r = run("simulate scene.json -o out.h5 " + c.flags);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_FALSE(archiveExists());
    EXPECT_NE(r.err.find(c.flag), std::string::npos) << r.err;
    if (c.flag != "--duration") {
      EXPECT_NE(r.err.find("range"), std::string::npos) << r.err;
    }
  }
}

}  // namespace
}  // namespace rodmesh::hardtest
