// rodmesh simulate SCENE.json -o OUT.h5: static equilibrium of every pose.
#include "apps/cli_common.hh"
#include "apps/commands.hh"
#include "solver/equilibrium.hh"

#include <cstdio>
#include <iostream>
#include <memory>

namespace rodmesh::cli {

namespace {
struct SimulateOptions {
  std::string scene;
  std::string output;
  NewtonOptions newton;
};
}  // namespace

Command registerSimulate(CLI::App& root, const GlobalOptions& global) {
  auto opts = std::make_shared<SimulateOptions>();
  CLI::App* app = root.add_subcommand("simulate", "static equilibrium of every pose of a scene");
  app->add_option("scene", opts->scene, "scene file (rodmesh-scene/1 JSON)")->required();
  app->add_option("-o,--output", opts->output, "result archive (HDF5)")->required();
  app->add_option("--tol", opts->newton.tolerance, "force residual tolerance, relative to the load scale")
      ->capture_default_str();
  app->add_option("--max-iter", opts->newton.maxIterations, "Newton iterations per load step")->capture_default_str();

  Command c;
  c.app = app;
  c.run = [opts, &global]() -> int {
    if (std::string why = opts->newton.isValid(); !why.empty()) throw InputError("simulate: " + why);
    checkOutputPath(opts->output, "-o");
    const Scene scene = readSceneFile(opts->scene);
    const bool quiet = global.quiet;
    if (!quiet)
      for (const std::string& w : lastSceneWarnings()) std::cerr << "warning: " << w << "\n";
    SceneModel model(scene);
    const Design design = Design::fromScene(scene);
    if (!quiet) printEffects(model.effects(), model.network(), model.pose(0).numDofs());

    auto progress = [&](int p, const PoseResult& r) {
      if (quiet) return;
      char line[512];
      std::snprintf(line, sizeof line, "pose %d '%s': %s, %d Newton iterations, %d load steps, residual %.3e N (%.1e relative), %s",
                    p, r.name.c_str(), r.report.converged ? "converged" : "NOT converged", r.report.iterations,
                    r.report.loadSteps, r.report.residualNorm, r.report.relativeResidual,
                    formatSeconds(r.report.timeSeconds).c_str());
      std::cerr << line;
      if (r.rmsError) std::fprintf(stderr, ", RMS error to target %.4f mm", *r.rmsError * 1e3);
      std::cerr << "\n";
      if (!r.report.converged) std::cerr << "  reason: " << r.report.message << "\n";
    };
    const SimulationResult res = simulateAll(model, design, opts->newton, progress);

    Archive a;
    a.version = versionString();
    a.command = "simulate";
    a.status = res.allConverged ? "converged" : "not_converged";
    a.sceneJson = scene.sourceText;
    describeModel(a, model.network(), model.effects(), res.dofsPerPose);
    const int nv = model.network().numVertices();
    a.restPositions.resize(nv, 3);
    a.radii.resize(nv, 2);
    for (int v = 0; v < nv; ++v) {
      a.restPositions.row(v) = design.restPositions[v].transpose();
      a.radii.row(v) = design.radii[v].transpose();
    }
    for (std::size_t p = 0; p < res.poses.size(); ++p) {
      const PoseResult& r = res.poses[p];
      ArchivePose ap;
      ap.name = r.name;
      ap.positions.resize(nv, 3);
      for (int v = 0; v < nv; ++v) ap.positions.row(v) = r.positions[v].transpose();
      if (model.effects().has(Effect::Twist)) ap.twist = r.twist;
      const auto& target = scene.poses[p].target;
      if (!target.empty()) {
        ap.target.resize(nv, 3);
        for (int v = 0; v < nv; ++v) ap.target.row(v) = target[v].transpose();
      }
      ap.residualNorm = r.report.residualNorm;
      ap.rmsError = r.rmsError;
      ap.status = r.report.converged ? "converged" : "not_converged";
      ap.iterations = r.report.iterations;
      ap.timeSeconds = r.report.timeSeconds;
      a.poses.push_back(std::move(ap));
    }
    writeArchive(a, opts->output);
    if (!quiet) std::cerr << "wrote " << opts->output << " (" << a.status << ")\n";
    return res.allConverged ? kExitDone : kExitNotConverged;
  };
  return c;
}

}  // namespace rodmesh::cli
