// Tests of solver/mass, solver/dynamics (backward Euler) and
// solver/relaxation (dynamic relaxation with kinetic damping).
//
// References:
//   - free fall: backward Euler with a constant step h under constant
//     acceleration g gives x_n = x_0 - g h^2 n (n + 1) / 2 exactly;
//   - first bending mode of a clamped-free beam: omega_1 = 1.875^2
//     sqrt(EI / (rho A L^4)). Backward Euler damps the amplitude by
//     1/sqrt(1 + (omega h)^2) per step and lengthens the period by a relative
//     (omega h)^2 / 3; with omega h ~ 0.016 both are tiny against the lumped-mass
//     discretization error of 20 edges (well under 1 %);
//   - backward Euler on an unforced system dissipates: kinetic + potential
//     energy never increases (for a convex energy, exactly);
//   - the dynamic state settles to the static (Newton) equilibrium, and
//     dynamic relaxation reaches it too, within the position error its
//     residual tolerance allows: |du| <= |r| / lambda_min(H).
#include "solver/dynamics.hh"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <vector>

#include "model/stiffness.hh"
#include "solver/equilibrium.hh"
#include "solver/mass.hh"
#include "solver/newton.hh"
#include "solver/relaxation.hh"
#include "tests/testutil/scenes.hh"

namespace rodmesh {
namespace {

constexpr double kPi = stiffness::kPi;

// A cantilever along x (clamped at vertex 0), 3D with twist (explicit
// effects, so that loaded and unloaded copies share their unknowns), normals
// along z: out-of-plane bending stiffness E pi rt rn^3 / 4.
Scene cantilever3d(int edges, double L, double rt, double rn) {
  Scene s = testutil::cantilever(edges, L, rt, rn, Vec3::UnitZ());
  s.effects = std::vector<Effect>{Effect::Stretch, Effect::Bend, Effect::Twist};
  return s;
}

// A curved quad grid of rods: nx x ny connections spaced `spacing` apart on
// the bump z = bump sin(pi x / W) sin(pi y / H) + 0.3 bump x / W, each link a
// rod of k edges; the connections on y = 0 are fixed (and those on y = H for
// a bridge); gravity along -z and a point force on the far corner. Material:
// TPU as in the paper.
Scene curvedGrid(int nx, int ny, int k, double spacing, double bump, bool bridge = false) {
  Scene s;
  s.sourcePath = "<test grid>";
  s.material = Material{3.2e7, 0.48, 1200.0};
  const double W = spacing * (nx - 1), H = spacing * (ny - 1);
  auto surface = [&](double x, double y) {
    return Vec3(x, y, bump * std::sin(kPi * x / W) * std::sin(kPi * y / H) + 0.3 * bump * x / W);
  };
  auto node = [&](int i, int j) { return j * nx + i; };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) s.vertices.push_back(surface(i * spacing, j * spacing));
  auto link = [&](int a, int b) {
    Rod rod;
    rod.vertices.push_back(a);
    const Vec3 pa = s.vertices[a], pb = s.vertices[b];
    for (int q = 1; q < k; ++q) {
      const Vec3 p = pa + (pb - pa) * (double(q) / k);
      rod.vertices.push_back(static_cast<int>(s.vertices.size()));
      s.vertices.push_back(surface(p.x(), p.y()));
    }
    rod.vertices.push_back(b);
    s.rods.push_back(rod);
  };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i + 1 < nx; ++i) link(node(i, j), node(i + 1, j));
  for (int j = 0; j + 1 < ny; ++j)
    for (int i = 0; i < nx; ++i) link(node(i, j), node(i, j + 1));
  s.normals.assign(s.vertices.size(), Vec3::UnitZ());
  s.radii.assign(s.vertices.size(), Vec2(0.0015, 0.001));
  s.gravity = Vec3(0.0, 0.0, -9.81);
  Pose p;
  p.name = "hang";
  for (int i = 0; i < nx; ++i) p.fixed.push_back(FixedVertex{node(i, 0), std::nullopt});
  if (bridge)
    for (int i = 0; i < nx; ++i) p.fixed.push_back(FixedVertex{node(i, ny - 1), std::nullopt});
  p.forces.push_back(PointForce{node(nx - 1, ny - 1), Vec3(0.0, 0.0, -0.02)});
  s.poses.push_back(p);
  return s;
}

