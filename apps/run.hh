// The work of `rodmesh simulate` and `rodmesh optimize` without the command
// line: option structs, their checks, and runs that return the archive the
// CLI writes. apps/cmd_*.cc map flags onto these; the Python module
// (python/) maps keyword arguments onto them, so both share one code path.
#pragma once

#include "io/archive.hh"
#include "model/design_space.hh"
#include "model/scene.hh"
#include "solver/design_optimizer.hh"
#include "solver/dynamics.hh"
#include "solver/equilibrium.hh"
#include "solver/newton.hh"
#include "solver/relaxation.hh"

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace rodmesh::cli {

// The version string stored in archives.
const char* versionString();

// Serves large blocks from the heap and keeps freed memory there
// (apps/heap_policy.cc): `rodmesh` applies it at start, Python scripts through
// rodmesh.keep_large_blocks_on_heap(). Process-wide. Returns whether it took
// effect (glibc only; false elsewhere and where mallopt refuses).
bool keepLargeBlocksOnHeap();

// ---- simulate (apps/run_simulate.cc)

struct SimulateOptions {
  std::string scene;
  std::string output;
  std::string staticSolver = "newton";
  NewtonOptions newton;
  RelaxationOptions relaxation;
  bool dynamic = false;
  double duration = 0.0;
  double fps = 30.0;
  std::optional<double> ramp;  // s; default: see rampFor
  double timeLimit = 0.0;      // s per pose; 0: none
  DynamicsOptions dynamics;
};

// Applies the flags' interplay (--tol and --max-iter reach the relaxation and
// dynamic solvers, --time-limit every solver) and checks every value; throws
// InputError with the CLI's message. `given(flag)`: whether the flag (e.g.
// "--max-iter") was given.
void resolveSimulateOptions(SimulateOptions& o, const std::function<bool(const char*)>& given);

// Solves every pose of `scene` (options resolved) and returns the archive
// `rodmesh simulate` writes; progress lines on stderr unless `quiet`.
Archive runSimulate(const Scene& scene, const SimulateOptions& o, bool quiet);

// ---- optimize (apps/run_optimize.cc)

// The default of `optimize --threads`: the machine's hardware threads
// (std::thread::hardware_concurrency, at least 1). Poses are solved in
// parallel on fixed slots, so the result does not depend on the count; the
// design monitor's thread (solver/design_monitor.hh) runs beside them.
int defaultOptimizeThreads();

struct OptimizeOptions {
  OptimizeOptions() { optimizer.threads = defaultOptimizeThreads(); }
  std::string scene;
  std::string output;
  std::string method;  // sand (default when built) or reduced
  std::string schedule;  // default: levels for sand, paper for reduced (docs/optimization.md)
  std::string designDerivatives;  // exact (default), fd or fd-resolve; --method reduced only
  std::vector<std::string> ipopt;
  bool noImperfectionBackOff = false;  // --no-imperfection-back-off (sets optimizer.imperfectionBackOff)
  bool sceneStart = false;             // --scene-start (clears optimizer.startFromTargets)
  double heartbeat = 10.0;             // --heartbeat: s without a progress line before saying what the run does
  DesignOptimizerOptions optimizer;
};

// Fills the defaults that depend on the method (method, schedule) and checks
// every option; throws InputError with the CLI's message.
void checkOptimizeOptions(OptimizeOptions& o);

struct OptimizeRun {
  Archive archive;          // what `rodmesh optimize` writes
  std::optional<double> initialRms;  // m, RMS error of the initial design; unset when it was not solved
};

// Runs the optimizer (options checked), re-solves every pose from rest under
// the design it returns (or the best earlier one that re-solves) and builds
// the archive. `progress` is called once per iteration on the calling thread;
// o.optimizer.stopRequested stops the run with the best design kept.
OptimizeRun runOptimize(const Scene& scene, const SceneModel& model, const DesignSpace& space, OptimizeOptions& o,
                        const DesignProgress& progress, bool quiet);

}  // namespace rodmesh::cli
