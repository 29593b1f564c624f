// rodmesh inspect ARCHIVE.h5: a human summary of a result archive.
#include "apps/cli_common.hh"
#include "apps/commands.hh"

#include <cstdio>
#include <iostream>
#include <memory>

namespace rodmesh::cli {

Command registerInspect(CLI::App& root, const GlobalOptions&) {
  auto path = std::make_shared<std::string>();
  CLI::App* app = root.add_subcommand("inspect", "human summary of a result archive");
  app->add_option("archive", *path, "result archive (HDF5)")->required();
  Command c;
  c.app = app;
  c.run = [path]() -> int {
    Archive a;
    try {
      a = readArchive(*path);
    } catch (const std::exception& e) {
      throw InputError(e.what());
    }
    std::printf("archive   %s\n", path->c_str());
    std::printf("format    %s (written by rodmesh %s)\n", a.format.c_str(), a.version.c_str());
    std::printf("command   %s\n", a.command.c_str());
    std::printf("status    %s\n", a.status.c_str());
    std::printf("model     %lld vertices, %lld edges, %lld rods, %lld connections, %lld unknowns per pose%s\n",
                a.nVertices, a.nEdges, a.nRods, a.nConnections, a.dofsPerPose, a.planar ? " (planar)" : "");
    std::printf("effects   %s\n", a.effects.c_str());
    if (!a.effectsReason.empty()) std::printf("          %s\n", a.effectsReason.c_str());
    if (a.radii.rows() > 0) {
      std::printf("radii     r_t %.3f..%.3f mm, r_n %.3f..%.3f mm\n", a.radii.col(0).minCoeff() * 1e3,
                  a.radii.col(0).maxCoeff() * 1e3, a.radii.col(1).minCoeff() * 1e3, a.radii.col(1).maxCoeff() * 1e3);
    }
    for (const ArchivePose& p : a.poses) {
      double maxDisp = 0.0;
      if (a.restPositions.rows() == p.positions.rows())
        maxDisp = (p.positions - a.restPositions).rowwise().norm().maxCoeff();
      std::printf("pose      %-16s %-13s residual %.3e N, max displacement %.4f mm", p.name.c_str(),
                  p.status.empty() ? "" : p.status.c_str(), p.residualNorm, maxDisp * 1e3);
      if (p.rmsError) std::printf(", RMS error %.4f mm", *p.rmsError * 1e3);
      std::printf("\n");
    }
    for (const ArchiveFrames& f : a.frames)
      std::printf("frames    %-16s %zu frames over %.3f s\n", f.name.c_str(), f.positions.size(),
                  f.time.size() ? f.time[f.time.size() - 1] : 0.0);
    if (a.history && !a.history->iteration.empty())
      std::printf("history   %zu iterations, final RMS error %.4f mm in %.2f s\n", a.history->iteration.size(),
                  a.history->rmsError.back() * 1e3, a.history->timeSeconds.back());
    return kExitDone;
  };
  return c;
}

}  // namespace rodmesh::cli
