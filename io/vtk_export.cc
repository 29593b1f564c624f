#include "io/vtk_export.hh"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>

#include "io/archive.hh"
#include "io/scene_reader.hh"
#include "io/vtk_writer.hh"

namespace rodmesh {
namespace {

namespace fs = std::filesystem;

std::string extensionOf(const std::string& path) {
  const std::string name = fs::path(path).filename().string();
  const auto dot = name.find_last_of('.');
  if (dot == std::string::npos || dot == 0) return "";
  std::string e = name.substr(dot + 1);
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  return e;
}

// PATH without its extension (when it has one).
std::string stemOf(const std::string& path) {
  const std::string e = extensionOf(path);
  return e.empty() ? path : path.substr(0, path.size() - e.size() - 1);
}

// Throws InputError unless `path` can be created: its directory exists and is
// writable, and the path itself is not a directory.
void checkWritable(const std::string& path) {
  const fs::path p(path);
  const std::string dir = p.parent_path().empty() ? "." : p.parent_path().string();
  struct stat st;
  if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode) || ::access(dir.c_str(), W_OK) != 0)
    throw InputError(path + ": cannot write here: directory " + dir + " does not exist or is not writable");
  if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) throw InputError(path + ": is a directory");
}

// A pose name made safe for a file name: [A-Za-z0-9._-] kept, others '_'.
std::string fileSafe(const std::string& name) {
  std::string out;
  for (char c : name) out += (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '.') ? c : '_';
  if (out.empty() || out[0] == '.') out = "_" + out;
  return out;
}

// The archive with its scene, checked for consistency: what every output needs.
struct Loaded {
  Archive a;
  Scene scene;
  int nv = 0;
  MatX3 rest;   // V x 3, /rest/positions
  MatX2 radii;  // V x 2, /design/radii
};

Loaded load(const std::string& path) {
  // Every dataset and attribute checked against the scene before use
  // (io/archive.hh: loadArchive), so the sizes below hold.
  LoadedArchive la = loadArchive(path);
  Loaded L;
  L.a = std::move(la.archive);
  L.scene = std::move(la.scene);
  L.nv = static_cast<int>(L.scene.vertices.size());
  L.rest = L.a.restPositions;
  L.radii = L.a.radii;
  return L;
}

std::string poseCount(const Archive& a) {
  return std::to_string(a.poses.size()) + (a.poses.size() == 1 ? " pose" : " poses");
}

std::string poseNames(const Archive& a) {
  std::string names;
  for (const ArchivePose& p : a.poses) names += (names.empty() ? "" : ", ") + p.name;
  return names.empty() ? "none" : names;
}

const ArchivePose& findPose(const Loaded& L, const std::string& name, const std::string& path) {
  for (const ArchivePose& p : L.a.poses)
    if (p.name == name) return p;
  throw InputError(path + ": no pose named '" + name + "' in the archive (available: " + poseNames(L.a) + ")");
}

// The PolyData of shape `q` (V x 3); `target` empty or V x 3.
vtk::PolyLines polyLines(const Loaded& L, const MatX3& q, const MatX3& target) {
  vtk::PolyLines d;
  const int nv = L.nv;
  d.points.assign(q.data(), q.data() + 3 * nv);
  for (const Rod& r : L.scene.rods) d.lines.push_back(r.vertices);
  vtk::FloatArray rt{"radius_t", 1, {}}, rn{"radius_n", 1, {}}, disp{"displacement", 3, {}};
  for (int i = 0; i < nv; ++i) {
    rt.values.push_back(L.radii(i, 0));
    rn.values.push_back(L.radii(i, 1));
    for (int k = 0; k < 3; ++k) disp.values.push_back(q(i, k) - L.rest(i, k));
  }
  d.pointData = {rt, rn, disp};
  if (target.rows() == nv) {
    vtk::FloatArray err{"error", 1, {}};
    for (int i = 0; i < nv; ++i) err.values.push_back((q.row(i) - target.row(i)).norm());
    d.pointData.push_back(err);
  }
  vtk::IntArray rod{"rod", {}};
  for (std::size_t r = 0; r < L.scene.rods.size(); ++r) rod.values.push_back(static_cast<int>(r));
  d.cellIntData = {rod};
  d.activeScalars = "radius_n";
  d.activeVectors = "displacement";
  return d;
}

