#include "meshing/export.hh"

#include "io/archive.hh"
#include "io/scene_reader.hh"
#include "model/network.hh"

#include <chrono>
#include <sstream>

namespace rodmesh::meshing {

std::vector<SweepEdge> sweepEdgesFromArchive(const Archive& a, const std::string& path, const std::string& pose,
                                             double* density) {
  const Scene scene = parseScene(a.sceneJson, path + ":/scene");
  const int nv = static_cast<int>(scene.vertices.size());
  std::vector<Vec3> rest(nv);
  if (a.restPositions.rows() == nv) {
    for (int i = 0; i < nv; ++i) rest[i] = a.restPositions.row(i).transpose();
  } else if (a.restPositions.rows() == 0) {
    rest = scene.vertices;
  } else {
    throw InputError(path + ": /rest/positions has " + std::to_string(a.restPositions.rows()) +
                     " rows; the scene has " + std::to_string(nv) + " vertices");
  }
  auto requireFinite = [&](const auto& m, const std::string& dataset) {
    for (Eigen::Index i = 0; i < m.rows(); ++i)
      if (!m.row(i).allFinite())
        throw InputError(path + ": " + dataset + " row " + std::to_string(i) + " is not finite");
  };
  requireFinite(a.restPositions, "/rest/positions");
  requireFinite(a.radii, "/design/radii");
  std::vector<Vec2> radii = scene.radii;
  if (a.radii.rows() == nv) {
    for (int i = 0; i < nv; ++i) radii[i] = a.radii.row(i).transpose();
  } else if (a.radii.rows() != 0) {
    throw InputError(path + ": /design/radii has " + std::to_string(a.radii.rows()) + " rows; the scene has " +
                     std::to_string(nv) + " vertices");
  }
  for (int i = 0; i < nv; ++i)
    if (!(radii[i][0] > 0 && radii[i][1] > 0))
      throw InputError(path + ": /design/radii row " + std::to_string(i) + " is not positive");
  std::vector<Vec3> shape = rest;
  if (!pose.empty()) {
    const ArchivePose* found = nullptr;
    std::string names;
    for (const ArchivePose& p : a.poses) {
      names += (names.empty() ? "" : ", ") + p.name;
      if (p.name == pose) found = &p;
    }
    if (!found)
      throw InputError(path + ": no pose named '" + pose + "' in the archive (available: " +
                       (names.empty() ? std::string("none") : names) + ")");
    if (found->positions.rows() != nv)
      throw InputError(path + ": /poses/" + pose + "/positions has " + std::to_string(found->positions.rows()) +
                       " rows; the scene has " + std::to_string(nv) + " vertices");
    requireFinite(found->positions, "/poses/" + pose + "/positions");
    for (int i = 0; i < nv; ++i) shape[i] = found->positions.row(i).transpose();
  }
  if (density) *density = scene.material.density;
  const RodNetwork net(scene);
  std::vector<SweepEdge> out;
  out.reserve(net.numEdges());
  for (int e = 0; e < net.numEdges(); ++e) {
    const Edge& ed = net.edges()[e];
    const EdgeFrame rf = net.restFrame(e, rest);
    SweepEdge s;
    s.p0 = shape[ed.a];
    s.p1 = shape[ed.b];
    s.r0 = radii[ed.a];
    s.r1 = radii[ed.b];
    s.rod = ed.rod;
    if (pose.empty()) {
      s.d1 = rf.d1;
      s.d2 = rf.d2;
    } else {
      // Transport the rest cross-section: keep d2 as close to its rest
      // direction as the deformed tangent allows.
      const EdgeFrame f = edgeFrameFromNormal(s.p1 - s.p0, rf.d2);
      s.d1 = f.d1;
      s.d2 = f.d2;
    }
    if (!((s.p1 - s.p0).norm() > 0))
      throw InputError(path + ": edge " + std::to_string(e) + " has zero length in the " +
                       (pose.empty() ? std::string("rest shape") : "pose '" + pose + "'"));
    out.push_back(s);
  }
  return out;
}

ExportReport exportSolid(const std::string& archivePath, const std::string& outPath, const ExportOptions& opt) {
  const auto t0 = std::chrono::steady_clock::now();
  checkMeshExtension(outPath);
  validateOptions(opt.solid);
  // Every dataset and attribute checked against the scene before use (io/archive.hh).
  const Archive a = loadArchive(archivePath).archive;
  double density = 0;
  const std::vector<SweepEdge> edges = sweepEdgesFromArchive(a, archivePath, opt.pose, &density);
  ExportReport r;
  r.shape = opt.pose.empty() ? "rest shape" : "pose '" + opt.pose + "'";
  IndexedMesh mesh = sweepRods(edges, opt.solid, &r.solid);
  roundToFloat(mesh);
  r.check = checkSolid(mesh);
  r.triangles = static_cast<int>(mesh.faces.size());
  r.vertices = static_cast<int>(mesh.vertices.size());
  r.mass = r.check.volume * density;
  if (!r.check.ok())
    throw std::runtime_error(outPath + ": not written: the solid of " + archivePath + " (" + r.shape +
                             ") fails the printability checks: " + r.check.problems());
  writeMeshFile(mesh, outPath);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

std::string formatExportReport(const ExportReport& r) {
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(2);
  o << "solid (" << r.shape << "): " << r.triangles << " triangles, " << r.vertices << " vertices; grid "
    << 1e3 * r.solid.resolution << " mm" << (r.solid.coarsened ? " (default coarsened to stay within the limits)" : "")
    << ", " << r.solid.sampledPoints << " samples, fillet " << 1e3 * r.solid.fillet << " mm\n";
  o << "checks: closed, manifold, no self-intersections, outward, one piece: "
    << (r.check.ok() ? "passed" : r.check.problems()) << "\n";
  o << "volume " << 1e6 * r.check.volume << " cm^3, mass " << 1e3 * r.mass << " g\n";
  o << "bounding box [" << 1e3 * r.check.lo.x() << ", " << 1e3 * r.check.lo.y() << ", " << 1e3 * r.check.lo.z()
    << "] - [" << 1e3 * r.check.hi.x() << ", " << 1e3 * r.check.hi.y() << ", " << 1e3 * r.check.hi.z()
    << "] mm (size " << 1e3 * (r.check.hi - r.check.lo).x() << " x " << 1e3 * (r.check.hi - r.check.lo).y() << " x "
    << 1e3 * (r.check.hi - r.check.lo).z() << " mm)\n";
  o << "time: " << r.seconds << " s\n";
  return o.str();
}

}  // namespace rodmesh::meshing