// Static equilibrium by Newton (production path, given tolerance).
PoseState newtonEquilibrium(const PoseSystem& sys, const Design& d, double tol) {
  NewtonOptions opt;
  opt.tolerance = tol;
  PoseState s = sys.restState(d);
  const NewtonReport r = solveEquilibrium(sys, d, s, opt);
  EXPECT_TRUE(r.converged()) << r.message;
  return s;
}

double maxDistance(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  double m = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, (a[i] - b[i]).norm());
  return m;
}

// --------------------------------------------------------------------- mass

TEST(Mass, LumpedMassesSumToTheRodMassAndMatchGravity) {
  const double L = 0.1, rt = 0.002, rn = 0.001;
  Scene s = testutil::straightRod(10, L, rt, rn);
  RodNetwork net(s);
  const Design d = Design::fromScene(s);
  const std::vector<double> m = lumpedVertexMasses(net, d, s.material.density);
  double total = 0.0;
  for (double mi : m) total += mi;
  const double exact = s.material.density * kPi * rt * rn * L;
  EXPECT_NEAR(total, exact, 1e-14 * exact);
  EXPECT_NEAR(m[0], 0.5 * m[1], 1e-15) << "end vertices carry half an edge";

  // Weight on each vertex (minus the gravity gradient) is m_v g.
  s.gravity = Vec3(0.0, 0.0, -9.81);
  SceneModel model(s);
  const PoseSystem& sys = model.pose(0);
  Eigen::VectorXd g;
  sys.evaluate(sys.withRestCharts(sys.restDofs(d), d), d, &g, nullptr);
  const Eigen::VectorXd dm = dofMasses(sys, m);
  ASSERT_EQ(dm.size(), sys.numDofs());
  for (int v = 0; v < net.numVertices(); ++v) {
    const int k = sys.vertexDof()[v];
    ASSERT_GE(k, 0);
    const int zc = sys.dofsPerVertex() == 3 ? k + 2 : -1;
    if (zc >= 0) {
      EXPECT_NEAR(-g[zc], -9.81 * m[v], 1e-12 * m[v]) << "vertex " << v;
    }
  }
  if (sys.hasTwist()) {
    EXPECT_EQ(dm.tail(net.numEdges()).norm(), 0.0) << "twists are massless";
  }
}

// ---------------------------------------------------------------- dynamics

TEST(Dynamics, OptionsValidation) {
  EXPECT_EQ(DynamicsOptions{}.isValid(), "");
  DynamicsOptions o;
  o.minStep = 0;
  EXPECT_NE(o.isValid(), "");
  o = DynamicsOptions{};
  o.maxStep = 1e-12;
  EXPECT_NE(o.isValid(), "");
  o = DynamicsOptions{};
  o.shrinkFactor = 1.0;
  EXPECT_NE(o.isValid(), "");
  o = DynamicsOptions{};
  o.tolerance = 0;
  EXPECT_NE(o.isValid(), "");
}

