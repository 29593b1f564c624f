// rodmesh simulate SCENE.json -o OUT.h5: static equilibrium of every pose
// (Newton, or dynamic relaxation with --static-solver relaxation), or with
// --dynamic --duration T [--fps F] a backward-Euler dynamic simulation of
// every pose from rest, stored as frames (/frames/NAME/positions T x V x 3,
// /frames/NAME/time) with the last frame also in /poses/NAME/positions.
#include <iostream>
#include <memory>

#include "apps/cli_common.hh"
#include "apps/commands.hh"
#include "apps/flag_checks.hh"
#include "apps/run.hh"

namespace rodmesh::cli {

Command registerSimulate(CLI::App& root, const GlobalOptions& global) {
  auto opts = std::make_shared<SimulateOptions>();
  CLI::App* app = root.add_subcommand(
      "simulate", "static equilibrium of every pose of a scene, or with --dynamic its motion from rest");
  app->add_option("scene", opts->scene, "scene file (rodmesh-scene/1 JSON)")->required();
  app->add_option("-o,--output", opts->output, "result archive (HDF5)")->required();
  app->add_option("--static-solver", opts->staticSolver,
                  "newton (default) or relaxation (dynamic relaxation with kinetic damping, the paper's solver)")
      ->check(CLI::IsMember({"newton", "relaxation"}))
      ->capture_default_str();
  app->add_option("--tol", opts->newton.tolerance,
                  "force residual tolerance, relative to the load scale; a static solve also brings its Newton correction within tol x the structure's size (with --dynamic, per time step)")
      ->check(realNumberIn(kSimulateTolRange))
      ->capture_default_str();
  app->add_option(
         "--max-iter", opts->newton.maxIterations,
         "Newton iterations per load step (relaxation: iterations; --dynamic: Newton iterations per time step)")
      ->check(wholeNumberIn(1, kMaxSimulateIterations))
      ->capture_default_str();
  app->add_option("--time-limit", opts->timeLimit,
                  "wall-clock seconds per pose, after which the solve stops with what it reached (default: none)")
      ->check(realNumberIn(kPositiveSecondsRange));
  app->add_flag("--dynamic", opts->dynamic, "simulate the motion from rest (backward Euler, adaptive steps)");
  app->add_option("--duration", opts->duration, "simulated time in seconds (--dynamic)")
      ->check(realNumberIn(kDurationRange));
  app->add_option("--fps", opts->fps, "frames stored per second, t = 0 included (--dynamic)")
      ->check(realNumberIn(kFpsRange))
      ->capture_default_str();
  app->add_option("--max-step", opts->dynamics.maxStep, "largest time step in seconds (--dynamic)")
      ->check(realNumberIn(kPositiveSecondsRange))
      ->capture_default_str();
  app->add_option("--ramp", opts->ramp,
                  "seconds over which loads and prescribed positions of held vertices grow from zero (--dynamic; "
                  "default 0, or a tenth of the duration when a held vertex is prescribed away from rest)")
      ->check(realNumberIn(kSecondsRange));

  Command c;
  c.app = app;
  c.run = [opts, app, &global]() -> int {
    SimulateOptions& o = *opts;
    resolveSimulateOptions(o, [&](const char* flag) { return app->count(flag) > 0; });
    checkOutputPath(o.output, "-o", {o.scene});
    const Scene scene = readSceneFile(o.scene);
    const bool quiet = global.quiet;
    if (!quiet)
      for (const std::string& w : lastSceneWarnings()) std::cerr << "warning: " << w << "\n";
    Archive a = runSimulate(scene, o, quiet);
    const bool allOk = a.status == "converged";
    writeArchive(a, o.output);
    if (!quiet) std::cerr << "wrote " << o.output << " (" << a.status << ")\n";
    return allOk ? kExitDone : kExitNotConverged;
  };
  return c;
}

}  // namespace rodmesh::cli