// `rodmesh export` to files for ParaView/VisIt: the rod mesh of a result
// archive as VTK XML PolyData (.vtp), collections of them (.pvd: every pose,
// or the frames of a dynamic run), and an XDMF side file (.xmf) that points
// into the archive's own HDF5 datasets. See docs/formats.md, "Files for
// ParaView".
//
// Every .vtp holds one polyline per rod (connectivity from the scene stored in
// the archive, /scene) through the archive's vertices, with
//   point data  radius_t, radius_n  [m]   /design/radii columns
//               displacement        [m]   positions - /rest/positions (3 comps)
//               error               [m]   |positions - target| (poses with a target)
//   cell data   rod                       rod index in the scene
// and, for a frame of a dynamic run, field data TimeValue [s].
#pragma once

#include <string>
#include <vector>

namespace rodmesh {

struct VtkExportOptions {
  std::string pose;       // --pose: the pose to write (empty: rest shape); for .pvd and xdmf, whose frames
  bool allPoses = false;  // --all-poses: rest shape and every pose, a .pvd and one .vtp each
  bool xdmf = false;      // --xdmf: an XDMF file referencing the archive's datasets
};

// What a call wrote, for the CLI to print.
struct VtkExportReport {
  std::string summary;             // one line, e.g. "rest shape and 3 poses"
  std::vector<std::string> files;  // every file written, the main one last
};

// True when `outPath` and the options ask for a visualization output (.vtp,
// .pvd or .xmf, --all-poses, --xdmf) rather than a printable solid.
bool isVisualizationExport(const std::string& outPath, const VtkExportOptions& opt);

// The default XDMF file of an archive: ARCHIVE with .h5/.hdf5 replaced by .xmf
// (or .xmf appended).
std::string defaultXdmfPath(const std::string& archivePath);

// Writes the files. Output kinds, from the options and the extension of
// `outPath` (empty only with xdmf):
//   xdmf, or OUT.xmf   XDMF file (default defaultXdmfPath) whose geometry,
//                      radii and targets are references into the archive:
//                      a temporal collection of the rest shape (time 0) and
//                      every pose (time k), or with `pose` the frames of that
//                      dynamic pose (time in s). Topology inline (the archive
//                      stores no connectivity), one Mixed polyline per rod
//   allPoses           OUT.pvd (OUT may end in .pvd or .vtp) and OUT_rest.vtp,
//                      OUT_NAME.vtp per pose; timestep 0 is the rest shape,
//                      k the k-th pose in archive order
//   OUT.vtp            the rest shape, or `pose`
//   OUT.pvd            the frames of a dynamic run: `pose`'s, or those of the
//                      only pose with frames; OUT_0000.vtp, ... with timestep
//                      = frame time [s]
// Every file appears together with the others or not at all (temporary files
// renamed when all are complete). Throws InputError for bad input (unknown
// pose, pose without frames, extension, unwritable directory, archive
// inconsistent with its scene) and std::runtime_error for files that are not
// rodmesh archives or cannot be written.
VtkExportReport exportVisualization(const std::string& archivePath, const std::string& outPath,
                                    const VtkExportOptions& opt);

}  // namespace rodmesh
