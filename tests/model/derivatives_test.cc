// Taylor tests of every energy term's derivatives (tests/testutil/taylor.hh):
// gradient, Hessian, design gradient, mixed and design Hessians, and the
// third-order directional derivative, at random bent, twisted, anisotropic
// states, in 3D (with and without twist) and with planar unknowns. The kinds
// of term come from the term list (PoseSystem::termKinds): a new block is
// tested here as soon as it is registered and a test scene has an element.
#include "model/pose_system.hh"
#include "solver/equilibrium.hh"
#include "tests/testutil/scenes.hh"
#include "tests/testutil/taylor.hh"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace rodmesh {
namespace {

using testutil::taylorTest;
using testutil::taylorTestScalar;
using Terms = PoseSystem::Terms;

enum class Kind { Spatial, Planar, SpatialNoTwist, Network, NetworkPlanar };

const char* kindName(Kind k) {
  switch (k) {
    case Kind::Spatial: return "spatial";
    case Kind::Planar: return "planar";
    case Kind::SpatialNoTwist: return "spatial-no-twist";
    case Kind::Network: return "network";
    case Kind::NetworkPlanar: return "network-planar";
  }
  return "?";
}

// The shared test network (tests/testutil/scenes.hh: a 3-valent connection of
// three curved rods and a 2-valent one at vertex 2, anisotropic radii), its
// far ends clamped or fixed, a point load.
Scene makeNetwork(bool planar) {
  testutil::StarNetworkOptions o;
  o.lift = planar ? 0.0 : 0.001;
  Scene s = testutil::starNetwork(o);
  s.sourcePath = "<derivatives>";
  Pose p;
  p.name = "p";
  p.clamped.push_back({3});
  p.fixed.push_back({6, std::nullopt});
  p.forces.push_back({9, planar ? Vec3(0.01, -0.02, 0.0) : Vec3(0.01, -0.02, 0.03)});
  s.poses.push_back(p);
  return s;
}

// A curved rod of 7 vertices (a helix arc, or a planar arc), anisotropic
// varying radii, clamped at vertex 0, fixed at vertex 3 of a second short rod
// sharing no vertex, with point forces, a twisting moment (3D), gravity and a
// contact between the two rods, pressed (|x_a - x_b| about 0.7 of its
// distance at rest), and two ties along the first rod (Fixture::at gives them
// rest lengths 0.6 of their scene distances: one stays elastic, the other, with
// a low yield force, is in plastic flow at every tested state).
Scene makeScene(Kind kind) {
  Scene s;
  s.sourcePath = "<derivatives>";
  s.material = Material{2e7, 0.45, 1100.0};
  const int n = 7;
  Rod rod;
  for (int i = 0; i < n; ++i) {
    const double a = 0.35 * i;
    const double z = kind == Kind::Planar ? 0.0 : 0.004 * i;
    s.vertices.push_back(Vec3(0.03 * std::cos(a), 0.03 * std::sin(a), z));
    rod.vertices.push_back(i);
  }
  s.rods.push_back(rod);
  // A second rod with a free interior, fixed at one end.
  Rod rod2;
  for (int i = 0; i < 4; ++i) {
    const double z = kind == Kind::Planar ? 0.0 : 0.002 * i * i;
    s.vertices.push_back(Vec3(0.05 + 0.01 * i, -0.02 + 0.003 * i * i, z));
    rod2.vertices.push_back(n + i);
  }
  s.rods.push_back(rod2);
  for (std::size_t v = 0; v < s.vertices.size(); ++v)
    s.radii.push_back(Vec2(0.0012 + 0.0001 * v, 0.0007 + 0.00015 * (v % 3)));
  s.gravity = kind == Kind::Planar ? Vec3(0.0, -9.81, 0.0) : Vec3(0.5, -2.0, -9.81);
  Pose p;
  p.name = "p";
  p.clamped.push_back({0});
  p.fixed.push_back({n + 3, Vec3(0.085, 0.01, 0.0)});
  p.forces.push_back({n - 1, kind == Kind::Planar ? Vec3(0.01, -0.02, 0.0) : Vec3(0.01, -0.02, 0.03)});
  p.forces.push_back({n, kind == Kind::Planar ? Vec3(-0.01, 0.0, 0.0) : Vec3(-0.01, 0.0, 0.02)});
  if (kind == Kind::Spatial) p.twistingMoments.push_back({n - 1, 1e-4});
  const int ca = 2, cb = n + 1;
  p.contacts.push_back({ca, cb, 1.4 * (s.vertices[cb] - s.vertices[ca]).norm(), 0.05});
  // Short ties (one and two edges), so that their Hessians vary at the
  // scale of the tested steps. Stretches at the tested states: 0.4 of the
  // distance (4 and 8 mm) plus the perturbation (about 1 mm); yield
  // stretches 50 mm and 0.05 mm.
  p.ties.push_back({4, 5, 20.0, 1.0});
  p.ties.push_back({1, 3, 20.0, 1e-3});
  s.poses.push_back(p);
  if (kind == Kind::SpatialNoTwist)
    s.effects = std::vector<Effect>{Effect::Stretch, Effect::Bend, Effect::Gravity};
  return s;
}

struct Fixture {
  Scene scene;
  std::unique_ptr<SceneModel> model;
  Design design;
  Eigen::VectorXd u, du, dp;
  const PoseSystem& sys() { return model->pose(0); }
  // The state at unknowns x: the design's rest frames as charts, full load,
  // internal variables (tie rest lengths) 0.6 of their initial values.
  PoseState at(const Eigen::VectorXd& x) {
    PoseState s = sys().withRestCharts(x, design);
    s.internal = 0.6 * sys().initialInternal();
    return s;
  }
};

std::unique_ptr<Fixture> makeFixture(Kind kind, unsigned seed) {
  auto f = std::make_unique<Fixture>();
  f->scene = (kind == Kind::Network || kind == Kind::NetworkPlanar) ? makeNetwork(kind == Kind::NetworkPlanar)
                                                                     : makeScene(kind);
  f->model = std::make_unique<SceneModel>(f->scene);
  f->design = Design::fromScene(f->scene);
  const PoseSystem& sys = f->sys();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const double h = 0.01;  // typical edge length
  // Random state: positions perturbed by up to 15% of an edge, twists up to 0.6 rad.
  f->u = sys.restDofs(f->design);
  f->du.resize(sys.numDofs());
  for (int i = 0; i < sys.numDofs(); ++i) {
    const bool theta = i >= sys.numVertexDofs();
    f->u[i] += theta ? 0.6 * U(rng) : 0.15 * h * U(rng);
    f->du[i] = theta ? 0.5 * U(rng) : 0.1 * h * U(rng);
  }
  // Design direction: rest positions by 10% of an edge, radii by 20%.
  const int nv = static_cast<int>(f->design.restPositions.size());
  f->dp.resize(f->design.numParameters());
  for (int v = 0; v < nv; ++v) {
    for (int c = 0; c < 3; ++c) f->dp[Design::restIndex(v, c)] = 0.1 * h * U(rng);
    for (int c = 0; c < 2; ++c) f->dp[f->design.radiusIndex(v, c)] = 0.2 * f->design.radii[v][c] * U(rng);
  }
  return f;
}

// Dense copy of a pattern-stored block; a lower-triangle block is mirrored.
Eigen::MatrixXd dense(const Eigen::SparseMatrix<double>& m, bool symmetricLower) {
  Eigen::MatrixXd M(m);
  if (symmetricLower) {
    const Eigen::MatrixXd L = M.triangularView<Eigen::StrictlyLower>();
    M += L.transpose();
  }
  return M;
}

// The joint Hessian over (u, p) as one dense symmetric matrix.
Eigen::MatrixXd jointHessian(const JointDerivatives& j, int n, int P) {
  Eigen::MatrixXd H(n + P, n + P);
  const Eigen::MatrixXd Hup = dense(j.Hup, false);
  H.topLeftCorner(n, n) = dense(j.Huu, false);
  H.topRightCorner(n, P) = Hup;
  H.bottomLeftCorner(P, n) = Hup.transpose();
  H.bottomRightCorner(P, P) = dense(j.Hpp, true);
  return H;
}

Eigen::VectorXd flatten(const Eigen::MatrixXd& M) { return Eigen::Map<const Eigen::VectorXd>(M.data(), M.size()); }

// A scene kind and one kind of term (-1: all terms together).
struct Case {
  Kind kind;
  int termIndex = -1;
  Terms terms() const { return termIndex < 0 ? Terms::All : Terms::only(termIndex); }
  TermKind term() const { return termIndex < 0 ? TermKind{"all", false, false, true} : PoseSystem::termKinds()[termIndex]; }
};

std::string caseName(const testing::TestParamInfo<Case>& info) {
  std::string k = std::string(kindName(info.param.kind)) + "_" + info.param.term().name;
  for (char& c : k)
    if (c == '-') c = '_';
  return k;
}

class TermDerivatives : public testing::TestWithParam<Case> {};

constexpr double kMinOrder = 1.85;

TEST_P(TermDerivatives, GradientAndHessian) {
  const Case c = GetParam();
  auto f = makeFixture(c.kind, 7);
  const PoseSystem& sys = f->sys();
  const Design& d = f->design;
  Eigen::VectorXd g;
  Eigen::SparseMatrix<double> Hs;
  const double E = sys.evaluate(f->at(f->u), d, &g, &Hs, c.terms());
  const Eigen::MatrixXd H = Eigen::MatrixXd(Hs).selfadjointView<Eigen::Lower>();

  auto energy = [&](const Eigen::VectorXd& u) { return sys.energy(f->at(u), d, c.terms()); };
  auto gradient = [&](const Eigen::VectorXd& u) {
    Eigen::VectorXd gg;
    sys.evaluate(f->at(u), d, &gg, nullptr, c.terms());
    return gg;
  };
  EXPECT_NEAR(energy(f->u), E, 1e-12 * std::abs(E) + 1e-300);
  const auto rg = taylorTestScalar(energy, f->u, f->du, g.dot(f->du));
  EXPECT_TAYLOR_ORDER(rg, kMinOrder) << testutil::findBadComponent(
      [&](const Eigen::VectorXd& u) { return Eigen::VectorXd::Constant(1, energy(u)); }, f->u,
      [&](int j) { return Eigen::VectorXd::Constant(1, g[j]); });

  if (c.term().linear) {
    EXPECT_EQ(H.norm(), 0.0) << "a load term linear in the positions has no Hessian";
    return;
  }
  const auto rh = taylorTest(gradient, f->u, f->du, H * f->du);
  EXPECT_TAYLOR_ORDER(rh, kMinOrder) << testutil::findBadComponent(gradient, f->u, [&](int j) {
    return Eigen::VectorXd(H.col(j));
  });
}

TEST_P(TermDerivatives, DesignDerivatives) {
  const Case c = GetParam();
  auto f = makeFixture(c.kind, 11);
  const PoseSystem& sys = f->sys();
  const int n = sys.numDofs(), P = f->design.numParameters();
  const PoseState state = f->at(f->u);
  const Eigen::VectorXd p0 = f->design.toVector();
  auto designOf = [&](const Eigen::VectorXd& p) {
    Design d = f->design;
    d.fromVector(p);
    return d;
  };
  const JointDerivatives j = sys.joint(state, f->design, c.terms());
  const Eigen::MatrixXd Hup = dense(j.Hup, false);
  const Eigen::MatrixXd Hpp = dense(j.Hpp, true);
  const Eigen::MatrixXd Huu = dense(j.Huu, false);
  ASSERT_EQ(Hup.rows(), n);
  ASSERT_EQ(Hup.cols(), P);
  // Huu is stored with both triangles: it must be symmetric as stored.
  EXPECT_LE((Huu - Huu.transpose()).norm(), 1e-14 * (Huu.norm() + 1e-300));

  // Both code paths (simulation and joint) agree on value, gradient, Hessian.
  Eigen::VectorXd g;
  Eigen::SparseMatrix<double> Hs;
  const double E = sys.evaluate(state, f->design, &g, &Hs, c.terms());
  EXPECT_NEAR(j.energy, E, 1e-12 * std::abs(E) + 1e-300);
  EXPECT_LE((j.gu - g).norm(), 1e-12 * (g.norm() + 1e-300));
  const Eigen::MatrixXd Hsim = Eigen::MatrixXd(Hs).selfadjointView<Eigen::Lower>();
  EXPECT_LE((Huu - Hsim).norm(), 1e-12 * (Hsim.norm() + 1e-300));

  // The first-order product (dF/dp)^T lambda and (dF/du) lambda match the
  // Hessian blocks.
  Eigen::VectorXd Hl;
  const Eigen::VectorXd prod = sys.designForceProduct(state, f->design, f->du, &Hl, c.terms());
  EXPECT_LE((prod - Hup.transpose() * f->du).norm(), 1e-10 * ((Hup.transpose() * f->du).norm() + 1e-300));
  EXPECT_LE((Hl - Huu * f->du).norm(), 1e-10 * ((Huu * f->du).norm() + 1e-300));
  if (!c.term().design) {
    // Point loads, moments and contacts do not depend on the design, except
    // through the positions of held vertices, which follow the rest shape.
    EXPECT_EQ(Hup.norm(), 0.0) << c.term().name << " does not couple unknowns and design";
    return;  // none acts on a held vertex here: dE/dp = 0, nothing more to check
  }
  // dE/dp.
  auto energyP = [&](const Eigen::VectorXd& p) { return sys.energy(state, designOf(p), c.terms()); };
  EXPECT_TAYLOR_ORDER(taylorTestScalar(energyP, p0, f->dp, j.gp.dot(f->dp)), kMinOrder);
  // d(grad_u E)/dp = H_up.
  auto gradU = [&](const Eigen::VectorXd& p) {
    Eigen::VectorXd gg;
    sys.evaluate(state, designOf(p), &gg, nullptr, c.terms());
    return gg;
  };
  EXPECT_TAYLOR_ORDER(taylorTest(gradU, p0, f->dp, Hup * f->dp), kMinOrder);
  // d(grad_p E)/dp = H_pp and d(grad_p E)/du = H_up^T.
  auto gradP = [&](const Eigen::VectorXd& p) { return sys.joint(state, designOf(p), c.terms()).gp; };
  EXPECT_TAYLOR_ORDER(taylorTest(gradP, p0, f->dp, Hpp * f->dp), kMinOrder);
  auto gradPu = [&](const Eigen::VectorXd& u) { return sys.joint(f->at(u), f->design, c.terms()).gp; };
  EXPECT_TAYLOR_ORDER(taylorTest(gradPu, f->u, f->du, Hup.transpose() * f->du), kMinOrder);
}

TEST_P(TermDerivatives, ThirdOrderDirectional) {
  const Case c = GetParam();
  auto f = makeFixture(c.kind, 13);
  const PoseSystem& sys = f->sys();
  const int n = sys.numDofs(), P = f->design.numParameters();
  const Eigen::VectorXd& v = f->du;
  const JointDerivatives j = sys.joint(f->at(f->u), f->design, c.terms());
  const JointDerivatives dj = sys.jointDirectional(f->at(f->u), f->design, v, c.terms());
  // D_v of the energy and of the gradient are the gradient and Hessian along v.
  EXPECT_NEAR(dj.energy, j.gu.dot(v), 1e-11 * (std::abs(j.gu.dot(v)) + j.gu.norm() * v.norm()));
  const Eigen::MatrixXd H = jointHessian(j, n, P);
  Eigen::VectorXd vj = Eigen::VectorXd::Zero(n + P);
  vj.head(n) = v;
  const Eigen::VectorXd Hv = H * vj;
  EXPECT_LE((dj.gu - Hv.head(n)).norm(), 1e-10 * (Hv.norm() + 1e-300));
  EXPECT_LE((dj.gp - Hv.tail(P)).norm(), 1e-10 * (Hv.norm() + 1e-300));
  // D_v of the joint Hessian against the Taylor remainder of the Hessian.
  const Eigen::VectorXd dH = flatten(jointHessian(dj, n, P));
  if (c.term().linear && !c.term().design) {
    EXPECT_EQ(dH.norm(), 0.0) << c.term().name << " is linear and design-free: its third derivatives vanish";
    return;
  }
  auto hessOf = [&](const Eigen::VectorXd& u) {
    return flatten(jointHessian(sys.joint(f->at(u), f->design, c.terms()), n, P));
  };
  EXPECT_TAYLOR_ORDER(taylorTest(hessOf, f->u, v, dH), kMinOrder);
}

constexpr Kind kAllKinds[] = {Kind::Spatial, Kind::Planar, Kind::SpatialNoTwist, Kind::Network, Kind::NetworkPlanar};

// Every scene kind with all terms, and with each registered kind of term it
// has elements of.
std::vector<Case> allCases() {
  std::vector<Case> cs;
  for (Kind k : kAllKinds) {
    cs.push_back({k, -1});
    auto f = makeFixture(k, 1);
    for (int t = 0; t < static_cast<int>(PoseSystem::termKinds().size()); ++t)
      if (f->sys().termCount(t) > 0) cs.push_back({k, t});
  }
  return cs;
}

INSTANTIATE_TEST_SUITE_P(AllTerms, TermDerivatives, testing::ValuesIn(allCases()), caseName);

// The helper itself: a wrong derivative must be caught (first-order remainder).
TEST(TaylorHelper, DetectsWrongDerivative) {
  auto f = makeFixture(Kind::Spatial, 3);
  const PoseSystem& sys = f->sys();
  Eigen::VectorXd g;
  sys.evaluate(f->at(f->u), f->design, &g, nullptr);
  auto energy = [&](const Eigen::VectorXd& u) { return sys.energy(f->at(u), f->design); };
  const auto good = taylorTestScalar(energy, f->u, f->du, g.dot(f->du));
  const auto bad = taylorTestScalar(energy, f->u, f->du, 1.01 * g.dot(f->du));
  EXPECT_GE(good.order, kMinOrder);
  EXPECT_LT(bad.order, 1.2) << bad.table();
}

// Every registered kind of term has elements in some test scene (so that
// the cases above test it), and the scenes have the layouts they are meant to.
TEST(TermDerivatives, ScenesExerciseEveryTerm) {
  const std::vector<TermKind>& kinds = PoseSystem::termKinds();
  std::vector<int> total(kinds.size(), 0);
  for (Kind k : kAllKinds) {
    auto f = makeFixture(k, 1);
    for (std::size_t t = 0; t < kinds.size(); ++t) total[t] += f->sys().termCount(static_cast<int>(t));
  }
  for (std::size_t t = 0; t < kinds.size(); ++t) EXPECT_GT(total[t], 0) << kinds[t].name << " is tested nowhere";
  EXPECT_EQ(makeFixture(Kind::Network, 1)->sys().termCount(PoseSystem::termKindIndex("connection")), 2);
  EXPECT_EQ(makeFixture(Kind::Spatial, 1)->sys().termCount(PoseSystem::termKindIndex("moment")), 1);
  // The ties are in the regimes the scene says: at a tested state the
  // update rule leaves the first (elastic) and moves the second (plastic).
  for (Kind k : {Kind::Spatial, Kind::Planar}) {
    auto t = makeFixture(k, 1);
    const PoseState st = t->at(t->u);
    const std::optional<PoseState> next = t->sys().advancedInternal(st, t->design);
    ASSERT_TRUE(next.has_value()) << kindName(k);
    EXPECT_EQ(next->internal[0], st.internal[0]) << kindName(k);
    EXPECT_GT(std::abs(next->internal[1] - st.internal[1]), 1e-3) << kindName(k);
  }
  auto f = makeFixture(Kind::Spatial, 1);
  EXPECT_TRUE(f->sys().hasTwist());
  auto p = makeFixture(Kind::Planar, 1);
  EXPECT_EQ(p->sys().dofsPerVertex(), 2);
  EXPECT_FALSE(p->sys().hasTwist());
  auto netp = makeFixture(Kind::NetworkPlanar, 1);
  EXPECT_EQ(netp->sys().dofsPerVertex(), 2);
  auto q = makeFixture(Kind::SpatialNoTwist, 1);
  EXPECT_EQ(q->sys().dofsPerVertex(), 3);
  EXPECT_FALSE(q->sys().hasTwist());
}

// Names, filters and the split of the energy by kind.
TEST(TermDerivatives, KindsAreNamedAndSumToTheEnergy) {
  const std::vector<TermKind>& kinds = PoseSystem::termKinds();
  for (std::size_t t = 0; t < kinds.size(); ++t) {
    EXPECT_EQ(PoseSystem::termKindIndex(kinds[t].name), static_cast<int>(t));
    EXPECT_TRUE(Terms::named(kinds[t].name) == Terms::only(static_cast<int>(t)));
    for (std::size_t u = 0; u < t; ++u) EXPECT_STRNE(kinds[t].name, kinds[u].name);
  }
  EXPECT_THROW(Terms::named("friction"), std::invalid_argument);
  EXPECT_EQ(PoseSystem::termKindIndex("friction"), -1);
  EXPECT_TRUE(Terms::loads().has(PoseSystem::termKindIndex("gravity")));
  EXPECT_TRUE(Terms::loads().has(PoseSystem::termKindIndex("point_force")));
  EXPECT_FALSE(Terms::loads().has(PoseSystem::termKindIndex("stretch")));
  for (Kind k : kAllKinds) {
    auto f = makeFixture(k, 5);
    const PoseState st = f->at(f->u);
    Eigen::VectorXd g, gk;
    const double E = f->sys().evaluate(st, f->design, &g, nullptr);
    double sum = 0.0;
    Eigen::VectorXd gsum = Eigen::VectorXd::Zero(g.size());
    for (std::size_t t = 0; t < kinds.size(); ++t) {
      sum += f->sys().evaluate(st, f->design, &gk, nullptr, Terms::only(static_cast<int>(t)));
      gsum += gk;
    }
    EXPECT_NEAR(sum, E, 1e-12 * std::abs(E)) << kindName(k);
    EXPECT_LE((gsum - g).norm(), 1e-12 * g.norm()) << kindName(k);
  }
}

}  // namespace
}  // namespace rodmesh
