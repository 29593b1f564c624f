// rodmesh mesh SURFACE -o SCENE.json: a rod-mesh scene from a triangle surface
// (and target poses from deformed copies of it).
// rodmesh mesh --grid hex|quad|tri --size W H --cells NX NY --rod-vertices K
// -o SCENE.json: a generated planar sheet (meshing/grid.hh). See docs/meshing.md.
#include <cstdlib>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>

#include "apps/commands.hh"
#include "apps/flag_checks.hh"
#include "io/scene_reader.hh"
#include "io/scene_writer.hh"
#include "meshing/grid.hh"
#include "meshing/rod_mesher.hh"
#include "meshing/surface.hh"

namespace rodmesh::cli {

namespace {

struct MeshCliOptions {
  std::string surface, output;
  bool dual = false;
  std::string densityFile, fixVerticesFile, boundary = "rim", design = "radii,rest_shape";
  std::vector<std::string> poses;
  std::vector<double> fixBox, radius{0.002, 0.002}, radiusBounds{0.001, 0.005}, gravity;
  double scale = 1.0;
  meshing::MeshOptions mesh;
  // --cells takes N (surface) or NX NY (--grid); see cellsOption below.
  std::vector<int> cells;
  std::string cellsSpill;  // a non-number taken by --cells: the SURFACE positional
  std::string cellsBad;    // a --cells value that is no int ("2147483648", "1e3")
  // --grid
  std::string grid, fit = "regular", hexRows = "alternate";
  std::vector<double> size;
  int rodVertices = 11;
  std::vector<std::string> fixSides, pulls;
};

std::string stemOf(const std::string& path) {
  auto slash = path.find_last_of('/');
  std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  auto dot = name.find_last_of('.');
  return dot == std::string::npos ? name : name.substr(0, dot);
}

void scaleSurface(meshing::TriSurface& s, double k) {
  for (Vec3& v : s.vertices) v *= k;
}

bool parseInt(const std::string& t, int& out) {
  try {
    std::size_t used = 0;
    const long v = std::stol(t, &used);
    if (used != t.size() || v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max()) return false;
    out = static_cast<int>(v);
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

double parseNumber(const std::string& t, const std::string& flag) {
  try {
    std::size_t used = 0;
    const double v = std::stod(t, &used);
    if (used == t.size()) return v;
  } catch (const std::exception&) {
  }
  throw InputError(flag + ": '" + t + "' is not a number");
}

// --scale: a unit conversion (0.001 for millimetres, 0.0254 for inches).
constexpr double kMinScale = 1e-6, kMaxScale = 1e6;

// Flags whose values are real numbers: each must be finite
// (requireFiniteNumbers), and what each allows (checked in full by
// validateOptions / validateGridOptions).
const std::vector<RealFlag> kRealFlags = {{"--scale", "[1e-06, 1e+06]"},
                                          {"--refinement", "[1, 20] edges per cell radius"},
                                          {"--tolerance", "[0, 1] x cell radius"},
                                          {"--merge", "[0, 1] x median Voronoi edge"},
                                          {"--edge-length", "(0, 100] m"},
                                          {"--young-modulus", "[1, 1e+13] Pa"},
                                          {"--poisson-ratio", "(-1, 0.5]"},
                                          {"--material-density", "[0.001, 1e+05] kg/m^3"},
                                          {"--radius", "[1e-06, 100] m"},
                                          {"--radius-bounds", "1e-06 <= MIN <= MAX <= 100 m"},
                                          {"--gravity", "[-1e+04, 1e+04] m/s^2 per component"},
                                          {"--fix-box", "finite coordinates in metres"},
                                          {"--size", "[1e-06, 1e+06] m"},
                                          {"--pull", "finite forces in newtons"}};

std::string fmt(double v) {
  std::ostringstream o;
  o.precision(10);
  o << v;
  return o.str();
}

// Maps the grid flags onto GridOptions (material and design come from `m`).
meshing::GridOptions gridOptions(const MeshCliOptions& o, const meshing::MeshOptions& m) {
  meshing::GridOptions g;
  g.kind = meshing::parseGridKind(o.grid, "--grid");
  if (o.size.size() != 2) throw InputError("--grid needs --size W H (metres)");
  g.width = o.size[0];
  g.height = o.size[1];
  if (o.cells.size() != 2) throw InputError("--grid needs --cells NX NY (cells across and up)");
  g.cellsX = o.cells[0];
  g.cellsY = o.cells[1];
  g.rodVertices = o.rodVertices;
  if (o.fit == "regular")
    g.fit = meshing::GridFit::Regular;
  else if (o.fit == "stretch")
    g.fit = meshing::GridFit::Stretch;
  else
    throw InputError("--fit must be 'regular' or 'stretch' (got '" + o.fit + "')");
  if (o.hexRows == "alternate")
    g.hexRows = meshing::HexRows::Alternate;
  else if (o.hexRows == "offset")
    g.hexRows = meshing::HexRows::Offset;
  else
    throw InputError("--hex-rows must be 'alternate' or 'offset' (got '" + o.hexRows + "')");
  g.material = m.material;
  g.radius = m.radius;
  g.radiusMin = m.radiusMin;
  g.radiusMax = m.radiusMax;
  g.designRadii = m.designRadii;
  g.designRestShape = m.designRestShape;
  g.controlPointsPerRod = m.controlPointsPerRod;
  g.gravity = m.gravity;
  for (const std::string& side : o.fixSides) g.fixSides.push_back(meshing::parseGridSide(side, "--fix-side"));
  if (o.pulls.size() % 4 != 0) throw InputError("--pull needs a side and three force components: SIDE FX FY FZ");
  for (std::size_t i = 0; i < o.pulls.size(); i += 4) {
    meshing::SidePull p;
    p.side = meshing::parseGridSide(o.pulls[i], "--pull");
    for (int k = 0; k < 3; ++k) p.force[k] = parseNumber(o.pulls[i + 1 + k], "--pull");
    g.pulls.push_back(p);
  }
  return g;
}

// Parses our own output before writing: the scene must satisfy the contract.
void checkAndWrite(const Scene& scene, const std::string& output) {
  const std::string json = sceneToJson(scene);
  try {
    parseScene(json, output);
  } catch (const InputError& e) {
    throw std::runtime_error(std::string("internal error: the generated scene is invalid: ") + e.what());
  }
  writeSceneFile(scene, output);
}

}  // namespace

Command registerMesh(CLI::App& root, const GlobalOptions& global) {
  auto o = std::make_shared<MeshCliOptions>();
  CLI::App* app = root.add_subcommand(
      "mesh", "rod-mesh scene from a triangle surface (.obj, .off, .ply) or a generated planar sheet (--grid)");
  app->add_option("surface", o->surface,
                  "input triangle surface (.obj, .off or .ply), metres (see --scale); omit with --grid");
  app->add_option("-o,--output", o->output, "scene file to write (rodmesh-scene/1 JSON)")->required();
  // --cells N (surface) or --cells NX NY (--grid). Up to two values are taken;
  // a second value that is not a number is the SURFACE positional that CLI11
  // collected greedily (`--cells 60 hat.obj`), handed back in run().
  app->add_option(
         "--cells",
         [o](const CLI::results_t& r) {
           o->cells.clear();
           for (std::size_t i = 0; i < r.size(); ++i) {
             int v = 0;
             char* end = nullptr;
             std::strtod(r[i].c_str(), &end);
             const bool numeric = end != r[i].c_str() && *end == '\0';
             if (parseInt(r[i], v))
               o->cells.push_back(v);
             else if (i == 1 && r.size() == 2 && !numeric)
               o->cellsSpill = r[i];
             else if (o->cellsBad.empty())
               o->cellsBad = r[i];  // reported with the allowed range in run()
           }
           return true;
         },
         "surface: number of cells of the centroidal Voronoi tessellation (default 64, at most 10000); "
         "--grid: cells across and up, NX NY")
      ->expected(1, 2)
      ->type_name("N|NX NY");
  app->add_option("--grid", o->grid,
                  "generate a planar sheet in z = 0 instead of meshing a surface: hex (regular hexagons), quad "
                  "(squares) or tri (equilateral triangles); needs --size and --cells NX NY");
  app->add_option("--size", o->size, "--grid: sheet size W H in metres (centred at the origin)")->expected(2);
  app->add_option("--rod-vertices", o->rodVertices, "--grid: vertices per rod K >= 2 (K - 1 edges per rod)")
      ->check(wholeNumberIn(2, std::numeric_limits<int>::max()))
      ->capture_default_str();
  app->add_option("--fit", o->fit,
                  "--grid: 'regular' (regular cells, largest lattice that fits W x H, centred) or 'stretch' "
                  "(spans W x H exactly; cells scaled in x and y)")
      ->capture_default_str();
  app->add_option("--hex-rows", o->hexRows,
                  "--grid hex: 'alternate' (rows of NX and NX-1 cells, symmetric sides) or 'offset' (every row NX "
                  "cells, odd rows shifted by half a cell)")
      ->capture_default_str();
  app->add_option("--fix-side", o->fixSides,
                  "--grid: hold the vertices on this side of the sheet in every pose: left, right, bottom, top "
                  "(repeatable)")
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  app->add_option("--pull", o->pulls,
                  "--grid: add a pose pull_SIDE in which the total force FX FY FZ [N] is shared equally by the "
                  "connections on SIDE that are not fixed (repeatable; without it, one pose 'rest')")
      ->expected(4)
      ->type_name("SIDE FX FY FZ")
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  app->add_flag("--dual", o->dual, "dual of a decimated surface instead of a Voronoi tessellation");
  app->add_option("--faces", o->mesh.dualFaces, "with --dual: face count of the decimated surface")
      ->check(wholeNumberIn(4, meshing::kMaxDualFaces))
      ->capture_default_str();
  app->add_option("--density", o->densityFile,
                  "per-vertex density file (one positive value per surface vertex); cells shrink as density^-1/4");
  app->add_option("--iterations", o->mesh.cvt.maxIterations, "maximum Lloyd iterations (1 to 1000)")
      ->check(wholeNumberIn(1, meshing::kMaxLloydIterations))
      ->capture_default_str();
  app->add_option("--merge", o->mesh.cvt.mergeFraction,
                  "contract Voronoi edges shorter than this fraction of the median (0: never)")
      ->capture_default_str();
  app->add_option("--refinement", o->mesh.cvt.refinement,
                  "refined-mesh edges per cell radius used by the CVT (1 to 20)")
      ->capture_default_str();
  app->add_option("--restarts", o->mesh.cvt.restarts, "Lloyd runs from different starts, lowest energy kept (1 to 20)")
      ->check(wholeNumberIn(1, meshing::kMaxRestarts))
      ->capture_default_str();
  app->add_option("--tolerance", o->mesh.cvt.tolerance, "Lloyd stops when no seed moves more than this x cell radius")
      ->capture_default_str();
  app->add_option("--boundary", o->boundary,
                  "open surfaces: 'rim' (rods along the boundary close the border cells) or 'free' (free rod ends)")
      ->capture_default_str();
  app->add_option("--edge-length", o->mesh.edgeLength, "rod edge length in metres (default: mean rod length / 10)");
  app->add_option("--pose", o->poses, "deformed copy of the surface (same connectivity): one target pose each");
  app->add_option(
         "--fix-box", o->fixBox,
         "fix rod vertices whose rest position lies in the box XMIN YMIN ZMIN XMAX YMAX ZMAX (metres, repeatable)")
      ->expected(6)
      ->check(realNumberIn({-limits::kMaxCoordinate, limits::kMaxCoordinate, false, false, "m"}))
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  app->add_option("--fix-vertices", o->fixVerticesFile,
                  "file of zero-based surface vertex indices; the nearest rod vertex of each is fixed");
  app->add_option("--scale", o->scale,
                  "multiply surface coordinates by this factor, 1e-6 to 1e6 (e.g. 0.001 for millimetres)")
      ->capture_default_str();
  app->add_option("--young-modulus", o->mesh.material.youngModulus, "Young's modulus [Pa]")->capture_default_str();
  app->add_option("--poisson-ratio", o->mesh.material.poissonRatio, "Poisson ratio")->capture_default_str();
  app->add_option("--material-density", o->mesh.material.density, "material density [kg/m^3]")->capture_default_str();
  app->add_option("--radius", o->radius, "initial cross-section radii R_T [R_N] in metres")
      ->expected(1, 2)
      ->capture_default_str();
  app->add_option("--radius-bounds", o->radiusBounds, "design bounds MIN MAX on every radius, metres")
      ->expected(2)
      ->capture_default_str();
  app->add_option("--design", o->design, "free design parameters: radii,rest_shape | radii | rest_shape | none")
      ->capture_default_str();
  app->add_option("--control-points", o->mesh.controlPointsPerRod, "design control points per rod")
      ->check(wholeNumberIn(2, meshing::kMaxControlPoints))
      ->capture_default_str();
  app->add_option("--gravity", o->gravity, "gravity vector GX GY GZ [m/s^2] (default: none)")->expected(3);

  Command c;
  c.app = app;
  c.run = [o, app, &global]() -> int {
    requireFiniteNumbers(*app, kRealFlags);
    if (!o->cellsSpill.empty()) {
      if (!o->surface.empty() || app->count("--grid") > 0)
        throw InputError("--cells: '" + o->cellsSpill + "' is not a cell count");
      o->surface = o->cellsSpill;
    }
    const bool grid = app->count("--grid") > 0;
    if (!o->cellsBad.empty())
      throw InputError("--cells must be " +
                       (grid ? std::string("two whole numbers NX NY >= 1")
                             : "a whole number in [2, " + std::to_string(meshing::kMaxCells) + "]") +
                       " (got '" + o->cellsBad + "')");
    if (grid == !o->surface.empty())
      throw InputError(grid ? "give either a SURFACE or --grid, not both (got SURFACE '" + o->surface + "' and --grid)"
                            : "give a SURFACE to mesh or --grid hex|quad|tri to generate a sheet");
    // Flags that belong to the other route are mistakes, not silently ignored.
    static const std::vector<std::string> surfaceOnly = {
        "--dual",      "--faces",    "--density",     "--iterations", "--merge",   "--refinement",   "--restarts",
        "--tolerance", "--boundary", "--edge-length", "--pose",       "--fix-box", "--fix-vertices", "--scale"};
    static const std::vector<std::string> gridOnly = {"--size",     "--rod-vertices", "--fit",
                                                      "--hex-rows", "--fix-side",     "--pull"};
    for (const std::string& f : grid ? surfaceOnly : gridOnly)
      if (app->count(f) > 0)
        throw InputError(f + (grid ? " applies to a SURFACE, not to --grid" : " applies to --grid only"));
    if (!grid && o->cells.size() == 2)
      throw InputError("--cells takes one number N with a SURFACE (NX NY is for --grid)");
    if (!grid && o->cells.size() == 1) o->mesh.cvt.cells = o->cells[0];

    meshing::MeshOptions& m = o->mesh;
    m.method = o->dual ? meshing::MeshMethod::Dual : meshing::MeshMethod::Cells;
    if (o->boundary == "rim")
      m.cvt.boundary = meshing::BoundaryMode::Rim;
    else if (o->boundary == "free")
      m.cvt.boundary = meshing::BoundaryMode::Free;
    else
      throw InputError("--boundary must be 'rim' or 'free' (got '" + o->boundary + "')");
    if (!(o->scale >= kMinScale && o->scale <= kMaxScale))
      throw InputError("--scale must lie in [" + fmt(kMinScale) + ", " + fmt(kMaxScale) + "] (got " + fmt(o->scale) +
                       ")");
    m.radius = o->radius.size() == 1 ? Vec2(o->radius[0], o->radius[0]) : Vec2(o->radius[0], o->radius[1]);
    m.radiusMin = o->radiusBounds[0];
    m.radiusMax = o->radiusBounds[1];
    if (o->design == "radii,rest_shape" || o->design == "rest_shape,radii")
      m.designRadii = m.designRestShape = true;
    else if (o->design == "radii")
      m.designRadii = true, m.designRestShape = false;
    else if (o->design == "rest_shape")
      m.designRadii = false, m.designRestShape = true;
    else if (o->design == "none")
      m.designRadii = m.designRestShape = false;
    else
      throw InputError("--design must be radii,rest_shape | radii | rest_shape | none (got '" + o->design + "')");
    if (o->fixBox.size() % 6 != 0) throw InputError("--fix-box needs six numbers");
    for (std::size_t i = 0; i < o->fixBox.size(); i += 6)
      m.fixBoxes.push_back({Vec3(o->fixBox[i], o->fixBox[i + 1], o->fixBox[i + 2]),
                            Vec3(o->fixBox[i + 3], o->fixBox[i + 4], o->fixBox[i + 5])});
    if (!o->gravity.empty()) m.gravity = Vec3(o->gravity[0], o->gravity[1], o->gravity[2]);

    if (grid) {
      const meshing::GridResult res = meshing::makeGridSheet(gridOptions(*o, m));
      checkAndWrite(res.scene, o->output);
      if (!global.quiet) {
        std::cerr << meshing::formatGridReport(res.report);
        std::cerr << "wrote " << o->output << "\n";
        if (res.report.fixedVertices == 0)
          std::cerr << "note: no vertex is fixed (--fix-side); the sheet is free floating\n";
      }
      return kExitDone;
    }

    meshing::validateOptions(m);

    std::vector<char> flips;
    meshing::TriSurface surface = meshing::validateSurface(meshing::readPolygonFile(o->surface), o->surface, &flips);
    scaleSurface(surface, o->scale);
    std::vector<meshing::DeformedPose> poses;
    for (const std::string& p : o->poses) {
      meshing::DeformedPose dp;
      dp.name = stemOf(p);
      dp.surface = meshing::readDeformedCopy(p, surface, flips);
      scaleSurface(dp.surface, o->scale);
      poses.push_back(std::move(dp));
    }
    std::vector<double> density;
    if (!o->densityFile.empty())
      density = meshing::readDensityFile(o->densityFile, static_cast<int>(surface.vertices.size()));
    if (!o->fixVerticesFile.empty())
      m.fixSurfaceVertices = meshing::readVertexListFile(o->fixVerticesFile, static_cast<int>(surface.vertices.size()));

    meshing::MeshResult res = meshing::meshSurface(surface, poses, density, m);
    checkAndWrite(res.scene, o->output);
    if (!global.quiet) {
      std::cerr << meshing::formatReport(res.report);
      std::cerr << "poses:";
      for (const Pose& p : res.scene.poses)
        std::cerr << " " << p.name << (p.target.empty() ? "" : " (target)") << " [" << p.fixed.size() << " fixed]";
      std::cerr << "\nwrote " << o->output << "\n";
      if (res.report.fixedVertices == 0)
        std::cerr << "note: no vertex is fixed (--fix-box / --fix-vertices); the rod mesh is free floating\n";
    }
    return kExitDone;
  };
  return c;
}

}  // namespace rodmesh::cli
