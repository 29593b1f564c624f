// Tests of model/design_space.*: control-point counts and order, Bernstein
// interpolation weights, exact linear reproduction at every level, radius
// bounds at the vertices, exact level transitions, the affine Jacobian
// d Design::toVector() / dz (3D and planar), and the initial controls.
//
// The test network (vertex indices; lengths in metres):
//   rod 0: 0-1-2-3-4      uneven spacing, slightly curved
//   rod 1: 0-5-6          short, uneven
//   rod 2: 7-8-9-10-0     ends at the 3-rod connection at vertex 0
//   rod 3: 11-12          a lone rod with two vertices (no interior vertex)
//   rod 4: 4-13-14-6      joins the free ends of rods 0 and 1 (2-rod connections)
// Distinct rod-end vertices: {0, 4, 6, 7, 11, 12}. The planar variant is the
// same network rotated into an oblique plane; the 3D one is lifted out of it.
#include "model/design_space.hh"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "model/effects.hh"
#include "model/network.hh"

namespace rodmesh {
namespace {

constexpr int kEnds = 6;
constexpr int kRods = 5;

Scene makeNetwork(bool planar, int controlPointsPerRod) {
  Scene s;
  s.sourcePath = "<design_space>";
  s.material = Material{2e7, 0.45, 1100.0};
  const Vec3 d1 = Vec3(-0.5, std::sqrt(3.0) / 2, 0.0);
  std::vector<Vec3> p = {
      {0, 0, 0},                                                                           // 0: connection
      {0.010, 0.001, 0},   {0.040, 0.004, 0},   {0.045, 0.0045, 0},  {0.065, 0.003, 0},    // 1-4: rod 0
      0.007 * d1,          0.030 * d1,                                                     // 5-6: rod 1
      {-0.020, -0.030, 0}, {-0.012, -0.021, 0}, {-0.010, -0.016, 0}, {-0.002, -0.004, 0},  // 7-10: rod 2
      {0.10, 0.10, 0},     {0.12, 0.10, 0},                                                // 11-12: rod 3
      {0.050, 0.030, 0},   {0.010, 0.032, 0},                                              // 13-14: rod 4
  };
  if (!planar)
    for (std::size_t v = 0; v < p.size(); ++v) p[v].z() = 0.002 * ((v * 7) % 5) - 0.004;
  // Rotate into an oblique plane so that the plane basis is not the xy axes.
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized())).toRotationMatrix();
  for (Vec3& x : p) s.vertices.push_back(R * x + Vec3(0.3, -0.1, 0.05));
  s.rods = {Rod{{0, 1, 2, 3, 4}, std::nullopt}, Rod{{0, 5, 6}, std::nullopt}, Rod{{7, 8, 9, 10, 0}, std::nullopt},
            Rod{{11, 12}, std::nullopt}, Rod{{4, 13, 14, 6}, std::nullopt}};
  for (std::size_t v = 0; v < s.vertices.size(); ++v)
    s.radii.push_back(Vec2(0.0010 + 0.0002 * (v % 3), 0.0008 + 0.0001 * (v % 4)));
  Pose pose;
  pose.name = "p";
  s.poses.push_back(pose);
  s.design.present = true;
  s.design.radii = s.design.restShape = true;
  s.design.hasRadiusBounds = true;
  s.design.radiusMin = 0.0005;
  s.design.radiusMax = 0.003;
  s.design.controlPointsPerRod = controlPointsPerRod;
  return s;
}

struct Fixture {
  Scene scene;
  EffectSet fx;
  DesignSpace space;
  Fixture(bool planar, int n) : scene(makeNetwork(planar, n)), fx(effectsOf(scene)), space(scene, fx) {}
  static EffectSet effectsOf(const Scene& s) {
    RodNetwork net(s);
    return resolveEffects(s, net);
  }
};

// Arc fractions of rod r's vertices, computed here independently of DesignSpace.
std::vector<double> arcFractions(const Scene& s, int r) {
  const std::vector<int>& vs = s.rods[r].vertices;
  std::vector<double> a(vs.size(), 0.0);
  for (std::size_t i = 1; i < vs.size(); ++i) a[i] = a[i - 1] + (s.vertices[vs[i]] - s.vertices[vs[i - 1]]).norm();
  for (double& x : a) x /= a.back();
  return a;
}

