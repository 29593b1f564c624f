// restFrameOf (model/energies/rod_math.hh): the rest frame of an edge from
// its reference normal is undefined where the normal lies along the edge.
// Within limits::kNormalAlongEdgeSine of that (where the scene reader
// refuses a normal) it comes out NaN, value and derivatives, so that a
// designed rest shape turning an edge onto its normal is a failed
// evaluation; just outside it the frame is orthonormal and finite.
#include "model/energies/rod_math.hh"
#include "model/limits.hh"

#include <gtest/gtest.h>

#include <cmath>

namespace rodmesh {
namespace {

using H = ad::Hess<3>;

// An edge at angle asin(sine) from the normal z, in the x-z plane, seeded as
// the three variables of a Hess.
V3<H> edgeAt(double sine) {
  const double c = std::sqrt(1.0 - sine * sine);
  return {H::variable(0.02 * sine, 0), H::variable(0.0, 1), H::variable(0.02 * c, 2)};
}

bool allFinite(const H& h) {
  if (!std::isfinite(h.v)) return false;
  for (double g : h.g)
    if (!std::isfinite(g)) return false;
  for (double e : h.h)
    if (!std::isfinite(e)) return false;
  return true;
}

TEST(RestFrame, UndefinedWithinTheReadersSineOfTheNormal) {
  const Eigen::Vector3d n(0.0, 0.0, 1.0);
  const double s = limits::kNormalAlongEdgeSine;
  for (const double sine : {2.0 * s, 1.01 * s, 1e-2, 0.5}) {
    const FrameT<H> f = restFrameOf(edgeAt(sine), n);
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(allFinite(f.d1[k]) && allFinite(f.d2[k])) << "sine " << sine;
    EXPECT_NEAR(dot(f.d1, f.d1).v, 1.0, 1e-9) << "sine " << sine;
    EXPECT_NEAR(dot(f.d1, f.d2).v, 0.0, 1e-9) << "sine " << sine;
    EXPECT_NEAR(dot(f.d2, f.t).v, 0.0, 1e-9) << "sine " << sine;
  }
  for (const double sine : {0.99 * s, 1e-6, 0.0}) {
    const FrameT<H> f = restFrameOf(edgeAt(sine), n);
    EXPECT_TRUE(std::isnan(f.d2.x.v) && std::isnan(f.d1.y.v) && std::isnan(f.t.z.v)) << "sine " << sine;
    const FrameT<double> g = restFrameOf(V3<double>(0.02 * sine, 0.0, 0.02), n);
    EXPECT_TRUE(std::isnan(g.d2.x)) << "sine " << sine;
  }
}

}  // namespace
}  // namespace rodmesh
