// A pose model is immutable: every evaluation is a function of the state and
// design it is given. Two states of one const model (different unknowns,
// charts and load factors) evaluated interleaved, or from two threads at
// once, give exactly the values each gives alone.
#include "model/pose_system.hh"
#include "model/scene_model.hh"
#include "tests/testutil/scenes.hh"

#include <gtest/gtest.h>

#include <optional>
#include <random>
#include <thread>
#include <vector>

namespace rodmesh {
namespace {

// A 3D network with twist, connections, a clamp, an explicitly displaced
// support, point forces and gravity: every kind of term and every
// state-dependent quantity (charts, load factor) is in play.
Scene networkScene() {
  testutil::StarNetworkOptions o;
  o.verticesPerArm = 4;
  o.lift = 0.002;
  Scene s = testutil::starNetwork(o);
  Pose p;
  p.name = "p";
  p.clamped.push_back({testutil::tipVertex(s)});
  const int last = static_cast<int>(s.vertices.size()) - 1;
  p.fixed.push_back({last, s.vertices[last] + Vec3(0.002, -0.001, 0.003)});
  p.forces.push_back({0, Vec3(0.01, -0.02, 0.03)});
  s.poses.push_back(p);
  return s;
}

// Everything one state evaluates to.
struct Values {
  double energy = 0.0;
  Eigen::VectorXd gradient;
  Eigen::SparseMatrix<double> hessian;
  JointDerivatives joint, directional;
  Eigen::VectorXd product;
  std::vector<Vec3> positions;
  Eigen::VectorXd materialTwists;
};

void evaluateAll(const PoseSystem& sys, const PoseState& s, const Design& d, const Eigen::VectorXd& v, Values& out) {
  out.energy = sys.evaluate(s, d, &out.gradient, &out.hessian);
  sys.evaluateJoint(s, d, out.joint);
  sys.evaluateJoint(s, d, out.directional, &v);
  out.product = sys.designForceProduct(s, d, v);
  out.positions = sys.positions(s, d);
  out.materialTwists = sys.materialTwists(s, d);
}

bool sameValues(const Eigen::SparseMatrix<double>& a, const Eigen::SparseMatrix<double>& b) {
  return a.nonZeros() == b.nonZeros() &&
         Eigen::Map<const Eigen::VectorXd>(a.valuePtr(), a.nonZeros()) ==
             Eigen::Map<const Eigen::VectorXd>(b.valuePtr(), b.nonZeros());
}

// Bit-for-bit equality of everything evaluated.
void expectIdentical(const Values& a, const Values& b, const char* what) {
  EXPECT_EQ(a.energy, b.energy) << what;
  EXPECT_EQ(a.gradient, b.gradient) << what;
  EXPECT_TRUE(sameValues(a.hessian, b.hessian)) << what;
  EXPECT_EQ(a.joint.energy, b.joint.energy) << what;
  EXPECT_EQ(a.joint.gu, b.joint.gu) << what;
  EXPECT_EQ(a.joint.gp, b.joint.gp) << what;
  EXPECT_TRUE(sameValues(a.joint.Huu, b.joint.Huu)) << what;
  EXPECT_TRUE(sameValues(a.joint.Hup, b.joint.Hup)) << what;
  EXPECT_TRUE(sameValues(a.joint.Hpp, b.joint.Hpp)) << what;
  EXPECT_EQ(a.directional.energy, b.directional.energy) << what;
  EXPECT_EQ(a.directional.gu, b.directional.gu) << what;
  EXPECT_TRUE(sameValues(a.directional.Huu, b.directional.Huu)) << what;
  EXPECT_TRUE(sameValues(a.directional.Hup, b.directional.Hup)) << what;
  EXPECT_TRUE(sameValues(a.directional.Hpp, b.directional.Hpp)) << what;
  EXPECT_EQ(a.product, b.product) << what;
  ASSERT_EQ(a.positions.size(), b.positions.size()) << what;
  for (std::size_t i = 0; i < a.positions.size(); ++i) EXPECT_EQ(a.positions[i], b.positions[i]) << what;
  EXPECT_EQ(a.materialTwists, b.materialTwists) << what;
}

class ImmutableModel : public ::testing::Test {
 protected:
  void SetUp() override {
    model_ = std::make_unique<SceneModel>(scene_);
    design_ = Design::fromScene(scene_);
    const PoseSystem& sys = model_->pose(0);
    ASSERT_TRUE(sys.hasTwist());
    ASSERT_GT(sys.termCount(PoseSystem::termKindIndex("connection")), 0);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    auto perturbed = [&](double scale) {
      Eigen::VectorXd u = sys.restDofs(design_);
      for (int i = 0; i < u.size(); ++i) u[i] += i >= sys.numVertexDofs() ? 0.5 * U(rng) : scale * U(rng);
      return u;
    };
    // A: rest charts, full load. B: other unknowns, half the load, and every
    // chart moved to its edge's current frame.
    a_ = sys.withRestCharts(perturbed(0.001), design_, 1.0);
    const PoseState b = sys.withRestCharts(perturbed(0.002), design_, 0.5);
    const std::optional<PoseState> anchored = sys.reanchored(b, design_, 2.0);
    ASSERT_TRUE(anchored.has_value());
    b_ = *anchored;
    v_ = Eigen::VectorXd::LinSpaced(sys.numDofs(), -1.0, 1.0);
  }