TEST(Dynamics, FreeFallFollowsBackwardEulerExactly) {
  // A free rod (no held vertex: singular stiffness, free twist) under gravity
  // falls without deforming; with a constant step, backward Euler gives
  // z_n = z_0 - g h^2 n (n + 1) / 2 for every vertex.
  Scene s = testutil::straightRod(8, 0.1, 0.002, 0.001);
  s.gravity = Vec3(0.0, 0.3, -9.81);  // not in the rod's plane: 3D with twist
  SceneModel model(s);
  const PoseSystem& sys = model.pose(0);
  ASSERT_TRUE(sys.hasTwist());
  const Design d = Design::fromScene(s);
  DynamicsOptions opt;
  opt.initialStep = opt.maxStep = 1e-3;
  BackwardEuler be(sys, d, dofMasses(sys, lumpedVertexMasses(model.network(), d, s.material.density)), opt);
  be.start(sys.restState(d), Eigen::VectorXd::Zero(sys.numDofs()));
  const int n = 50;
  ASSERT_TRUE(be.advanceTo(n * 1e-3)) << be.report().message;
  EXPECT_EQ(be.report().steps, n);
  EXPECT_EQ(be.report().rejectedSteps, 0);
  const std::vector<Vec3> x = sys.positions(be.state(), d);
  const double h = 1e-3, fall = h * h * n * (n + 1) / 2.0;
  for (std::size_t v = 0; v < x.size(); ++v) {
    const Vec3 expected = s.vertices[v] + fall * *s.gravity;
    EXPECT_NEAR((x[v] - expected).norm(), 0.0, 1e-9 * fall) << "vertex " << v;
  }
  EXPECT_TRUE(be.velocities().allFinite());
}

// Period of the tip's oscillation about z = 0 from upward zero crossings.
double measuredPeriod(const std::vector<double>& t, const std::vector<double>& z) {
  std::vector<double> crossings;
  for (std::size_t i = 1; i < z.size(); ++i)
    if (z[i - 1] < 0 && z[i] >= 0) crossings.push_back(t[i - 1] + (t[i] - t[i - 1]) * (-z[i - 1]) / (z[i] - z[i - 1]));
  if (crossings.size() < 2) return NAN;
  return (crossings.back() - crossings.front()) / (crossings.size() - 1);
}

// A cantilever released from its static shape under a small tip force.
struct Oscillation {
  Scene loaded, free;
  std::unique_ptr<SceneModel> mLoaded, mFree;
  Design design;
  PoseState s0;  // the loaded equilibrium (unknowns and charts) the motion starts from
  double tip0 = 0.0;
};

std::unique_ptr<Oscillation> releasedCantilever(int edges, double L, double rt, double rn, double tipForce) {
  auto o = std::make_unique<Oscillation>();
  o->free = cantilever3d(edges, L, rt, rn);
  o->loaded = o->free;
  o->loaded.poses[0].forces.push_back(PointForce{edges, Vec3(0.0, 0.0, tipForce)});
  o->mLoaded = std::make_unique<SceneModel>(o->loaded);
  o->mFree = std::make_unique<SceneModel>(o->free);
  o->design = Design::fromScene(o->free);
  const PoseSystem& sl = o->mLoaded->pose(0);
  o->s0 = newtonEquilibrium(sl, o->design, 1e-10);
  o->tip0 = sl.positions(o->s0, o->design)[edges].z();
  const PoseSystem& sf = o->mFree->pose(0);
  EXPECT_EQ(sf.numDofs(), sl.numDofs());
  return o;
}