// The frames of `pose`, or of the only pose with frames when `pose` is empty.
const ArchiveFrames& framesOf(const Loaded& L, const std::string& pose, const std::string& path) {
  std::string framed;
  for (const ArchiveFrames& f : L.a.frames) framed += (framed.empty() ? "" : ", ") + f.name;
  if (!pose.empty()) {
    for (const ArchiveFrames& f : L.a.frames)
      if (f.name == pose) return f;
    throw InputError(path + ": pose '" + pose + "' has no frames (" +
                     (framed.empty() ? std::string("not a dynamic run") : "poses with frames: " + framed) +
                     "); --pose with a .pvd or XDMF output selects the frames of a dynamic run: write OUT.vtp for "
                     "the pose's final shape");
  }
  if (L.a.frames.size() == 1) return L.a.frames[0];
  throw InputError(path + ": " +
                   (L.a.frames.empty() ? std::string("no frames (not a dynamic run): write OUT.vtp, or use "
                                                     "--all-poses for a collection of every pose")
                                       : "several poses have frames (" + framed + "): choose one with --pose"));
}

std::string baseName(const std::string& path) { return fs::path(path).filename().string(); }

// ---- XDMF

// Path of the archive as seen from the directory of the .xmf file.
std::string archiveRef(const std::string& archivePath, const std::string& xmfPath) {
  const fs::path archive = fs::absolute(archivePath).lexically_normal();
  fs::path dir = fs::absolute(xmfPath).lexically_normal().parent_path();
  const fs::path rel = archive.lexically_relative(dir);
  return rel.empty() ? archive.string() : rel.string();
}

// Number type of composite data items (XDMF 3 readers need it on every item).
const std::string kFloat = "NumberType=\"Float\" Precision=\"8\"";

struct Xdmf {
  std::string out;
  std::string h5;       // archive reference
  std::string rodItem;  // inline cell values 0..R-1
  const Loaded* L = nullptr;

  std::string hdf(const std::string& dataset, const std::string& dims) const {
    return "<DataItem Dimensions=\"" + dims + "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" +
           vtk::xmlEscape(h5 + ":" + dataset) + "</DataItem>";
  }
  // Column `col` of a V x 2 dataset.
  std::string column(const std::string& dataset, int col) const {
    const std::string v = std::to_string(L->nv);
    return "<DataItem ItemType=\"HyperSlab\" Dimensions=\"" + v + " 1\" Type=\"HyperSlab\" " + kFloat + ">" +
           "<DataItem Dimensions=\"3 2\" Format=\"XML\">0 " + std::to_string(col) + " 1 1 " + v + " 1</DataItem>" +
           hdf(dataset, v + " 2") + "</DataItem>";
  }
  // Frame t of a T x V x 3 dataset, as V x 3.
  std::string frame(const std::string& dataset, long t, long frames) const {
    const std::string v = std::to_string(L->nv);
    return "<DataItem ItemType=\"HyperSlab\" Dimensions=\"1 " + v + " 3\" Type=\"HyperSlab\" " + kFloat + ">" +
           "<DataItem Dimensions=\"3 3\" Format=\"XML\">" + std::to_string(t) + " 0 0 1 1 1 1 " + v + " 3</DataItem>" +
           hdf(dataset, std::to_string(frames) + " " + v + " 3") + "</DataItem>";
  }
  std::string restItem() const { return hdf("/rest/positions", std::to_string(L->nv) + " 3"); }
  std::string difference(const std::string& a, const std::string& b) const {
    return "<DataItem ItemType=\"Function\" Function=\"$0 - $1\" Dimensions=\"" + std::to_string(L->nv) + " 3\" " +
           kFloat + ">" + a + b + "</DataItem>";
  }

  // One grid: geometry `positions` (a DataItem), displacement from rest,
  // radii, rod, and the target's error vector when `targetDataset` is set.
  void grid(const std::string& name, double time, const std::string& positions, const std::string& targetDataset) {
    const std::string v = std::to_string(L->nv);
    out += "      <Grid Name=\"" + vtk::xmlEscape(name) + "\" GridType=\"Uniform\">\n";
    out += "        <Time Value=\"" + vtk::formatDouble(time) + "\"/>\n";
    out += "        <xi:include xpointer=\"xpointer(//Xdmf/Domain/Topology[1])\"/>\n";
    out += "        <Geometry GeometryType=\"XYZ\">" + positions + "</Geometry>\n";
    out += "        <Attribute Name=\"rod\" AttributeType=\"Scalar\" Center=\"Cell\">" + rodItem + "</Attribute>\n";
    // radii: V x 2 [r_t, r_n] straight from the archive, readable by every
    // XDMF reader; radius_t, radius_n (hyperslabs) and the differences below
    // need ParaView's "XDMF Reader" (XDMF 3 readers skip them).
    out += "        <Attribute Name=\"radii\" AttributeType=\"Matrix\" Center=\"Node\">" +
           hdf("/design/radii", v + " 2") + "</Attribute>\n";
    for (int col = 0; col < 2; ++col) {
      const std::string n = col == 0 ? "radius_t" : "radius_n";
      const std::string item = column("/design/radii", col);
      out +=
          "        <Attribute Name=\"" + n + "\" AttributeType=\"Scalar\" Center=\"Node\">" + item + "</Attribute>\n";
    }
    out += "        <Attribute Name=\"displacement\" AttributeType=\"Vector\" Center=\"Node\">" +
           difference(positions, restItem()) + "</Attribute>\n";
    if (!targetDataset.empty()) {
      out += "        <Attribute Name=\"target\" AttributeType=\"Vector\" Center=\"Node\">" +
             hdf(targetDataset, v + " 3") + "</Attribute>\n";
      out += "        <Attribute Name=\"error_vector\" AttributeType=\"Vector\" Center=\"Node\">" +
             difference(positions, hdf(targetDataset, v + " 3")) + "</Attribute>\n";
    }
    out += "      </Grid>\n";
  }
};

