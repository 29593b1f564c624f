// SAND keeps its phase designs (and the iterates of its BFGS start) as fallbacks (solver/design_fallback.hh), and
// the design chosen for the archive re-solves from rest, in a run whose final
// design cannot be (testutil::fallbackCase: the thin design the targets call
// for is out of reach from rest under its Newton budget).
#include <gtest/gtest.h>

#include <cmath>

#include "model/design_space.hh"
#include "nlp/sand.hh"
#include "solver/design_fallback.hh"
#include "tests/testutil/design_problems.hh"

namespace rodmesh {
namespace {

TEST(SandFallback, KeepsItsPhaseDesignsAndArchivesOneThatResolvesFromRest) {
  const Scene s = testutil::fallbackCase();
  SceneModel model(s);
  const DesignSpace space(s, model.effects());
  SandOptions o;
  o.readOptionsFile = false;
  o.optimizer.maxIterations = 200;
  o.optimizer.newton = testutil::fallbackCaseNewton();
  const DesignOptimizerResult r = optimizeSand(model, space, o);
  SCOPED_TRACE(r.message);
  ASSERT_FALSE(r.fallbacks.empty());
  for (std::size_t i = 0; i < r.fallbacks.size(); ++i) {
    // Phase ends, and the BFGS iterates that start the first phase
    // (equilibria; SandOptions::warmupIterations).
    const std::string& label = r.fallbacks[i].label;
    const std::size_t at = label.find("radii level 0, iteration ");
    const bool warmup = at != std::string::npos && std::stoi(label.substr(at + 25)) <= o.warmupIterations;
    EXPECT_TRUE(label.find("kept at the end of") != std::string::npos || warmup) << label;
    EXPECT_TRUE(std::isfinite(r.fallbacks[i].objective));
    if (i > 0) {
      EXPECT_LE(r.fallbacks[i - 1].objective, r.fallbacks[i].objective) << "best first";
    }
  }
  const ArchivedDesign a = chooseArchivedDesign(model, space, r, o.optimizer.newton);
  SCOPED_TRACE(a.note);
  // SAND meets the targets, whose design (0.6 times the radii) is out of the
  // reach of a solve from rest with this budget: a fallback is archived.
  EXPECT_LT(r.rms, 0.01 * r.initialRms);
  EXPECT_TRUE(a.fallback);
  ASSERT_TRUE(a.allConverged);
  EXPECT_LE(a.rms, r.initialRms * (1 + 1e-9));
  EXPECT_NE(a.note.find(a.label), std::string::npos);
}

}  // namespace
}  // namespace rodmesh
