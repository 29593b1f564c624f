// rodmesh: command-line entry point. Parses the verb and hands over to it.
#include "apps/commands.hh"
#include "apps/run.hh"
#include "io/scene_reader.hh"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <iostream>
#include <new>
#include <string>
#include <vector>

namespace {

// "-inf", "-nan", "-infinity" in any case: CLI11 takes them for short flags
// (-i -n -f) and reports the rest of a flag's values as unexpected
// arguments, naming neither the flag nor the value. No rodmesh flag is
// spelled like this, so they are passed on with a leading space: a value to
// CLI11, which the flag's own check then refuses by name (strtod and the
// checks of apps/flag_checks.hh show the text as typed, trimmed).
bool negativeNonFinite(const char* arg) {
  std::string t(arg);
  for (char& c : t) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return t == "-inf" || t == "-infinity" || t == "-nan";
}

// Library exceptions (std::bad_alloc, std::length_error, ...) carry class or
// function names, not a message for a user.
std::string userMessage(const std::exception& e) {
  if (dynamic_cast<const std::bad_alloc*>(&e) != nullptr)
    return "out of memory: the problem is too large for this machine (fewer vertices, poses or control points)";
  const std::string what = e.what();
  if (what.rfind("std::", 0) == 0 || what.find("::_M_") != std::string::npos || what.find("basic_string") != std::string::npos ||
      what.find("vector::") != std::string::npos || what.rfind("map::", 0) == 0 || what.rfind("stoi", 0) == 0 ||
      what.rfind("stod", 0) == 0 || what.empty())
    return "internal error (an unexpected library failure); nothing was written";
  return rodmesh::printableText(what);
}

// CLI11's own wording for a value it could not convert or arguments it could
// not place, reworded to name the flag and the text as typed.
std::string parseErrorMessage(const CLI::ParseError& e) {
  std::string what = e.what();
  const std::string convert = "Could not convert: ";
  if (what.rfind(convert, 0) == 0) {
    const std::string rest = what.substr(convert.size());  // "--max-iter = 1e12"
    const std::size_t eq = rest.find(" = ");
    if (eq != std::string::npos)
      return rest.substr(0, eq) + ": '" + rest.substr(eq + 3) + "' is not a value this flag takes (see --help)";
  }
  const std::string extras = "The following arguments were not expected: ";
  if (what.rfind(extras, 0) == 0)
    return "unexpected arguments: " + what.substr(extras.size()) +
           " (a flag given more values than it takes, or a value without its flag; see --help)";
  return what;
}

}  // namespace

int main(int argc, char** argv) {
  // Large blocks from the heap, kept after free (apps/heap_policy.cc): the
  // factorizations' workspaces are reused instead of faulted in anew.
  rodmesh::cli::keepLargeBlocksOnHeap();
  using namespace rodmesh::cli;
  CLI::App app{"rodmesh: design of 3D-printable flexible rod meshes"};
  app.require_subcommand(1);
  app.set_version_flag("--version", versionString());
  GlobalOptions global;
  app.add_flag("-q,--quiet", global.quiet, "no progress output on stderr");

  std::vector<Command> commands;
  commands.push_back(registerSimulate(app, global));
  commands.push_back(registerOptimize(app, global));
  commands.push_back(registerInspect(app, global));
#ifdef RODMESH_HAVE_MESHING
  commands.push_back(registerMesh(app, global));
  commands.push_back(registerExport(app, global));
#endif
  for (Command& c : commands) c.app->add_flag("-q,--quiet", global.quiet, "no progress output on stderr");

  app.name(argv[0]);
  std::vector<std::string> args;
  for (int i = 1; i < argc; ++i) args.push_back(negativeNonFinite(argv[i]) ? std::string(" ") + argv[i] : argv[i]);
  std::reverse(args.begin(), args.end());  // CLI11 takes them last first
  try {
    app.parse(args);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // One line, like every other bad input (issue 9): the flag, the value and
    // what is allowed, without CLI11's "Run with --help" line.
    std::cerr << "rodmesh: error: " << rodmesh::printableText(parseErrorMessage(e)) << "\n";
    return kExitBadInput;
  }
  for (Command& c : commands) {
    if (c.app->parsed()) {
      try {
        return c.run();
      } catch (const rodmesh::InputError& e) {
        std::cerr << "rodmesh: error: " << rodmesh::printableText(e.what()) << "\n";
        return kExitBadInput;
      } catch (const std::exception& e) {
        // Unreadable or unwritable files and the like: nothing was written.
        std::cerr << "rodmesh: error: " << userMessage(e) << "\n";
        return kExitBadInput;
      }
    }
  }
  return kExitBadInput;
}