Eigen::VectorXd uniform(std::mt19937& rng, const Eigen::VectorXd& lo, const Eigen::VectorXd& hi, double unbounded) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Eigen::VectorXd z(lo.size());
  for (int i = 0; i < z.size(); ++i)
    z[i] = std::isfinite(lo[i]) ? lo[i] + (hi[i] - lo[i]) * u(rng) : unbounded * (2.0 * u(rng) - 1.0);
  return z;
}

std::vector<DesignPhase> phasesAt(int level) {
  return {DesignPhase{true, false, level}, DesignPhase{false, true, level}, DesignPhase{true, true, level}};
}

TEST(DesignSpace, CountsAndOrder) {
  for (int n = 2; n <= 6; ++n) {
    SCOPED_TRACE("n = " + std::to_string(n));
    for (bool planar : {false, true}) {
      Fixture f(planar, n);
      ASSERT_EQ(f.fx.planar, planar);
      const DesignSpace& ds = f.space;
      EXPECT_EQ(ds.numSharedEnds(), kEnds);
      EXPECT_EQ(ds.numControlPoints(), kEnds + kRods * (n - 2));
      const int expectedLevels = n == 2 ? 1 : n == 3 ? 2 : 3;
      ASSERT_EQ(ds.numLevels(), expectedLevels);
      EXPECT_EQ(ds.degree(ds.numLevels() - 1), n - 1);
      EXPECT_EQ(ds.numNodes(0), kEnds);
      if (n >= 3) {
        EXPECT_EQ(ds.numNodes(1), kEnds + kRods);
      }
      EXPECT_EQ(ds.numNodes(ds.numLevels() - 1), ds.numControlPoints());
      const int dim = planar ? 2 : 3;
      for (int L = 0; L < ds.numLevels(); ++L) {
        const int N = ds.numNodes(L);
        EXPECT_EQ(ds.numFree(DesignPhase{true, false, L}), 2 * N);
        EXPECT_EQ(ds.numFree(DesignPhase{false, true, L}), dim * N);
        EXPECT_EQ(ds.numFree(DesignPhase{true, true, L}), (2 + dim) * N);
      }
      // Shared ends first, in vertex order, then interior ones rod by rod.
      const int endVertices[kEnds] = {0, 4, 6, 7, 11, 12};
      for (int e = 0; e < kEnds; ++e) {
        EXPECT_EQ(ds.controlPoints()[e].rod, -1);
        EXPECT_EQ(ds.controlPoints()[e].vertex, endVertices[e]);
        EXPECT_EQ(ds.controlPoints()[e].arcFraction, 0.0);
      }
      for (int r = 0; r < kRods; ++r)
        for (int j = 1; j <= n - 2; ++j) {
          const ControlPoint& cp = ds.controlPoints()[kEnds + r * (n - 2) + j - 1];
          EXPECT_EQ(cp.rod, r);
          EXPECT_EQ(cp.vertex, -1);
          EXPECT_DOUBLE_EQ(cp.arcFraction, double(j) / (n - 1));
          EXPECT_EQ(ds.controlIndex(r, j), kEnds + r * (n - 2) + j - 1);
        }
      // The 3-rod connection at vertex 0 has one control point.
      EXPECT_EQ(ds.controlIndex(0, 0), 0);
      EXPECT_EQ(ds.controlIndex(1, 0), 0);
      EXPECT_EQ(ds.controlIndex(2, n - 1), 0);
      EXPECT_EQ(ds.controlIndex(4, 0), ds.controlIndex(0, n - 1));
      EXPECT_EQ(ds.controlIndex(4, n - 1), ds.controlIndex(1, n - 1));
      EXPECT_FALSE(ds.describe().empty());
    }
  }
  // Hand count for the paper's n = 4, 3D, radii and rest shape at level 1:
  // (6 ends + 5 middles) x (2 radii + 3 displacement) = 55; planar 44.
  EXPECT_EQ(Fixture(false, 4).space.numFree(DesignPhase{true, true, 1}), 55);
  EXPECT_EQ(Fixture(true, 4).space.numFree(DesignPhase{true, true, 1}), 44);
  EXPECT_EQ(Fixture(false, 4).space.numFree(DesignPhase{true, false, 2}), 32);
}

