// Sub-commands of the rodmesh executable. Each cmd_*.cc file registers one verb
// and maps its flags onto option structs; the work itself lives in the libraries.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <string>

namespace rodmesh::cli {

// Exit statuses (docs/formats.md §2).
constexpr int kExitDone = 0;
constexpr int kExitNotConverged = 1;
constexpr int kExitBadInput = 2;

// Options shared by every verb.
struct GlobalOptions {
  bool quiet = false;
};

// A registered verb: `run` is called after parsing when the verb was chosen.
struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;
};

Command registerSimulate(CLI::App& root, const GlobalOptions& global);
Command registerInspect(CLI::App& root, const GlobalOptions& global);
Command registerOptimize(CLI::App& root, const GlobalOptions& global);
#ifdef RODMESH_HAVE_MESHING
Command registerMesh(CLI::App& root, const GlobalOptions& global);
Command registerExport(CLI::App& root, const GlobalOptions& global);
#endif

// The version string stored in archives.
const char* versionString();

}  // namespace rodmesh::cli
