// `rodmesh export`: from a result archive to a printable solid.
#pragma once

#include "meshing/solid.hh"

#include <string>
#include <vector>

namespace rodmesh {
struct Archive;
}

namespace rodmesh::meshing {

struct ExportOptions {
  std::string pose;  // empty: rest shape
  SolidOptions solid;
};

struct ExportReport {
  std::string shape;   // "rest" or "pose NAME"
  SolidCheck check;
  SolidReport solid;
  double mass = 0.0;   // kg (volume x scene density)
  int triangles = 0, vertices = 0;
  double seconds = 0.0;
};

// The rod edges of an archive's design, in the rest shape (pose empty) or in
// a pose. Cross-section frames: the rest frame of RodNetwork::restFrame; in a
// pose, d2 is the rest d2 projected perpendicular to the deformed edge
// tangent (twist is not applied), d1 = d2 x t. Throws InputError for an
// unknown pose (naming it and the available ones) or inconsistent sizes.
std::vector<SweepEdge> sweepEdgesFromArchive(const Archive& a, const std::string& archivePath,
                                             const std::string& pose, double* density = nullptr);

// Builds, checks and writes the solid. Nothing is written unless every check
// passes (then the file appears atomically). Throws InputError for bad input
// and std::runtime_error if the solid fails the checks.
ExportReport exportSolid(const std::string& archivePath, const std::string& outPath, const ExportOptions& opt);

std::string formatExportReport(const ExportReport& r);

}  // namespace rodmesh::meshing