// The rest shape and every pose (frames == nullptr), or the frames of one
// dynamic pose.
std::string xdmfDocument(const Loaded& L, const std::string& archivePath, const std::string& xmfPath,
                         const ArchiveFrames* frames) {
  Xdmf x;
  x.L = &L;
  x.h5 = archiveRef(archivePath, xmfPath);
  const std::string v = std::to_string(L.nv);
  std::string& o = x.out;
  o += "<?xml version=\"1.0\" ?>\n";
  o += "<!-- rodmesh export: the rod mesh of " + vtk::xmlEscape(baseName(archivePath)) +
       "; geometry, radii and targets are read from the archive. -->\n";
  o += "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n  <Domain>\n";
  // Topology: the archive stores no connectivity, so it is written here, one
  // polyline per rod (Mixed: cell type 2 = polyline, node count, node ids).
  std::size_t len = 0;
  std::string ids;
  for (const Rod& r : L.scene.rods) {
    ids += (ids.empty() ? "" : " ") + std::string("2 ") + std::to_string(r.vertices.size());
    for (int i : r.vertices) ids += " " + std::to_string(i);
    len += 2 + r.vertices.size();
  }
  o += "    <Topology Name=\"rods\" TopologyType=\"Mixed\" NumberOfElements=\"" + std::to_string(L.scene.rods.size()) +
       "\">\n      <DataItem Dimensions=\"" + std::to_string(len) + "\" NumberType=\"Int\" Format=\"XML\">" + ids +
       "</DataItem>\n    </Topology>\n";
  std::string rods;
  for (std::size_t r = 0; r < L.scene.rods.size(); ++r) rods += (r ? " " : "") + std::to_string(r);
  x.rodItem = "<DataItem Dimensions=\"" + std::to_string(L.scene.rods.size()) +
              "\" NumberType=\"Int\" Format=\"XML\">" + rods + "</DataItem>";

  if (!frames) {
    // Time k is the k-th pose, 0 the rest shape.
    o += "    <Grid Name=\"shapes\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
    x.grid("rest", 0.0, x.restItem(), "");
    int k = 0;
    for (const ArchivePose& p : L.a.poses) {
      const std::string g = "/poses/" + p.name;
      x.grid(p.name, ++k, x.hdf(g + "/positions", v + " 3"), p.target.rows() > 0 ? g + "/target" : "");
    }
  } else {
    const ArchiveFrames& f = *frames;
    std::string target;
    for (const ArchivePose& p : L.a.poses)
      if (p.name == f.name && p.target.rows() > 0) target = "/poses/" + f.name + "/target";
    o += "    <Grid Name=\"frames " + vtk::xmlEscape(f.name) +
         "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
    const long T = static_cast<long>(f.positions.size());
    for (long t = 0; t < T; ++t)
      x.grid(f.name + " " + std::to_string(t), f.time[t], x.frame("/frames/" + f.name + "/positions", t, T), target);
  }
  o += "    </Grid>\n";
  o += "  </Domain>\n</Xdmf>\n";
  return o;
}

}  // namespace

bool isVisualizationExport(const std::string& outPath, const VtkExportOptions& opt) {
  const std::string e = extensionOf(outPath);
  return opt.allPoses || opt.xdmf || e == "vtp" || e == "pvd" || e == "xmf";
}

std::string defaultXdmfPath(const std::string& archivePath) {
  const std::string e = extensionOf(archivePath);
  return (e == "h5" || e == "hdf5" ? stemOf(archivePath) : archivePath) + ".xmf";
}