TEST(Dynamics, CantileverPeriodMatchesFirstBendingMode) {
  const int N = 20;
  const double L = 0.1, rt = 0.002, rn = 0.001;
  auto o = releasedCantilever(N, L, rt, rn, 1e-5);
  const Material& mat = o->free.material;
  const double EI = stiffness::bendingOut(mat.youngModulus, rt, rn);
  const double rhoA = stiffness::massPerLength(mat.density, rt, rn);
  const double omega = 1.875104 * 1.875104 * std::sqrt(EI / (rhoA * std::pow(L, 4)));
  const double period = 2 * kPi / omega;
  ASSERT_LT(std::abs(o->tip0), 5e-3 * L) << "small amplitude";

  const PoseSystem& sys = o->mFree->pose(0);
  DynamicsOptions opt;
  opt.initialStep = opt.maxStep = period / 400;
  BackwardEuler be(sys, o->design, dofMasses(sys, lumpedVertexMasses(o->mFree->network(), o->design, mat.density)),
                   opt);
  be.start(o->s0, Eigen::VectorXd::Zero(sys.numDofs()));
  std::vector<double> t{0.0}, z{o->tip0};
  const int steps = static_cast<int>(2.6 * 400);
  for (int i = 1; i <= steps; ++i) {
    ASSERT_TRUE(be.advanceTo(i * opt.maxStep)) << be.report().message;
    t.push_back(be.time());
    z.push_back(sys.positions(be.state(), o->design)[N].z());
  }
  const double measured = measuredPeriod(t, z);
  RecordProperty("period_closed_form_s", std::to_string(period));
  RecordProperty("period_measured_s", std::to_string(measured));
  EXPECT_NEAR(measured / period, 1.0, 0.005) << "measured " << measured << " s, closed form " << period << " s";
  // Backward Euler damps, but only slightly at this step.
  double late = 0.0;
  for (std::size_t i = z.size() - 400; i < z.size(); ++i) late = std::max(late, std::abs(z[i]));
  EXPECT_LT(late, std::abs(o->tip0));
  EXPECT_GT(late, 0.8 * std::abs(o->tip0));
}

TEST(Dynamics, EnergyNeverIncreasesWithoutForcing) {
  // Moderately large amplitude (tip at ~15 % of L), adaptive steps.
  const int N = 12;
  auto o = releasedCantilever(N, 0.1, 0.002, 0.001, 2e-3);
  ASSERT_GT(std::abs(o->tip0), 0.05 * 0.1);
  const PoseSystem& sys = o->mFree->pose(0);
  DynamicsOptions opt;
  opt.maxStep = 5e-3;
  BackwardEuler be(sys, o->design,
                   dofMasses(sys, lumpedVertexMasses(o->mFree->network(), o->design, o->free.material.density)), opt);
  be.start(o->s0, Eigen::VectorXd::Zero(sys.numDofs()));
  const double E0 = be.kineticEnergy() + be.potentialEnergy();
  ASSERT_GT(E0, 0.0);
  double prev = E0;
  for (int i = 1; i <= 200; ++i) {
    ASSERT_TRUE(be.advanceTo(i * 2.5e-3)) << be.report().message;
    const double Et = be.kineticEnergy() + be.potentialEnergy();
    ASSERT_TRUE(std::isfinite(Et));
    EXPECT_LE(Et, prev + 1e-9 * E0) << "energy increased at t = " << be.time();
    prev = Et;
  }
  EXPECT_LT(prev, 0.9 * E0) << "backward Euler dissipates";
  EXPECT_GT(be.report().steps, 100);
}

TEST(Dynamics, SettlesToTheStaticEquilibrium) {
  Scene s = curvedGrid(4, 4, 4, 0.02, 0.004);
  SceneModel model(s);
  ASSERT_GT(model.network().numConnections(), 0);
  ASSERT_TRUE(model.effects().has(Effect::Connections));
  const Design d = Design::fromScene(s);
  const PoseSystem& sys = model.pose(0);
  const PoseState sStatic = newtonEquilibrium(sys, d, 1e-10);
  const std::vector<Vec3> xStatic = sys.positions(sStatic, d);
  const double sag = maxDistance(xStatic, s.vertices);
  ASSERT_GT(sag, 1e-3);

  DynamicsOptions opt;
  opt.maxStep = 1.0;
  DynamicFrames frames;
  const DynamicsReport r =
      simulateDynamics(sys, d, lumpedVertexMasses(model.network(), d, s.material.density), opt, 20.0, 1.0, frames);
  ASSERT_TRUE(r.converged()) << r.message;
  ASSERT_EQ(frames.time.size(), 21u);
  EXPECT_EQ(frames.time.front(), 0.0);
  EXPECT_EQ(frames.time.back(), 20.0);
  EXPECT_EQ(maxDistance(frames.positions.front(), s.vertices), 0.0) << "frame 0 is the rest state";
  EXPECT_LT(maxDistance(frames.positions.back(), xStatic), 1e-6 * sag);
  EXPECT_GT(r.maxStepTaken, 0.1) << "steps grow once the motion has died out";
}