TEST(DesignSpace, InterpolationWeights) {
  for (int n = 2; n <= 6; ++n) {
    SCOPED_TRACE("n = " + std::to_string(n));
    Fixture f(false, n);
    const DesignSpace& ds = f.space;
    const auto& W = ds.interpolation();
    ASSERT_EQ(W.rows(), ds.numVertices());
    ASSERT_EQ(W.cols(), ds.numControlPoints());
    std::vector<int> rodOf(ds.numVertices(), -1);
    for (int r = 0; r < kRods; ++r)
      for (std::size_t i = 1; i + 1 < f.scene.rods[r].vertices.size(); ++i) rodOf[f.scene.rods[r].vertices[i]] = r;
    for (int v = 0; v < W.rows(); ++v) {
      double sum = 0.0;
      for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(W, v); it; ++it) {
        EXPECT_GE(it.value(), 0.0) << "vertex " << v;
        sum += it.value();
        const ControlPoint& cp = ds.controlPoints()[it.col()];
        if (rodOf[v] >= 0 && cp.rod >= 0) {
          EXPECT_EQ(cp.rod, rodOf[v]) << "vertex " << v;
        }
      }
      EXPECT_NEAR(sum, 1.0, 1e-15) << "vertex " << v;
    }
    // Rod-end vertices: exactly the unit row of their shared control point.
    for (int e = 0; e < kEnds; ++e) {
      const int v = ds.controlPoints()[e].vertex;
      for (int c = 0; c < ds.numControlPoints(); ++c) EXPECT_EQ(W.coeff(v, c), c == e ? 1.0 : 0.0);
    }
    // And so random control values reach the end vertices exactly.
    std::mt19937 rng(n);
    std::uniform_real_distribution<double> u(0.001, 0.002);
    ControlValues c{Eigen::MatrixXd(ds.numControlPoints(), 2), Eigen::MatrixXd::Zero(ds.numControlPoints(), 3)};
    for (int i = 0; i < c.radii.size(); ++i) c.radii.data()[i] = u(rng);
    const Design d = ds.toDesign(c);
    for (int e = 0; e < kEnds; ++e) EXPECT_EQ(d.radii[ds.controlPoints()[e].vertex], c.radii.row(e).transpose());
  }
}

// End node values random, each rod's interior nodes on the straight line
// between its end values (a + (b - a) k / d): every vertex value must be
// a + (b - a) s with s the vertex's arc fraction, at every level.
// fitControls: a field the controls represent is reproduced by the fit;
// the residual of any other field is orthogonal to W's columns. The
// network's shorter rods have fewer interior vertices than interior control
// points (W^T W singular: the fit used to fail there), so the fitted
// controls themselves are not unique; those that reach no vertex are zero.
TEST(DesignSpace, FitControlsIsTheLeastSquaresFit) {
  Fixture f(false, 4);
  const DesignSpace& ds = f.space;
  const auto& W = ds.interpolation();
  Eigen::MatrixXd c(ds.numControlPoints(), 3);
  for (int i = 0; i < c.rows(); ++i) c.row(i) << std::sin(1.3 * i), std::cos(0.7 * i), 0.1 * i;
  Eigen::MatrixXd fit;
  ASSERT_TRUE(ds.fitControls(W * c, fit));
  EXPECT_LT((Eigen::MatrixXd(W * fit) - W * c).cwiseAbs().maxCoeff(), 1e-9);
  Eigen::MatrixXd field(ds.numVertices(), 3);
  for (int v = 0; v < field.rows(); ++v) field.row(v) << std::cos(2.1 * v), v % 3, std::sin(v);
  ASSERT_TRUE(ds.fitControls(field, fit));
  EXPECT_LT((Eigen::MatrixXd(W.transpose() * (W * fit - field))).cwiseAbs().maxCoeff(), 1e-9);
  const Eigen::SparseMatrix<double> Wt = W.transpose();
  for (int j = 0; j < Wt.outerSize(); ++j) {
    double reach = 0.0;
    for (Eigen::SparseMatrix<double>::InnerIterator it(Wt, j); it; ++it) reach += std::abs(it.value());
    if (reach == 0.0) EXPECT_EQ(fit.row(j).norm(), 0.0) << "control " << j;
  }
  EXPECT_FALSE(ds.fitControls(Eigen::MatrixXd::Zero(ds.numVertices() + 1, 3), fit));
}

