#include "apps/cmd_export_vtk.hh"

#include <iostream>

#include "apps/commands.hh"
#include "io/scene_reader.hh"

namespace rodmesh::cli {

std::shared_ptr<VtkExportFlags> addVtkExportFlags(CLI::App* app) {
  auto f = std::make_shared<VtkExportFlags>();
  app->description(
      "printable solid (.stl, .obj, .ply) of the rod mesh in an archive, or files for ParaView (.vtp, .pvd, .xmf)");
  if (CLI::Option* out = app->get_option_no_throw("--output")) {
    out->required(false);
    out->description(
        "file to write: a solid (.stl binary, .obj, .ply), VTK PolyData (.vtp), the frames of a dynamic run (.pvd) "
        "or XDMF (.xmf)");
  }
  if (CLI::Option* pose = app->get_option_no_throw("--pose"))
    pose->description(
        "export the equilibrium shape of this pose instead of the rest shape; with .pvd or --xdmf: the frames of this "
        "dynamic pose");
  // Conflicts (--all-poses with --pose, ...) are reported by exportVisualization, in one line.
  app->add_flag("--all-poses", f->allPoses,
                "ParaView collection OUT.pvd of the rest shape and every pose, with OUT_rest.vtp, OUT_NAME.vtp");
  app->add_flag("--xdmf", f->xdmf,
                "XDMF file that reads the archive's own datasets (default ARCHIVE.xmf next to the archive)");
  return f;
}

std::optional<int> runVtkExportIfRequested(const std::string& archive, const std::string& output,
                                           const std::string& pose, const VtkExportFlags& flags,
                                           const GlobalOptions& global) {
  VtkExportOptions opt;
  opt.pose = pose;
  opt.allPoses = flags.allPoses;
  opt.xdmf = flags.xdmf;
  if (!isVisualizationExport(output, opt)) {
    if (output.empty()) throw InputError("export: -o/--output is required (or --xdmf)");
    return std::nullopt;
  }
  const VtkExportReport r = exportVisualization(archive, output, opt);
  if (!global.quiet) {
    std::cerr << "export: " << r.summary << "\n";
    std::cerr << "wrote " << r.files.back();
    if (r.files.size() > 1)
      std::cerr << " and " << r.files.size() - 1 << " more file" << (r.files.size() > 2 ? "s" : "");
    std::cerr << "\n";
  }
  return kExitDone;
}

}  // namespace rodmesh::cli
