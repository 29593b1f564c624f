// rodmesh._rodmesh: `rodmesh mesh` from Python (surfaces given as arrays or
// files, and generated sheets). Calls the meshing library only; CGAL stays in
// meshing/'s own translation units. Options and defaults are those of the
// CLI (apps/cmd_mesh.cc); the scene is written to JSON and parsed back, as
// the CLI writes it and `simulate` reads it.
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "io/scene_reader.hh"
#include "io/scene_writer.hh"
#include "meshing/grid.hh"
#include "meshing/rod_mesher.hh"
#include "meshing/surface.hh"

#include <functional>
#include <set>
#include <string>
#include <vector>

namespace py = pybind11;
using namespace rodmesh;

namespace {

using RowMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using IntRowMat = Eigen::Matrix<long long, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct Kw {
  const py::dict& d;
  bool has(const char* k) const { return d.contains(k) && !d[k].is_none(); }
  template <class T>
  T get(const char* k) const {
    return d[k].cast<T>();
  }
};

void rejectUnknown(const py::dict& kw, const std::set<std::string>& known, const char* fn) {
  for (auto item : kw) {
    const std::string k = py::str(item.first);
    if (!known.count(k)) throw py::type_error(std::string(fn) + "() got an unexpected keyword argument '" + k + "'");
  }
}

std::vector<double> numbers(const py::object& o) {
  if (py::isinstance<py::float_>(o) || py::isinstance<py::int_>(o)) return {o.cast<double>()};
  return o.cast<std::vector<double>>();
}

// Options shared by surfaces and grids (material, radii, design, gravity).
void commonOptions(const Kw& kw, meshing::MeshOptions& m) {
  if (kw.has("young_modulus")) m.material.youngModulus = kw.get<double>("young_modulus");
  if (kw.has("poisson_ratio")) m.material.poissonRatio = kw.get<double>("poisson_ratio");
  if (kw.has("material_density")) m.material.density = kw.get<double>("material_density");
  if (kw.has("radius")) {
    const std::vector<double> r = numbers(kw.d["radius"]);
    if (r.size() != 1 && r.size() != 2) throw InputError("--radius takes R_T [R_N]");
    m.radius = r.size() == 1 ? Vec2(r[0], r[0]) : Vec2(r[0], r[1]);
  }
  if (kw.has("radius_bounds")) {
    const std::vector<double> b = numbers(kw.d["radius_bounds"]);
    if (b.size() != 2) throw InputError("--radius-bounds takes MIN MAX");
    m.radiusMin = b[0];
    m.radiusMax = b[1];
  }
  if (kw.has("design")) {
    const std::string d = kw.get<std::string>("design");
    if (d == "radii,rest_shape" || d == "rest_shape,radii")
      m.designRadii = m.designRestShape = true;
    else if (d == "radii")
      m.designRadii = true, m.designRestShape = false;
    else if (d == "rest_shape")
      m.designRadii = false, m.designRestShape = true;
    else if (d == "none")
      m.designRadii = m.designRestShape = false;
    else
      throw InputError("--design must be radii,rest_shape | radii | rest_shape | none (got '" + d + "')");
  }
  if (kw.has("control_points")) m.controlPointsPerRod = kw.get<int>("control_points");
  if (kw.has("gravity")) {
    const std::vector<double> g = numbers(kw.d["gravity"]);
    if (g.size() != 3) throw InputError("--gravity takes GX GY GZ");
    m.gravity = Vec3(g[0], g[1], g[2]);
  }
}

// The scene as `rodmesh mesh` writes it and the reader reads it back.
Scene roundTrip(const Scene& s, const std::string& name) {
  const std::string json = sceneToJson(s);
  try {
    return parseScene(json, name);
  } catch (const InputError& e) {
    throw std::runtime_error(std::string("internal error: the generated scene is invalid: ") + e.what());
  }
}

meshing::TriSurface surfaceFromArrays(const RowMat& V, const IntRowMat& F, const std::string& name,
                                      std::vector<char>* flips) {
  if (V.cols() != 3) throw InputError(name + ": V must be an N x 3 array, got " + std::to_string(V.cols()) + " columns");
  if (F.cols() != 3) throw InputError(name + ": F must be an M x 3 array, got " + std::to_string(F.cols()) + " columns");
  meshing::PolygonSoup soup;
  for (Eigen::Index i = 0; i < V.rows(); ++i) soup.vertices.push_back(V.row(i).transpose());
  for (Eigen::Index i = 0; i < F.rows(); ++i)
    soup.faces.push_back({static_cast<int>(F(i, 0)), static_cast<int>(F(i, 1)), static_cast<int>(F(i, 2))});
  return meshing::validateSurface(soup, name, flips);
}

std::string stemOf(const std::string& path) {
  auto slash = path.find_last_of('/');
  std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  auto dot = name.find_last_of('.');
  return dot == std::string::npos ? name : name.substr(0, dot);
}

// mesh_surface(surface, faces, poses, options): `surface` is a path or a
// V x 3 array (then `faces` is M x 3); `poses` a list of (name, path or V x 3
// array) pairs, deformed copies with the rest surface's faces.
Scene meshSurfacePy(const py::object& surface, const py::object& faces, const py::list& poses, const py::dict& kwd) {
  rejectUnknown(kwd,
                {"cells", "dual", "faces_target", "iterations", "merge", "refinement", "restarts", "tolerance",
                 "boundary", "edge_length", "fix_box", "fix_vertices", "density", "scale", "young_modulus",
                 "poisson_ratio", "material_density", "radius", "radius_bounds", "design", "control_points",
                 "gravity"},
                "mesh_surface");
  const Kw kw{kwd};
  meshing::MeshOptions m;
  commonOptions(kw, m);
  if (kw.has("dual")) m.method = kw.get<bool>("dual") ? meshing::MeshMethod::Dual : meshing::MeshMethod::Cells;
  if (kw.has("cells")) m.cvt.cells = kw.get<int>("cells");
  if (kw.has("faces_target")) m.dualFaces = kw.get<int>("faces_target");
  if (kw.has("iterations")) m.cvt.maxIterations = kw.get<int>("iterations");
  if (kw.has("merge")) m.cvt.mergeFraction = kw.get<double>("merge");
  if (kw.has("refinement")) m.cvt.refinement = kw.get<double>("refinement");
  if (kw.has("restarts")) m.cvt.restarts = kw.get<int>("restarts");
  if (kw.has("tolerance")) m.cvt.tolerance = kw.get<double>("tolerance");
  if (kw.has("edge_length")) m.edgeLength = kw.get<double>("edge_length");
  if (kw.has("boundary")) {
    const std::string b = kw.get<std::string>("boundary");
    if (b == "rim")
      m.cvt.boundary = meshing::BoundaryMode::Rim;
    else if (b == "free")
      m.cvt.boundary = meshing::BoundaryMode::Free;
    else
      throw InputError("--boundary must be 'rim' or 'free' (got '" + b + "')");
  }
  if (kw.has("fix_box")) {
    std::vector<std::vector<double>> boxes;
    py::object fb = kwd["fix_box"];
    try {
      boxes = fb.cast<std::vector<std::vector<double>>>();
    } catch (const py::cast_error&) {
      boxes = {fb.cast<std::vector<double>>()};
    }
    for (const std::vector<double>& b : boxes) {
      if (b.size() != 6) throw InputError("--fix-box needs six numbers");
      m.fixBoxes.push_back({Vec3(b[0], b[1], b[2]), Vec3(b[3], b[4], b[5])});
    }
  }
  double scale = 1.0;
  if (kw.has("scale")) scale = kw.get<double>("scale");
  if (!(scale >= 1e-6 && scale <= 1e6)) throw InputError("--scale must lie in [1e-06, 1e+06] (got " + std::to_string(scale) + ")");
  meshing::validateOptions(m);

  std::vector<char> flips;
  meshing::TriSurface rest;
  const bool fromFile = py::isinstance<py::str>(surface);
  if (fromFile) {
    const std::string path = surface.cast<std::string>();
    rest = meshing::validateSurface(meshing::readPolygonFile(path), path, &flips);
  } else {
    if (faces.is_none()) throw InputError("mesh_surface: a surface given as vertices needs faces F (M x 3)");
    rest = surfaceFromArrays(surface.cast<RowMat>(), faces.cast<IntRowMat>(), "surface", &flips);
  }
  for (Vec3& v : rest.vertices) v *= scale;
  std::vector<meshing::DeformedPose> deformed;
  for (const py::handle& item : poses) {
    const py::tuple t = item.cast<py::tuple>();
    meshing::DeformedPose dp;
    dp.name = t[0].cast<std::string>();
    if (py::isinstance<py::str>(t[1])) {
      const std::string path = t[1].cast<std::string>();
      if (dp.name.empty()) dp.name = stemOf(path);
      dp.surface = meshing::readDeformedCopy(path, rest, flips);
    } else {
      const RowMat X = t[1].cast<RowMat>();
      if (X.rows() != static_cast<Eigen::Index>(rest.vertices.size()) || X.cols() != 3)
        throw InputError("pose '" + dp.name + "': a deformed copy needs " + std::to_string(rest.vertices.size()) +
                         " x 3 vertices (the surface's), got " + std::to_string(X.rows()) + " x " +
                         std::to_string(X.cols()));
      dp.surface = rest;
      for (Eigen::Index i = 0; i < X.rows(); ++i) dp.surface.vertices[i] = X.row(i).transpose();
      dp.surface.sourcePath = dp.name;
    }
    // Scaled like the rest surface (`rodmesh mesh --scale`).
    for (Vec3& v : dp.surface.vertices) v *= scale;
    deformed.push_back(std::move(dp));
  }
  std::vector<double> density;
  if (kw.has("density")) {
    py::object d = kwd["density"];
    if (py::isinstance<py::str>(d))
      density = meshing::readDensityFile(d.cast<std::string>(), static_cast<int>(rest.vertices.size()));
    else
      density = d.cast<std::vector<double>>();
  }
  if (kw.has("fix_vertices")) {
    py::object f = kwd["fix_vertices"];
    if (py::isinstance<py::str>(f))
      m.fixSurfaceVertices = meshing::readVertexListFile(f.cast<std::string>(), static_cast<int>(rest.vertices.size()));
    else
      m.fixSurfaceVertices = f.cast<std::vector<int>>();
  }
  meshing::MeshResult res = meshing::meshSurface(rest, deformed, density, m);
  return roundTrip(res.scene, "mesh_surface");
}

Scene gridPy(const std::string& kind, const py::dict& kwd) {
  rejectUnknown(kwd,
                {"size", "cells", "rod_vertices", "fit", "hex_rows", "fix_side", "pull", "young_modulus",
                 "poisson_ratio", "material_density", "radius", "radius_bounds", "design", "control_points",
                 "gravity"},
                "grid");
  const Kw kw{kwd};
  meshing::MeshOptions m;
  commonOptions(kw, m);
  meshing::GridOptions g;
  g.kind = meshing::parseGridKind(kind, "--grid");
  if (kw.has("size")) {
    const std::vector<double> s = numbers(kwd["size"]);
    if (s.size() != 2) throw InputError("--grid needs --size W H (metres)");
    g.width = s[0];
    g.height = s[1];
  }
  if (kw.has("cells")) {
    const std::vector<int> c = kwd["cells"].cast<std::vector<int>>();
    if (c.size() != 2) throw InputError("--grid needs --cells NX NY (cells across and up)");
    g.cellsX = c[0];
    g.cellsY = c[1];
  }
  if (kw.has("rod_vertices")) g.rodVertices = kw.get<int>("rod_vertices");
  if (kw.has("fit")) {
    const std::string f = kw.get<std::string>("fit");
    if (f == "regular")
      g.fit = meshing::GridFit::Regular;
    else if (f == "stretch")
      g.fit = meshing::GridFit::Stretch;
    else
      throw InputError("--fit must be 'regular' or 'stretch' (got '" + f + "')");
  }
  if (kw.has("hex_rows")) {
    const std::string h = kw.get<std::string>("hex_rows");
    if (h == "alternate")
      g.hexRows = meshing::HexRows::Alternate;
    else if (h == "offset")
      g.hexRows = meshing::HexRows::Offset;
    else
      throw InputError("--hex-rows must be 'alternate' or 'offset' (got '" + h + "')");
  }
  g.material = m.material;
  g.radius = m.radius;
  g.radiusMin = m.radiusMin;
  g.radiusMax = m.radiusMax;
  g.designRadii = m.designRadii;
  g.designRestShape = m.designRestShape;
  g.controlPointsPerRod = m.controlPointsPerRod;
  g.gravity = m.gravity;
  if (kw.has("fix_side")) {
    py::object f = kwd["fix_side"];
    std::vector<std::string> sides =
        py::isinstance<py::str>(f) ? std::vector<std::string>{f.cast<std::string>()} : f.cast<std::vector<std::string>>();
    for (const std::string& s : sides) g.fixSides.push_back(meshing::parseGridSide(s, "--fix-side"));
  }
  if (kw.has("pull")) {
    // (side, fx, fy, fz), or a list of them
    py::object p = kwd["pull"];
    std::vector<py::object> pulls;
    py::sequence seq = p.cast<py::sequence>();
    if (seq.size() > 0 && py::isinstance<py::str>(seq[0]))
      pulls.push_back(p);
    else
      for (const py::handle& h : seq) pulls.push_back(py::reinterpret_borrow<py::object>(h));
    for (const py::object& q : pulls) {
      py::sequence s = q.cast<py::sequence>();
      if (s.size() != 4) throw InputError("--pull needs a side and three force components: SIDE FX FY FZ");
      meshing::SidePull sp;
      sp.side = meshing::parseGridSide(s[0].cast<std::string>(), "--pull");
      for (int k = 0; k < 3; ++k) sp.force[k] = s[k + 1].cast<double>();
      g.pulls.push_back(sp);
    }
  }
  const meshing::GridResult res = meshing::makeGridSheet(g);
  return roundTrip(res.scene, "grid");
}

}  // namespace

// The PyScene wrapper lives in module.cc; these return plain Scenes that it wraps.
void bindMeshing(py::module_& m, const std::function<py::object(Scene&&)>& wrap) {
  m.def(
      "mesh_surface",
      [wrap](const py::object& surface, const py::object& faces, const py::list& poses, const py::dict& options) {
        return wrap(meshSurfacePy(surface, faces, poses, options));
      },
      py::arg("surface"), py::arg("faces"), py::arg("poses"), py::arg("options"));
  m.def(
      "grid", [wrap](const std::string& kind, const py::dict& options) { return wrap(gridPy(kind, options)); },
      py::arg("kind"), py::arg("options"));
}