TEST(DesignSpace, LinearReproductionAtEveryLevel) {
  for (int n = 2; n <= 6; ++n) {
    for (bool planar : {false, true}) {
      SCOPED_TRACE("n = " + std::to_string(n) + (planar ? " planar" : " 3D"));
      Fixture f(planar, n);
      const DesignSpace& ds = f.space;
      const int dim = planar ? 2 : 3;
      std::mt19937 rng(10 * n + planar);
      std::uniform_real_distribution<double> u(-1.0, 1.0);
      const ControlValues base = ds.initialControls(f.scene);
      for (int L = 0; L < ds.numLevels(); ++L) {
        const int N = ds.numNodes(L), d = ds.degree(L);
        Eigen::MatrixXd radii(N, 2), disp(N, dim);
        for (int e = 0; e < kEnds; ++e) {
          radii.row(e) = Eigen::RowVector2d(0.0015 + 0.0005 * u(rng), 0.0015 + 0.0005 * u(rng));
          for (int k = 0; k < dim; ++k) disp(e, k) = 0.01 * u(rng);
        }
        for (int r = 0; r < kRods; ++r)
          for (int k = 1; k < d; ++k) {
            const double t = double(k) / d;
            const int a = ds.nodeIndex(L, r, 0), b = ds.nodeIndex(L, r, d), i = ds.nodeIndex(L, r, k);
            radii.row(i) = radii.row(a) + (radii.row(b) - radii.row(a)) * t;
            disp.row(i) = disp.row(a) + (disp.row(b) - disp.row(a)) * t;
          }
        Eigen::VectorXd z(N * (2 + dim));
        for (int i = 0; i < N; ++i) {
          z.segment<2>(2 * i) = radii.row(i).transpose();
          z.segment(2 * N + dim * i, dim) = disp.row(i).transpose();
        }
        const Design des = ds.toDesign(ds.unpack(DesignPhase{true, true, L}, z, base));
        double worst = 0.0;
        for (int r = 0; r < kRods; ++r) {
          const std::vector<int>& vs = f.scene.rods[r].vertices;
          const std::vector<double> s = arcFractions(f.scene, r);
          const int a = ds.nodeIndex(L, r, 0), b = ds.nodeIndex(L, r, d);
          for (std::size_t i = 0; i < vs.size(); ++i) {
            const Eigen::RowVector2d er = radii.row(a) + (radii.row(b) - radii.row(a)) * s[i];
            Eigen::Vector3d ed = Eigen::Vector3d::Zero();
            const Eigen::RowVectorXd dl = disp.row(a) + (disp.row(b) - disp.row(a)) * s[i];
            if (planar)
              ed = f.fx.planeBasis * dl.transpose();
            else
              ed = dl.transpose();
            worst = std::max(worst, (des.radii[vs[i]] - er.transpose()).norm() / 0.002);
            worst = std::max(worst, (des.restPositions[vs[i]] - f.scene.vertices[vs[i]] - ed).norm() / 0.01);
          }
        }
        EXPECT_LE(worst, 1e-14) << "level " << L;
      }
    }
  }
}

