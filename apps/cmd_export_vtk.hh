// `rodmesh export` to files for ParaView/VisIt (.vtp, .pvd, .xmf): the flags
// and the branch taken at the start of the export verb. The work is in
// io/vtk_export.hh; printable solids stay in apps/cmd_export.cc.
#pragma once

#include <CLI/CLI.hpp>
#include <memory>
#include <optional>
#include <string>

#include "io/vtk_export.hh"

namespace rodmesh::cli {

struct GlobalOptions;

struct VtkExportFlags {
  bool allPoses = false;
  bool xdmf = false;
};

// Adds --all-poses and --xdmf to the export verb, makes -o optional (--xdmf
// has a default output) and extends the help texts.
std::shared_ptr<VtkExportFlags> addVtkExportFlags(CLI::App* exportApp);

// Runs a visualization export when the flags or the extension of `output` ask
// for one (and returns the exit status); std::nullopt otherwise, so that the
// printable-solid export goes on. Also rejects a missing -o for solids.
std::optional<int> runVtkExportIfRequested(const std::string& archive, const std::string& output,
                                           const std::string& pose, const VtkExportFlags& flags,
                                           const GlobalOptions& global);

}  // namespace rodmesh::cli
