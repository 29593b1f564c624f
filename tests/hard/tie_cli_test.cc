// The plastic tie (model/terms/tie.hh, scene key poses[i].ties) through the
// command line, as a user runs it: `rodmesh simulate` of a cantilever whose
// tip is tied down and lifted by more than the tie's yield load rests where
// the linear beam carries the load less the yield force, and a ramped
// dynamic run (which records the tie's yielding step by step) ends there
// too. A scene with a malformed tie is refused with exit 2.
#include "tests/hard/hard_util.hh"
#include "tests/testutil/scenes.hh"

#include <cmath>

namespace rodmesh::hardtest {
namespace {

constexpr double kLength = 0.1, kRadius = 1e-3, kDrop = 0.02, kTie = 0.05, kYield = 2e-5;
constexpr int kEdges = 20;

// A cantilever along +x clamped at 0, its tip tied to a held vertex kDrop
// below and lifted by `force`.
Scene tiedCantilever(double force) {
  Scene s = testutil::cantileverOverHeldRod(kEdges, kLength, kRadius, kDrop);
  Pose& p = s.poses.at(0);
  p.ties.push_back({kEdges, kEdges + 1, kTie, kYield});
  p.forces.push_back({kEdges, Vec3(0.0, 0.0, force)});
  return s;
}

class TieCli : public HardCase {};

TEST_F(TieCli, ATieThatYieldsHoldsBackOnlyItsYieldForce) {
  const Scene probe = tiedCantilever(0.0);
  const double K = 3.0 * probe.material.youngModulus * M_PI * std::pow(kRadius, 4) / 4.0 / std::pow(kLength, 3);
  const double F = 1.5 * kYield * (K + kTie) / kTie;  // 1.5 times the yield load
  const double lift = (F - kYield) / K, elastic = F / (K + kTie);
  ASSERT_GT(lift, 1.5 * elastic) << "the plastic answer must differ from the elastic one";
  const Scene s = tiedCantilever(F);
  const RunResult r = simulate(s);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NEAR(row(onlyPose(archive()).positions, kEdges).z(), lift, 0.01 * lift);

  const RunResult d = simulate(s, "--dynamic --duration 200 --ramp 20 --fps 0.05");
  ASSERT_EQ(d.status, 0) << d.err;
  const Archive a = archive();
  ASSERT_EQ(a.frames.size(), 1u);
  ASSERT_FALSE(a.frames[0].positions.empty());
  EXPECT_NEAR(row(a.frames[0].positions.back(), kEdges).z(), lift, 0.01 * lift);
}

TEST_F(TieCli, AMalformedTieIsRefused) {
  Scene s = tiedCantilever(1e-5);
  s.poses[0].ties[0].yieldForce = 0.0;
  const RunResult r = simulate(s);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("poses[0].ties[0].yield_force"), std::string::npos) << r.err;
  EXPECT_FALSE(archiveExists());
}

}  // namespace
}  // namespace rodmesh::hardtest