TEST(DesignSpace, RadiusBoundsHoldAtEveryVertex) {
  for (int n = 2; n <= 6; ++n) {
    SCOPED_TRACE("n = " + std::to_string(n));
    Fixture f(false, n);
    const DesignSpace& ds = f.space;
    EXPECT_EQ(ds.radiusLower(), 0.0005);
    EXPECT_EQ(ds.radiusUpper(), 0.003);
    std::mt19937 rng(n);
    const ControlValues base = ds.initialControls(f.scene);
    for (int L = 0; L < ds.numLevels(); ++L) {
      for (const DesignPhase& ph : phasesAt(L)) {
        Eigen::VectorXd lo, hi;
        ds.bounds(ph, lo, hi);
        ASSERT_EQ(lo.size(), ds.numFree(ph));
        ASSERT_EQ(hi.size(), ds.numFree(ph));
        const int nr = ph.radii ? 2 * ds.numNodes(L) : 0;
        for (int i = 0; i < lo.size(); ++i) {
          if (i < nr) {
            EXPECT_EQ(lo[i], 0.0005);
            EXPECT_EQ(hi[i], 0.003);
          } else {
            EXPECT_EQ(lo[i], -std::numeric_limits<double>::infinity());
            EXPECT_EQ(hi[i], std::numeric_limits<double>::infinity());
          }
        }
        if (!ph.radii) continue;
        std::vector<Eigen::VectorXd> zs = {lo.cwiseMax(-1.0), hi.cwiseMin(1.0)};
        for (int trial = 0; trial < 20; ++trial) zs.push_back(uniform(rng, lo, hi, 0.01));
        for (const Eigen::VectorXd& z : zs) {
          const Design d = ds.toDesign(ds.unpack(ph, z, base));
          for (int v = 0; v < ds.numVertices(); ++v)
            for (int k = 0; k < 2; ++k) {
              // To the last digit (issue 23): no rounding below or above.
              EXPECT_GE(d.radii[v][k], 0.0005) << "level " << L << " vertex " << v;
              EXPECT_LE(d.radii[v][k], 0.003) << "level " << L << " vertex " << v;
            }
        }
      }
    }
  }
  // Without scene bounds: [0.1 x smallest, 10 x largest] initial radius component.
  Scene s = makeNetwork(false, 4);
  s.design.hasRadiusBounds = false;
  RodNetwork net(s);
  const DesignSpace ds(s, resolveEffects(s, net));
  EXPECT_DOUBLE_EQ(ds.radiusLower(), 0.1 * 0.0008);
  EXPECT_DOUBLE_EQ(ds.radiusUpper(), 10.0 * 0.0014);
  Eigen::VectorXd lo, hi;
  ds.bounds(DesignPhase{true, false, 0}, lo, hi);
  EXPECT_EQ(lo[0], ds.radiusLower());
  EXPECT_EQ(hi[0], ds.radiusUpper());
}

// Issue 23: the reduced method archived vertex radii of 0.0019999999999999996
// under a 0.002 lower bound. Controls exactly on a bound: the interpolated
// sums W * c round below or above it at some vertices (checked, so that the
// test means something), toDesign's radii do not.
TEST(DesignSpace, ControlsOnABoundGiveVertexRadiiWithinIt) {
  int roundedOutside = 0;
  for (int n : {3, 5, 7, 12}) {
    for (const double b : {0.002, 0.0005, 0.0013, 0.0029, 0.0021}) {
      for (const bool lower : {true, false}) {
        SCOPED_TRACE("n " + std::to_string(n) + (lower ? " lower " : " upper ") + std::to_string(b));
        Scene s = makeNetwork(false, n);
        s.design.radiusMin = lower ? b : 1e-5;
        s.design.radiusMax = lower ? 0.01 : b;
        for (Vec2& r : s.radii) r = Vec2(b, b);
        RodNetwork net(s);
        const DesignSpace ds(s, resolveEffects(s, net));
        ControlValues c = ds.initialControls(s);
        c.radii.setConstant(b);
        const Eigen::MatrixXd raw = ds.interpolation() * c.radii;
        roundedOutside += lower ? (raw.array() < b).count() : (raw.array() > b).count();
        const Design d = ds.toDesign(c);
        for (int v = 0; v < ds.numVertices(); ++v)
          for (int k = 0; k < 2; ++k) {
            EXPECT_GE(d.radii[v][k], s.design.radiusMin) << "vertex " << v;
            EXPECT_LE(d.radii[v][k], s.design.radiusMax) << "vertex " << v;
          }
      }
    }
  }
  EXPECT_GT(roundedOutside, 0) << "no interpolated radius rounded off its bound: the test checks nothing";
}

double maxRelDiff(const Design& a, const Design& b) {
  const Eigen::VectorXd x = a.toVector(), y = b.toVector();
  return (x - y).cwiseAbs().maxCoeff() / std::max(1e-300, y.cwiseAbs().maxCoeff());
}