  Scene scene_ = networkScene();
  std::unique_ptr<SceneModel> model_;
  Design design_;
  PoseState a_, b_;
  Eigen::VectorXd v_;
};

TEST_F(ImmutableModel, InterleavedStatesGiveTheirOwnValues) {
  const PoseSystem& sys = model_->pose(0);
  Values aloneA, aloneB;
  evaluateAll(sys, a_, design_, v_, aloneA);
  {
    // B alone, on a model that never saw A.
    SceneModel fresh(scene_);
    evaluateAll(fresh.pose(0), b_, design_, v_, aloneB);
  }
  // The states differ: the test would not see a leak otherwise.
  ASSERT_NE(aloneA.energy, aloneB.energy);
  ASSERT_NE(aloneA.positions[static_cast<int>(scene_.vertices.size()) - 1],
            aloneB.positions[static_cast<int>(scene_.vertices.size()) - 1]);

  // Interleaved, into the same outputs and into fresh ones.
  Values shared, fresh;
  for (int round = 0; round < 3; ++round) {
    evaluateAll(sys, b_, design_, v_, shared);
    expectIdentical(shared, aloneB, "B after A (shared outputs)");
    evaluateAll(sys, a_, design_, v_, shared);
    expectIdentical(shared, aloneA, "A after B (shared outputs)");
    fresh = Values{};
    evaluateAll(sys, b_, design_, v_, fresh);
    expectIdentical(fresh, aloneB, "B after A (fresh outputs)");
  }
  // Re-anchoring returned a new state and left A's charts as they were.
  EXPECT_EQ(a_.charts.tangent, sys.restCharts(design_).tangent);
}

TEST_F(ImmutableModel, ConcurrentEvaluationsFromTwoThreads) {
  const PoseSystem& sys = model_->pose(0);
  Values aloneA, aloneB;
  {
    SceneModel other(scene_);
    evaluateAll(other.pose(0), a_, design_, v_, aloneA);
    evaluateAll(other.pose(0), b_, design_, v_, aloneB);
  }
  // The joint pattern is built on first use: both threads race to it.
  Values inA, inB;
  bool sameA = true, sameB = true;
  auto run = [&](const PoseState& s, const Values& alone, Values& out, bool& same) {
    for (int k = 0; k < 10; ++k) {
      evaluateAll(sys, s, design_, v_, out);
      same = same && out.energy == alone.energy && out.gradient == alone.gradient &&
             sameValues(out.hessian, alone.hessian) && sameValues(out.directional.Huu, alone.directional.Huu);
    }
  };
  std::thread ta(run, std::cref(a_), std::cref(aloneA), std::ref(inA), std::ref(sameA));
  std::thread tb(run, std::cref(b_), std::cref(aloneB), std::ref(inB), std::ref(sameB));
  ta.join();
  tb.join();
  EXPECT_TRUE(sameA);
  EXPECT_TRUE(sameB);
  expectIdentical(inA, aloneA, "A from its thread");
  expectIdentical(inB, aloneB, "B from its thread");
}

TEST_F(ImmutableModel, HessianValuesWrittenIntoTheCallersPattern) {
  const PoseSystem& sys = model_->pose(0);
  const Eigen::SparseMatrix<double>& pattern = sys.hessianPattern();
  Eigen::VectorXd g;
  Eigen::SparseMatrix<double> H;
  sys.evaluate(a_, design_, &g, &H);
  ASSERT_EQ(H.nonZeros(), pattern.nonZeros());
  EXPECT_EQ(Eigen::Map<const Eigen::VectorXi>(H.innerIndexPtr(), H.nonZeros()),
            Eigen::Map<const Eigen::VectorXi>(pattern.innerIndexPtr(), pattern.nonZeros()));
  // Later evaluations write values only: the matrix keeps its storage.
  const double* values = H.valuePtr();
  const int* rows = H.innerIndexPtr();
  sys.evaluate(b_, design_, &g, &H);
  EXPECT_EQ(H.valuePtr(), values);
  EXPECT_EQ(H.innerIndexPtr(), rows);
  // The model's pattern holds no values.
  EXPECT_EQ(Eigen::Map<const Eigen::VectorXd>(pattern.valuePtr(), pattern.nonZeros()).cwiseAbs().maxCoeff(), 0.0);
}

}  // namespace
}  // namespace rodmesh
