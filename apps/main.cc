// rodmesh: command-line entry point. Parses the verb and hands over to it.
#include "apps/commands.hh"
#include "io/scene_reader.hh"

#include <iostream>
#include <vector>

int main(int argc, char** argv) {
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

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // One line, like every other bad input (issue 9): the flag, the value and
    // what is allowed, without CLI11's "Run with --help" line.
    std::cerr << "rodmesh: error: " << rodmesh::printableText(e.what()) << "\n";
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
        std::cerr << "rodmesh: error: " << rodmesh::printableText(e.what()) << "\n";
        return kExitBadInput;
      }
    }
  }
  return kExitBadInput;
}