TEST(DesignSpace, LevelTransitionsAreExact) {
  for (int n = 2; n <= 6; ++n) {
    for (bool planar : {false, true}) {
      SCOPED_TRACE("n = " + std::to_string(n) + (planar ? " planar" : " 3D"));
      Fixture f(planar, n);
      const DesignSpace& ds = f.space;
      std::mt19937 rng(n + 100 * planar);
      const ControlValues base = ds.initialControls(f.scene);
      const int finest = ds.numLevels() - 1;
      for (int L = 0; L <= finest; ++L) {
        const DesignPhase ph{true, true, L};
        Eigen::VectorXd lo, hi;
        ds.bounds(ph, lo, hi);
        const Eigen::VectorXd z = uniform(rng, lo, hi, 0.01);
        const ControlValues c = ds.unpack(ph, z, base);
        const Design d = ds.toDesign(c);
        // Round trip at the same level (least squares of a representable design).
        EXPECT_LE((ds.pack(ph, c) - z).cwiseAbs().maxCoeff(), 1e-14) << "level " << L;
        // The finest level holds every level's design exactly: E_finest = I.
        const Eigen::VectorXd zf = ds.pack(DesignPhase{true, true, finest}, c);
        EXPECT_LE(maxRelDiff(ds.toDesign(ds.unpack(DesignPhase{true, true, finest}, zf, base)), d), 1e-15);
        if (L == finest) continue;
        const DesignPhase next{true, true, L + 1};
        const Eigen::VectorXd z1 = ds.pack(next, c);
        EXPECT_LE(maxRelDiff(ds.toDesign(ds.unpack(next, z1, base)), d), 1e-14) << "level " << L;
        // pack agrees with the explicit elevation map on node values.
        const Eigen::SparseMatrix<double> T = ds.levelTransfer(L, L + 1);
        const int N0 = ds.numNodes(L), N1 = ds.numNodes(L + 1), dim = planar ? 2 : 3;
        ASSERT_EQ(T.rows(), N1);
        ASSERT_EQ(T.cols(), N0);
        Eigen::MatrixXd r0(N0, 2), r1(N1, 2), d0(N0, dim), d1(N1, dim);
        for (int i = 0; i < N0; ++i) {
          r0.row(i) = z.segment<2>(2 * i).transpose();
          d0.row(i) = z.segment(2 * N0 + dim * i, dim).transpose();
        }
        for (int i = 0; i < N1; ++i) {
          r1.row(i) = z1.segment<2>(2 * i).transpose();
          d1.row(i) = z1.segment(2 * N1 + dim * i, dim).transpose();
        }
        EXPECT_LE((Eigen::MatrixXd(T * r0) - r1).cwiseAbs().maxCoeff(), 1e-16);
        EXPECT_LE((Eigen::MatrixXd(T * d0) - d1).cwiseAbs().maxCoeff(), 1e-16);
        // Elevation rows are convex combinations.
        for (int i = 0; i < N1; ++i) EXPECT_NEAR(Eigen::MatrixXd(T).row(i).sum(), 1.0, 1e-15);
        EXPECT_GE(Eigen::MatrixXd(T).minCoeff(), 0.0);
      }
    }
  }
}

TEST(DesignSpace, UnpackTakesFixedPartsFromBase) {
  Fixture f(false, 4);
  const DesignSpace& ds = f.space;
  std::mt19937 rng(7);
  ControlValues base = ds.initialControls(f.scene);
  base.displacement.setRandom();
  base.displacement *= 0.001;
  for (int L = 0; L < ds.numLevels(); ++L) {
    Eigen::VectorXd lo, hi;
    const DesignPhase radiiOnly{true, false, L}, restOnly{false, true, L};
    ds.bounds(radiiOnly, lo, hi);
    const ControlValues a = ds.unpack(radiiOnly, uniform(rng, lo, hi, 0.01), base);
    EXPECT_EQ(a.displacement, base.displacement);
    EXPECT_NE(a.radii, base.radii);
    ds.bounds(restOnly, lo, hi);
    const ControlValues b = ds.unpack(restOnly, uniform(rng, lo, hi, 0.01), base);
    EXPECT_EQ(b.radii, base.radii);
    EXPECT_NE(b.displacement, base.displacement);
  }
}

