// rodmesh inspect ARCHIVE.h5: a human summary of a result archive.
#include "apps/cli_common.hh"
#include "apps/commands.hh"
#include "solver/equilibrium.hh"  // kImperfectionRadiusChange
#include "solver/newton.hh"  // kCriticalStiffnessRatio

#include <algorithm>
#include <cmath>
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
    // Every dataset and attribute checked before use (io/archive.hh); a bad
    // archive is an InputError naming the file and the dataset.
    const Archive a = loadArchive(*path).archive;
    // Text from the archive is printed with control characters (terminal
    // escapes included) shown as \xNN.
    std::printf("archive   %s\n", printableText(*path).c_str());
    std::printf("format    %s (written by rodmesh %s)\n", printableText(a.format).c_str(),
                printableText(a.version).c_str());
    std::printf("command   %s\n", printableText(a.command).c_str());
    std::printf("status    %s\n", printableText(a.status).c_str());
    if (a.optimize) {
      std::printf("optimize  method %s, %lld iterations in %s\n", printableText(a.optimize->method).c_str(),
                  a.optimize->iterations, formatSeconds(a.optimize->timeSeconds).c_str());
      if (!a.optimize->message.empty()) std::printf("          %s\n", printableText(a.optimize->message).c_str());
    }
    std::printf("model     %lld vertices, %lld edges, %lld rods, %lld connections, %lld unknowns per pose%s\n",
                a.nVertices, a.nEdges, a.nRods, a.nConnections, a.dofsPerPose, a.planar ? " (planar)" : "");
    std::printf("effects   %s\n", printableText(a.effects).c_str());
    if (!a.effectsReason.empty()) std::printf("          %s\n", printableText(a.effectsReason).c_str());
    if (a.radii.rows() > 0) {
      std::printf("radii     r_t %.3f..%.3f mm, r_n %.3f..%.3f mm\n", a.radii.col(0).minCoeff() * 1e3,
                  a.radii.col(0).maxCoeff() * 1e3, a.radii.col(1).minCoeff() * 1e3, a.radii.col(1).maxCoeff() * 1e3);
    }
    if (a.initialRadii && a.initialRadii->rows() > 0) {
      const MatX2& r = *a.initialRadii;
      std::printf("initially r_t %.3f..%.3f mm, r_n %.3f..%.3f mm\n", r.col(0).minCoeff() * 1e3,
                  r.col(0).maxCoeff() * 1e3, r.col(1).minCoeff() * 1e3, r.col(1).maxCoeff() * 1e3);
    }
    if (a.controlPoints) {
      const ArchiveControlPoints& c = *a.controlPoints;
      const long shared = std::count(c.rod.begin(), c.rod.end(), -1);
      std::printf("control   %zu points (%ld shared ends, %zu interior)%s%s\n", c.rod.size(), shared,
                  c.rod.size() - static_cast<std::size_t>(shared), c.radii.rows() ? ", radii" : "",
                  c.restDisplacement.rows() ? ", rest displacement" : "");
      if (c.radiusBounds) {
        const ArchiveControlPoints::RadiusBounds& b = *c.radiusBounds;
        std::printf("bounds    radii %.4g..%.4g mm: %lld of %zu control radius values held at a bound (%lld at the "
                    "minimum, %lld at the maximum)",
                    b.min * 1e3, b.max * 1e3, b.atMin + b.atMax, 2 * c.rod.size(), b.atMin, b.atMax);
        // The bounds that hold radii only, as the optimizer's message says
        // it (solver/bound_activity.cc); + 0.0 turns a -0 into 0.
        if (b.atMin > 0 || b.atMax > 0) {
          std::printf("; to first order the objective falls");
          if (b.atMin > 0) std::printf(" by %.2g%% per 1%% lower minimum", b.minElasticity + 0.0);
          if (b.atMax > 0) std::printf("%s by %.2g%% per 1%% higher maximum", b.atMin > 0 ? " and" : "",
                                       -b.maxElasticity + 0.0);
        }
        std::printf("\n");
      }
    }
    for (const ArchivePose& p : a.poses) {
      double maxDisp = 0.0;
      if (a.restPositions.rows() == p.positions.rows())
        maxDisp = (p.positions - a.restPositions).rowwise().norm().maxCoeff();
      std::printf("pose      %-16s %-13s residual %.3e N, max displacement %.4f mm", printableText(p.name).c_str(),
                  printableText(p.status).c_str(), p.residualNorm, maxDisp * 1e3);
      if (p.rmsError) std::printf(", RMS error %.4f mm", *p.rmsError * 1e3);
      if (p.rmsError && p.initialPositions.rows() == p.target.rows() && p.target.rows() > 0)
        std::printf(" (initially %.4f mm)",
                    std::sqrt((p.initialPositions - p.target).squaredNorm() / p.target.rows()) * 1e3);
      if (p.equilibriumGap) std::printf(", equilibrium gap %.3e mm", *p.equilibriumGap * 1e3);
      std::printf("\n");
      if (p.stable >= 0 || p.smallestEigenvalue) {
        std::printf("          %s", p.stable == 1 ? "stable" : p.stable == 0 ? "UNSTABLE" : "stability unknown");
        if (p.smallestEigenvalue) std::printf(", smallest stiffness eigenvalue %.4g N/m", *p.smallestEigenvalue);
        if (p.smallestEigenvalue && p.unloadedSmallestEigenvalue && *p.unloadedSmallestEigenvalue > 0) {
          // Only the critical case is worth the comparison (a structure
          // that is a mechanism at rest has no stiffness to compare with).
          const double ratio = *p.smallestEigenvalue / *p.unloadedSmallestEigenvalue;
          if (p.stable == 1 && ratio <= kCriticalStiffnessRatio)
            std::printf(" (%.2g of the unloaded structure's): at a critical point, a little more load or a small "
                        "imperfection makes it snap or buckle",
                        ratio);
        }
        std::printf("\n");
      }
      if (p.imperfectionSensitive >= 0) {
        std::printf("          radii changed by %.2g%%: ", 100 * kImperfectionRadiusChange);
        if (p.imperfectionGap) std::printf("equilibrium moves up to %.4f mm", *p.imperfectionGap * 1e3);
        else std::printf("no equilibrium reached");
        std::printf("%s\n", p.imperfectionSensitive == 1
                                ? ": IMPERFECTION-SENSITIVE, a printed object may reach another equilibrium"
                                : "");
      }
      for (Eigen::Index k = 0; k < p.criticalPoints.rows(); ++k)
        std::printf("          critical point at load factor %.4g (eigenvalue %.3g N/m), jumped %.4f mm\n",
                    p.criticalPoints(k, 0), p.criticalPoints(k, 1), p.criticalPoints(k, 2) * 1e3);
    }
    if (a.optimize) {
      if (const auto rms = overallRmsError(a)) std::printf("rms       %.4f mm over all poses\n", *rms * 1e3);
    }
    for (const ArchiveFrames& f : a.frames)
      std::printf("frames    %-16s %zu frames over %.3f s\n", printableText(f.name).c_str(), f.positions.size(),
                  f.time.size() ? f.time[f.time.size() - 1] : 0.0);
    if (a.history && !a.history->iteration.empty()) {
      const ArchiveHistory& h = *a.history;
      std::printf("history   %zu iterations", h.iteration.size());
      if (!h.objective.empty()) std::printf(", objective %.4e -> %.4e", h.objective.front(), h.objective.back());
      if (!h.rmsError.empty()) std::printf(", final RMS error %.4f mm", h.rmsError.back() * 1e3);
      if (!h.timeSeconds.empty()) std::printf(" at %.2f s", h.timeSeconds.back());
      std::printf("\n");
    }
    return kExitDone;
  };
  return c;
}

}  // namespace rodmesh::cli
