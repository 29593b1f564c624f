// rodmesh export ARCHIVE.h5 -o OUT.{stl,obj,ply} [--pose NAME]: a printable,
// one-piece solid of the designed rod mesh. See docs/meshing.md.
#include "apps/cmd_export_vtk.hh"
#include "apps/commands.hh"
#include "apps/flag_checks.hh"
#include "meshing/export.hh"

#include <iostream>
#include <memory>

namespace rodmesh::cli {

namespace {
struct ExportCliOptions {
  std::string archive, output;
  meshing::ExportOptions exp;
};
}  // namespace

Command registerExport(CLI::App& root, const GlobalOptions& global) {
  auto o = std::make_shared<ExportCliOptions>();
  CLI::App* app = root.add_subcommand("export", "printable solid (.stl, .obj, .ply) of the rod mesh in an archive");
  app->add_option("archive", o->archive, "result archive (HDF5) from simulate or optimize")->required();
  app->add_option("-o,--output", o->output, "solid to write: .stl (binary), .obj or .ply")->required();
  app->add_option("--pose", o->exp.pose, "export the equilibrium shape of this pose instead of the rest shape");
  app->add_option(
      "--resolution", o->exp.solid.resolution,
      "contouring grid step in metres, at most 1 (default: max(min radius / 2.5, median minor radius / 4)); "
      "refused if the solid would exceed 5e6 triangles");
  app->add_option("--fillet", o->exp.solid.fillet,
                  "blend radius where rods meet, 0 to 1 metres (default: half the median minor radius; 0: sharp)");

  auto vtk = addVtkExportFlags(app);  // .vtp/.pvd/.xmf for ParaView: apps/cmd_export_vtk.cc

  Command c;
  c.app = app;
  c.run = [o, app, vtk, &global]() -> int {
    requireFiniteNumbers(*app, {{"--resolution", "(0, 1] m, or 0 for the default"}, {"--fillet", "[0, 1] m"}});
    if (app->count("--fillet") > 0 && !(o->exp.solid.fillet >= 0))
      throw InputError("--fillet must be a blend radius in [0, 1] m (got " + app->get_option("--fillet")->results()[0] +
                       ")");
    if (auto status = runVtkExportIfRequested(o->archive, o->output, o->exp.pose, *vtk, global)) return *status;
    const meshing::ExportReport r = meshing::exportSolid(o->archive, o->output, o->exp);
    if (!global.quiet) std::cerr << meshing::formatExportReport(r) << "wrote " << o->output << "\n";
    return kExitDone;
  };
  return c;
}

}  // namespace rodmesh::cli