// The map z -> Design::toVector() is affine, so J dz equals the difference to
// round-off for any dz, and every column equals a one-sided difference.
TEST(DesignSpace, JacobianMatchesDifferences) {
  for (int n : {2, 3, 4, 5}) {
    for (bool planar : {false, true}) {
      Fixture f(planar, n);
      const DesignSpace& ds = f.space;
      std::mt19937 rng(n + 50 * planar);
      const ControlValues base = ds.initialControls(f.scene);
      for (int L = 0; L < ds.numLevels(); ++L)
        for (const DesignPhase& ph : phasesAt(L)) {
          SCOPED_TRACE("n = " + std::to_string(n) + (planar ? " planar" : " 3D") + " level " + std::to_string(L) +
                       (ph.radii ? " radii" : "") + (ph.restShape ? " rest" : ""));
          const Eigen::SparseMatrix<double> J = ds.jacobian(ph);
          ASSERT_EQ(J.rows(), 5 * ds.numVertices());
          ASSERT_EQ(J.cols(), ds.numFree(ph));
          Eigen::VectorXd lo, hi;
          ds.bounds(ph, lo, hi);
          const Eigen::VectorXd z = uniform(rng, lo, hi, 0.01);
          const Eigen::VectorXd p0 = ds.toDesign(ds.unpack(ph, z, base)).toVector();
          const double scale = p0.cwiseAbs().maxCoeff();
          // Affine: J dz == difference.
          const Eigen::VectorXd dz = uniform(rng, lo, hi, 0.01) - z;
          const Eigen::VectorXd p1 = ds.toDesign(ds.unpack(ph, z + dz, base)).toVector();
          EXPECT_LE((J * dz - (p1 - p0)).cwiseAbs().maxCoeff(), 1e-14 * scale);
          // Columns.
          const double h = 1e-3;
          const Eigen::MatrixXd Jd(J);
          double worst = 0.0;
          int worstCol = -1;
          for (int i = 0; i < z.size(); ++i) {
            Eigen::VectorXd zi = z;
            zi[i] += h;
            const Eigen::VectorXd col = (ds.toDesign(ds.unpack(ph, zi, base)).toVector() - p0) / h;
            const double err = (col - Jd.col(i)).cwiseAbs().maxCoeff();
            if (err > worst) worst = err, worstCol = i;
          }
          // Round-off of a difference of O(scale) values divided by h.
          EXPECT_LE(worst, 2e-15 * scale / h) << "worst column " << worstCol;
          // Parts not free in the phase do not move.
          if (!ph.radii) {
            EXPECT_EQ(Jd.bottomRows(2 * ds.numVertices()).cwiseAbs().maxCoeff(), 0.0);
          }
          if (!ph.restShape) {
            EXPECT_EQ(Jd.topRows(3 * ds.numVertices()).cwiseAbs().maxCoeff(), 0.0);
          }
          // A planar rest shape stays in its plane.
          if (planar && ph.restShape) {
            const Design d = ds.toDesign(ds.unpack(ph, z, base));
            for (int v = 0; v < ds.numVertices(); ++v)
              EXPECT_NEAR((d.restPositions[v] - f.fx.planeOrigin).dot(f.fx.planeNormal), 0.0, 1e-15) << "vertex " << v;
            const Eigen::MatrixXd Jrest = Jd.topRows(3 * ds.numVertices());
            for (int v = 0; v < ds.numVertices(); ++v)
              EXPECT_LE((f.fx.planeNormal.transpose() * Jrest.middleRows(3 * v, 3)).cwiseAbs().maxCoeff(), 1e-15);
          }
        }
    }
  }
}