TEST(Dynamics, FailureKeepsTheLastStateAndSaysWhy) {
  // One Newton iteration per step cannot meet a 1e-12 tolerance on a
  // sagging network: every step is rejected until the step is too small.
  Scene s = curvedGrid(3, 3, 3, 0.02, 0.004);
  SceneModel model(s);
  const Design d = Design::fromScene(s);
  DynamicsOptions opt;
  opt.maxNewtonIterations = 1;
  opt.tolerance = 1e-12;
  opt.minStep = 1e-5;
  DynamicFrames frames;
  const DynamicsReport r =
      simulateDynamics(model.pose(0), d, lumpedVertexMasses(model.network(), d, 1200.0), opt, 0.1, 100.0, frames);
  EXPECT_FALSE(r.converged());
  EXPECT_EQ(r.outcome, Outcome::NumericalFailure);
  EXPECT_TRUE(r.usable) << "the last accepted state";
  EXPECT_NE(r.message.find("time step fell below"), std::string::npos) << r.message;
  EXPECT_LT(r.time, 0.1);
  EXPECT_GT(r.rejectedSteps, 0);
  ASSERT_FALSE(frames.positions.empty());
  for (const auto& f : frames.positions)
    for (const Vec3& x : f) ASSERT_TRUE(x.allFinite());
  EXPECT_TRUE(frames.finalDofs.allFinite());
}

TEST(Dynamics, HeldVerticesStayAtTheirPrescribedPositions) {
  Scene s = curvedGrid(3, 3, 3, 0.02, 0.004);
  // Move one fixed vertex: it must sit at its new position in every frame
  // after the ramp.
  s.poses[0].fixed[0].position = s.vertices[0] + Vec3(0.0, 0.0, 0.005);
  SceneModel model(s);
  const Design d = Design::fromScene(s);
  DynamicsOptions opt;
  opt.loadRampTime = 0.05;
  DynamicFrames frames;
  const DynamicsReport r =
      simulateDynamics(model.pose(0), d, lumpedVertexMasses(model.network(), d, 1200.0), opt, 0.1, 100.0, frames);
  ASSERT_TRUE(r.converged()) << r.message;
  for (std::size_t f = 0; f < frames.time.size(); ++f) {
    const double lam = std::min(1.0, frames.time[f] / 0.05);
    EXPECT_NEAR((frames.positions[f][0] - (s.vertices[0] + lam * Vec3(0, 0, 0.005))).norm(), 0.0, 1e-15);
    EXPECT_EQ(frames.positions[f][1], s.vertices[1]) << "held at rest";
  }
}

// -------------------------------------------------------------- relaxation

TEST(Relaxation, OptionsValidation) {
  EXPECT_EQ(RelaxationOptions{}.isValid(), "");
  RelaxationOptions o;
  o.massSafety = 0.2;
  EXPECT_NE(o.isValid(), "");
  o = RelaxationOptions{};
  o.tolerance = 2;
  EXPECT_NE(o.isValid(), "");
}

