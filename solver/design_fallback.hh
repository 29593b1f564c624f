// Which design `rodmesh optimize` archives (docs/formats.md §4,
// "Outcome"): every archived pose must be an equilibrium re-solved from
// scratch (Newton from the rest state) under the archived design, so that
// `rodmesh simulate` on a scene carrying the archived rest positions and
// radii reproduces it. The optimizers reach their equilibria by continuation
// (warm starts across small design changes, or Ipopt's iterates polished by
// Newton), so their final design may sit on a branch that load stepping from
// rest does not reach. Both optimizers therefore keep a short list of earlier
// accepted designs (control values only); when a pose of the final design
// cannot be re-solved from rest, chooseArchivedDesign tries them from the
// best objective to the worst, the initial design last, and archives the
// first whose every pose re-solves (docs/optimization.md, "After the
// optimizer").
#pragma once

#include <string>
#include <vector>

#include "model/design_space.hh"
#include "solver/equilibrium.hh"
#include "solver/newton.hh"

namespace rodmesh {

// An earlier design of a run, kept in case the final one cannot be re-solved
// from rest.
struct FallbackDesign {
  ControlValues controls;
  double objective = 0.0;  // f on the optimizer's own equilibria (m^2, contract §4)
  double rms = 0.0;        // m, on the same equilibria
  std::string label;       // where the run had it, e.g. "end of radii level 1 (iteration 37)"
  bool pinned = false;     // never dropped when the list is full (a design known to re-solve from rest)
};

// A bounded list of fallback designs, best objective first. When full, the
// design whose objective is closest (by ratio) to the next better one is
// dropped, so that the list spans the run's progress rather than crowding
// round its end, where the designs share the final one's branch. A pinned
// design (one the design monitor re-solved from rest: the one fallback known
// to be reachable by loading) is never dropped; pinned designs do not count
// against the capacity. Designs with a non-finite objective or controls
// equal to one already held are ignored (adding a held design pinned pins it).
class DesignFallbacks {
 public:
  explicit DesignFallbacks(int capacity = 12) : capacity_(capacity < 1 ? 1 : capacity) {}
  void add(const ControlValues& controls, double objective, double rms, const std::string& label,
           bool pinned = false);
  const std::vector<FallbackDesign>& designs() const { return designs_; }

 private:
  int capacity_;
  std::vector<FallbackDesign> designs_;
};

bool sameControls(const ControlValues& a, const ControlValues& b);

// The design to archive, with every pose re-solved from rest under it.
struct ArchivedDesign {
  ControlValues controls;
  Design design;
  SimulationResult simulation;  // simulateAll under `design`, as `rodmesh simulate` solves
  bool allConverged = false;    // every pose of `simulation` converged
  bool fallback = false;        // an earlier design replaces the final one
  std::string label;            // "the final design", or the fallback's label
  double optimizerRms = 0.0;    // m, this design's RMS on the optimizer's equilibria
  double rms = 0.0;             // m, on `simulation` (contract §3)
  // Empty when the final design re-solved from rest; otherwise what happened,
  // with numbers, for the archive's message and stderr.
  std::string note;
  // The final design re-solved from rest along the loading path, but some
  // pose's equilibrium there lies farther than `gapTolerance` from the
  // optimizer's own (`gap`, m, the largest over poses and vertices): the
  // optimizer designed an equilibrium the loaded object does not reach.
  bool offPath = false;
  double gap = 0.0, gapTolerance = 0.0;
  // The scene was inferred planar and optimized in plane, but an in-plane
  // equilibrium of the archived design is unstable out of plane: as
  // `rodmesh simulate` does, every pose was solved again in 3D with twist,
  // and `simulation` holds those equilibria (not the optimizer's).
  bool outOfPlane = false;
  // The scene gives no normals, so they were derived from its rest shape and
  // kept while the rest shape was optimized; `rodmesh simulate` derives them
  // from the archived rest shape instead: every pose was solved again with
  // those, and `simulation` holds these equilibria (`normalsGap`, m, the
  // largest distance to the ones under the scene's normals).
  bool renormalized = false;
  double normalsGap = 0.0;
};

// The loading-path equilibria of a design are "the ones the optimizer
// designed" when no vertex of any pose lies farther than this from the
// optimizer's own: a tenth of the optimizer's RMS error (what the design
// claims to achieve), and never below 1e-6 of the structure's size (the
// solvers' tolerances).
double designedEquilibriumTolerance(double optimizerRms, double structureSize);

struct DesignOptimizerResult;

// Re-solves every pose from rest under the final design of `result`, along
// the loading path (solver/newton.hh); when the re-solved equilibria are not
// the optimizer's (designedEquilibriumTolerance), the design is marked
// offPath and earlier designs (result.fallbacks, best objective first) are
// re-solved too: the first whose RMS from rest is lower than the final
// design's from rest is archived instead. When a pose does not converge,
// tries result.fallbacks from the best objective to
// the worst and then the initial design, and returns the first whose every
// pose converges (a fallback other than the initial design must also be no
// worse, re-solved from rest, than the initial design was on the optimizer's
// equilibria). When none does, the final design with its unconverged poses.
// `newton`: the options of `rodmesh simulate`'s Newton solve (the defaults
// unless the caller changes both); `threads`: poses solved in parallel.
ArchivedDesign chooseArchivedDesign(const SceneModel& model, const DesignSpace& space, const DesignOptimizerResult& result,
                                    const NewtonOptions& newton, int threads = 1);

}  // namespace rodmesh