TEST(DesignSpace, InitialControls) {
  for (int n = 2; n <= 6; ++n) {
    SCOPED_TRACE("n = " + std::to_string(n));
    // Uniform radii: control values exactly the scene's, and vertex values
    // too (a sum of weights is 1 only to round-off, but toDesign adds the
    // weighted differences from a vertex's first control value), zero
    // displacement: the initial design is the scene's.
    Scene s = makeNetwork(false, n);
    s.radii.assign(s.vertices.size(), Vec2(0.0012, 0.0009));
    {
      RodNetwork net(s);
      const DesignSpace ds(s, resolveEffects(s, net));
      const ControlValues c = ds.initialControls(s);
      EXPECT_EQ(c.displacement, Eigen::MatrixXd::Zero(ds.numControlPoints(), 3));
      for (int i = 0; i < ds.numControlPoints(); ++i) EXPECT_EQ(c.radii.row(i), Eigen::RowVector2d(0.0012, 0.0009));
      const Design d = ds.toDesign(c);
      for (int v = 0; v < ds.numVertices(); ++v) {
        EXPECT_EQ(d.radii[v], s.radii[v]) << "vertex " << v;
        EXPECT_EQ(d.restPositions[v], s.vertices[v]) << "vertex " << v;
      }
    }
    // Radii linear in arc length along each rod: reproduced to round-off.
    for (std::size_t r = 0; r < s.rods.size(); ++r) {
      const std::vector<int>& vs = s.rods[r].vertices;
      for (int v : {vs.front(), vs.back()}) s.radii[v] = Vec2(0.001 + 0.0001 * (v % 5), 0.0008 + 0.0002 * (v % 3));
    }
    for (std::size_t r = 0; r < s.rods.size(); ++r) {
      const std::vector<int>& vs = s.rods[r].vertices;
      const std::vector<double> a = arcFractions(s, static_cast<int>(r));
      for (std::size_t i = 1; i + 1 < vs.size(); ++i)
        s.radii[vs[i]] = s.radii[vs.front()] + (s.radii[vs.back()] - s.radii[vs.front()]) * a[i];
    }
    {
      RodNetwork net(s);
      const DesignSpace ds(s, resolveEffects(s, net));
      const Design d = ds.toDesign(ds.initialControls(s));
      for (int v = 0; v < ds.numVertices(); ++v) EXPECT_LE((d.radii[v] - s.radii[v]).norm(), 1e-17) << "vertex " << v;
    }
    // General radii: end vertices exact, every vertex within its rod's range.
    Scene g = makeNetwork(false, n);
    RodNetwork net(g);
    const DesignSpace ds(g, resolveEffects(g, net));
    const Design d = ds.toDesign(ds.initialControls(g));
    for (const Rod& rod : g.rods) {
      Vec2 lo = g.radii[rod.vertices[0]], hi = lo;
      for (int v : rod.vertices) lo = lo.cwiseMin(g.radii[v]), hi = hi.cwiseMax(g.radii[v]);
      EXPECT_EQ(d.radii[rod.vertices.front()], g.radii[rod.vertices.front()]);
      EXPECT_EQ(d.radii[rod.vertices.back()], g.radii[rod.vertices.back()]);
      for (int v : rod.vertices)
        for (int k = 0; k < 2; ++k) {
          EXPECT_GE(d.radii[v][k], lo[k] * (1 - 1e-14)) << "vertex " << v;
          EXPECT_LE(d.radii[v][k], hi[k] * (1 + 1e-14)) << "vertex " << v;
        }
    }
  }
}

// A closed rod (first vertex == last vertex) has one shared end control point
// used at both ends; weights still form a partition of unity and linear
// (here: constant) values are reproduced.
TEST(DesignSpace, ClosedRod) {
  Scene s;
  s.vertices = {Vec3(0, 0, 0), Vec3(0.01, 0, 0), Vec3(0.012, 0.01, 0), Vec3(0.0, 0.008, 0)};
  s.rods = {Rod{{0, 1, 2, 3, 0}, std::nullopt}};
  s.radii.assign(4, Vec2(0.001, 0.001));
  s.design.controlPointsPerRod = 4;
  const DesignSpace ds(s, EffectSet{});
  ASSERT_EQ(ds.numControlPoints(), 3);
  EXPECT_EQ(ds.controlIndex(0, 0), ds.controlIndex(0, 3));
  const auto& W = ds.interpolation();
  for (int v = 0; v < 4; ++v) EXPECT_NEAR(Eigen::MatrixXd(W).row(v).sum(), 1.0, 1e-15);
  const DesignPhase coarse{true, false, 0};
  const ControlValues c = ds.unpack(coarse, Eigen::Vector2d(0.002, 0.003), ds.initialControls(s));
  const Design d = ds.toDesign(c);
  for (int v = 0; v < 4; ++v) EXPECT_LE((d.radii[v] - Vec2(0.002, 0.003)).norm(), 1e-18);
  const Eigen::VectorXd fine = ds.pack(DesignPhase{true, false, 2}, c);
  ASSERT_EQ(fine.size(), 6);
  for (int i = 0; i < 3; ++i) EXPECT_LE((fine.segment<2>(2 * i) - Vec2(0.002, 0.003)).norm(), 1e-18);
}

TEST(DesignSpace, RejectsBadInput) {
  Scene s = makeNetwork(false, 1);
  RodNetwork net(s);
  const EffectSet fx = resolveEffects(s, net);
  EXPECT_THROW(DesignSpace(s, fx), std::invalid_argument);
  s.design.controlPointsPerRod = 4;
  const DesignSpace ds(s, fx);
  EXPECT_THROW(ds.numNodes(3), std::out_of_range);
  EXPECT_THROW(ds.levelTransfer(2, 1), std::invalid_argument);
}

}  // namespace
}  // namespace rodmesh