// Relaxation and Newton on the same pose: same equilibrium, within the
// linearized position error of the two residuals, |du| <= |r| / lambda_min.
void expectSameEquilibrium(const Scene& s, double tol) {
  SceneModel model(s);
  const Design d = Design::fromScene(s);
  const PoseSystem& sys = model.pose(0);
  const PoseState sN = newtonEquilibrium(sys, d, tol);
  const std::vector<Vec3> xN = sys.positions(sN, d);
  Eigen::VectorXd gN;
  Eigen::SparseMatrix<double> HN;
  sys.evaluate(sN, d, &gN, &HN);
  const Eigen::MatrixXd H = Eigen::MatrixXd(HN).selfadjointView<Eigen::Lower>();
  const double lambdaMin = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(H).eigenvalues().minCoeff();
  ASSERT_GT(lambdaMin, 0.0) << "stable equilibrium";

  Eigen::VectorXd uR = sys.restDofs(d);
  RelaxationOptions ro;
  ro.tolerance = tol;
  Charts chartsR;
  const RelaxationReport r = relaxEquilibrium(sys, d, uR, ro, &chartsR);
  ASSERT_TRUE(r.converged()) << r.message;
  // Converged: below the tolerance, or at the round-off floor as in Newton.
  EXPECT_TRUE(r.relativeResidual <= tol || r.residualNorm <= sys.roundoffForce(d)) << r.relativeResidual;
  EXPECT_GT(r.iterations, 0);
  ASSERT_FALSE(r.residualHistory.empty());
  EXPECT_EQ(r.residualHistory.size(), r.historySeconds.size());
  EXPECT_EQ(r.residualHistory.back(), r.relativeResidual);
  Eigen::VectorXd gR;
  const PoseState sR{uR, chartsR, 1.0, {}};
  sys.evaluate(sR, d, &gR, nullptr);
  const std::vector<Vec3> xR = sys.positions(sR, d);
  const double bound = (gR.norm() + gN.norm()) / lambdaMin;
  const double moved = maxDistance(xN, s.vertices);
  ::testing::Test::RecordProperty("relaxation_iterations", r.iterations);
  char buf[96];
  std::snprintf(buf, sizeof buf, "%.3e", maxDistance(xR, xN));
  ::testing::Test::RecordProperty("distance_m", buf);
  std::snprintf(buf, sizeof buf, "%.3e", bound);
  ::testing::Test::RecordProperty("bound_m", buf);
  EXPECT_LE(maxDistance(xR, xN), 1.5 * bound + 1e-15) << "relaxation and Newton reach different equilibria";
  EXPECT_LT(maxDistance(xR, xN), 1e-4 * moved) << "the bound is meaningful at this tolerance";
}

TEST(Relaxation, ReachesTheNewtonEquilibriumOfACantilever) {
  Scene s = cantilever3d(12, 0.1, 0.002, 0.001);
  s.gravity = Vec3(0.0, 0.0, -9.81);
  s.poses[0].forces.push_back(PointForce{12, Vec3(0.0, 0.001, -0.002)});
  expectSameEquilibrium(s, 1e-8);
}

TEST(Relaxation, ReachesTheNewtonEquilibriumOfANetwork) {
  expectSameEquilibrium(curvedGrid(4, 3, 3, 0.02, 0.004, true), 1e-8);
}

TEST(Relaxation, NoLoadIsTheRestState) {
  Scene s = cantilever3d(5, 0.1, 0.002, 0.001);
  SceneModel model(s);
  const Design d = Design::fromScene(s);
  Eigen::VectorXd u = model.pose(0).restDofs(d);
  const RelaxationReport r = relaxEquilibrium(model.pose(0), d, u, RelaxationOptions{});
  EXPECT_TRUE(r.converged());
  EXPECT_EQ(r.iterations, 0);
  EXPECT_EQ(u, model.pose(0).restDofs(d));
}

TEST(Relaxation, IterationLimitIsReported) {
  Scene s = curvedGrid(3, 3, 3, 0.02, 0.004);
  SceneModel model(s);
  const Design d = Design::fromScene(s);
  Eigen::VectorXd u = model.pose(0).restDofs(d);
  RelaxationOptions ro;
  ro.maxIterations = 5;
  const RelaxationReport r = relaxEquilibrium(model.pose(0), d, u, ro);
  EXPECT_FALSE(r.converged());
  EXPECT_EQ(r.outcome, Outcome::MaxIterations);
  EXPECT_TRUE(r.usable);  // at the full load, finite: an answer short of the tolerance
  EXPECT_EQ(r.iterations, 5);
  EXPECT_NE(r.message.find("iteration limit"), std::string::npos);
  EXPECT_TRUE(u.allFinite());
}

}  // namespace
}  // namespace rodmesh