VtkExportReport exportVisualization(const std::string& archivePath, const std::string& outPath,
                                    const VtkExportOptions& opt) {
  const std::string ext = extensionOf(outPath);
  const bool xdmf = opt.xdmf || ext == "xmf";
  if (opt.allPoses && !opt.pose.empty()) throw InputError("--all-poses and --pose exclude each other");
  if (xdmf && !outPath.empty() && ext != "xmf")
    throw InputError(outPath + ": an XDMF output must end in .xmf (or leave -o out: " + defaultXdmfPath(archivePath) +
                     ")");
  if (!xdmf && outPath.empty())
    throw InputError(std::string("-o/--output is required") + (opt.allPoses ? " (OUT.pvd for --all-poses)" : ""));
  if (!xdmf && opt.allPoses && ext != "pvd" && ext != "vtp")
    throw InputError(outPath + ": --all-poses writes a .pvd collection: name it OUT.pvd (or OUT.vtp)");
  if (!xdmf && !opt.allPoses && ext != "vtp" && ext != "pvd")
    throw InputError(outPath + ": unsupported output format '." + ext + "' (expected .vtp, .pvd or .xmf)");
  const std::string out = xdmf && outPath.empty() ? defaultXdmfPath(archivePath) : outPath;
  checkWritable(out);

  const Loaded L = load(archivePath);
  if (!opt.pose.empty()) findPose(L, opt.pose, archivePath);
  VtkExportReport report;
  vtk::FileSet files;

  if (xdmf) {
    const ArchiveFrames* fr = opt.pose.empty() ? nullptr : &framesOf(L, opt.pose, archivePath);
    files.add(out, xdmfDocument(L, archivePath, out, fr));
    report.summary = "XDMF reading " + archivePath + ": " +
                     (fr ? std::to_string(fr->positions.size()) + " frames of pose '" + fr->name + "'"
                         : "rest shape and " + poseCount(L.a) + " (time 0: rest, k: pose k)");
  } else if (opt.allPoses) {
    const std::string stem = stemOf(out), pvd = stem + ".pvd";
    std::vector<vtk::CollectionEntry> entries;
    std::set<std::string> used;
    auto uniqueFile = [&](const std::string& label) {
      std::string f = stem + "_" + fileSafe(label) + ".vtp";
      for (int n = 2; used.count(f); ++n) f = stem + "_" + fileSafe(label) + "_" + std::to_string(n) + ".vtp";
      used.insert(f);
      return f;
    };
    const std::string restFile = uniqueFile("rest");
    files.add(restFile, vtk::polyDataXml(polyLines(L, L.rest, MatX3())));
    entries.push_back({0.0, 0, "rest", baseName(restFile)});
    int k = 0;
    for (const ArchivePose& p : L.a.poses) {
      const std::string f = uniqueFile(p.name);
      files.add(f, vtk::polyDataXml(polyLines(L, p.positions, p.target)));
      entries.push_back({static_cast<double>(++k), 0, p.name, baseName(f)});
    }
    files.add(pvd, vtk::collectionXml(entries));
    report.summary = "rest shape and " + poseCount(L.a) + " (timestep 0: rest, k: pose k)";
  } else if (ext == "vtp") {
    const ArchivePose* p = opt.pose.empty() ? nullptr : &findPose(L, opt.pose, archivePath);
    files.add(out, vtk::polyDataXml(p ? polyLines(L, p->positions, p->target) : polyLines(L, L.rest, MatX3())));
    report.summary = p ? "pose '" + p->name + "'" : "rest shape";
  } else {  // .pvd: frames of a dynamic run
    const ArchiveFrames* fr = &framesOf(L, opt.pose, archivePath);
    MatX3 target;
    for (const ArchivePose& p : L.a.poses)
      if (p.name == fr->name) target = p.target;
    const std::string stem = stemOf(out);
    const std::size_t T = fr->positions.size();
    const int width = std::max<int>(4, static_cast<int>(std::to_string(T ? T - 1 : 0).size()));
    std::vector<vtk::CollectionEntry> entries;
    for (std::size_t t = 0; t < T; ++t) {
      std::string idx = std::to_string(t);
      idx.insert(0, width - idx.size(), '0');
      const std::string f = stem + "_" + idx + ".vtp";
      vtk::PolyLines d = polyLines(L, fr->positions[t], target);
      d.fieldData.push_back({"TimeValue", 1, {fr->time[t]}});
      files.add(f, vtk::polyDataXml(d));
      entries.push_back({fr->time[t], 0, "", baseName(f)});
    }
    files.add(out, vtk::collectionXml(entries));
    report.summary = std::to_string(T) + " frames of pose '" + fr->name + "', t = 0.." +
                     vtk::formatDouble(T ? fr->time[T - 1] : 0.0) + " s";
  }
  files.commit();
  report.files = files.paths();
  return report;
}

}  // namespace rodmesh
