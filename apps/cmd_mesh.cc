// rodmesh mesh SURFACE -o SCENE.json: a rod-mesh scene from a triangle surface
// (and target poses from deformed copies of it). See docs/meshing.md.
#include "apps/commands.hh"
#include "io/scene_reader.hh"
#include "io/scene_writer.hh"
#include "meshing/rod_mesher.hh"
#include "meshing/surface.hh"

#include <iostream>
#include <memory>
#include <sstream>

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

}  // namespace

Command registerMesh(CLI::App& root, const GlobalOptions& global) {
  auto o = std::make_shared<MeshCliOptions>();
  CLI::App* app = root.add_subcommand("mesh", "rod-mesh scene from a triangle surface (.obj, .off, .ply)");
  app->add_option("surface", o->surface, "input triangle surface (.obj, .off or .ply), metres (see --scale)")
      ->required();
  app->add_option("-o,--output", o->output, "scene file to write (rodmesh-scene/1 JSON)")->required();
  app->add_option("--cells", o->mesh.cvt.cells, "number of cells of the centroidal Voronoi tessellation")
      ->capture_default_str();
  app->add_flag("--dual", o->dual, "dual of a decimated surface instead of a Voronoi tessellation");
  app->add_option("--faces", o->mesh.dualFaces, "with --dual: face count of the decimated surface")
      ->capture_default_str();
  app->add_option("--density", o->densityFile,
                  "per-vertex density file (one positive value per surface vertex); cells shrink as density^-1/4");
  app->add_option("--iterations", o->mesh.cvt.maxIterations, "maximum Lloyd iterations")->capture_default_str();
  app->add_option("--merge", o->mesh.cvt.mergeFraction,
                  "contract Voronoi edges shorter than this fraction of the median (0: never)")
      ->capture_default_str();
  app->add_option("--refinement", o->mesh.cvt.refinement, "refined-mesh edges per cell radius used by the CVT")
      ->capture_default_str();
  app->add_option("--restarts", o->mesh.cvt.restarts, "Lloyd runs from different starts (lowest energy kept)")
      ->capture_default_str();
  app->add_option("--tolerance", o->mesh.cvt.tolerance, "Lloyd stops when no seed moves more than this x cell radius")
      ->capture_default_str();
  app->add_option("--boundary", o->boundary,
                  "open surfaces: 'rim' (rods along the boundary close the border cells) or 'free' (free rod ends)")
      ->capture_default_str();
  app->add_option("--edge-length", o->mesh.edgeLength, "rod edge length in metres (default: mean rod length / 10)");
  app->add_option("--pose", o->poses, "deformed copy of the surface (same connectivity): one target pose each");
  app->add_option("--fix-box", o->fixBox,
                  "fix rod vertices whose rest position lies in the box XMIN YMIN ZMIN XMAX YMAX ZMAX (metres, repeatable)")
      ->expected(6)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  app->add_option("--fix-vertices", o->fixVerticesFile,
                  "file of zero-based surface vertex indices; the nearest rod vertex of each is fixed");
  app->add_option("--scale", o->scale, "multiply surface coordinates by this factor (e.g. 0.001 for millimetres)")
      ->capture_default_str();
  app->add_option("--young-modulus", o->mesh.material.youngModulus, "Young's modulus [Pa]")->capture_default_str();
  app->add_option("--poisson-ratio", o->mesh.material.poissonRatio, "Poisson ratio")->capture_default_str();
  app->add_option("--material-density", o->mesh.material.density, "material density [kg/m^3]")
      ->capture_default_str();
  app->add_option("--radius", o->radius, "initial cross-section radii R_T [R_N] in metres")
      ->expected(1, 2)
      ->capture_default_str();
  app->add_option("--radius-bounds", o->radiusBounds, "design bounds MIN MAX on every radius, metres")
      ->expected(2)
      ->capture_default_str();
  app->add_option("--design", o->design, "free design parameters: radii,rest_shape | radii | rest_shape | none")
      ->capture_default_str();
  app->add_option("--control-points", o->mesh.controlPointsPerRod, "design control points per rod")
      ->capture_default_str();
  app->add_option("--gravity", o->gravity, "gravity vector GX GY GZ [m/s^2] (default: none)")->expected(3);

  Command c;
  c.app = app;
  c.run = [o, &global]() -> int {
    meshing::MeshOptions& m = o->mesh;
    m.method = o->dual ? meshing::MeshMethod::Dual : meshing::MeshMethod::Cells;
    if (o->boundary == "rim") m.cvt.boundary = meshing::BoundaryMode::Rim;
    else if (o->boundary == "free") m.cvt.boundary = meshing::BoundaryMode::Free;
    else throw InputError("--boundary must be 'rim' or 'free' (got '" + o->boundary + "')");
    if (!(o->scale > 0)) throw InputError("--scale must be positive");
    m.radius = o->radius.size() == 1 ? Vec2(o->radius[0], o->radius[0]) : Vec2(o->radius[0], o->radius[1]);
    m.radiusMin = o->radiusBounds[0];
    m.radiusMax = o->radiusBounds[1];
    if (o->design == "radii,rest_shape" || o->design == "rest_shape,radii") m.designRadii = m.designRestShape = true;
    else if (o->design == "radii") m.designRadii = true, m.designRestShape = false;
    else if (o->design == "rest_shape") m.designRadii = false, m.designRestShape = true;
    else if (o->design == "none") m.designRadii = m.designRestShape = false;
    else throw InputError("--design must be radii,rest_shape | radii | rest_shape | none (got '" + o->design + "')");
    if (o->fixBox.size() % 6 != 0) throw InputError("--fix-box needs six numbers");
    for (std::size_t i = 0; i < o->fixBox.size(); i += 6)
      m.fixBoxes.push_back({Vec3(o->fixBox[i], o->fixBox[i + 1], o->fixBox[i + 2]),
                            Vec3(o->fixBox[i + 3], o->fixBox[i + 4], o->fixBox[i + 5])});
    if (!o->gravity.empty()) m.gravity = Vec3(o->gravity[0], o->gravity[1], o->gravity[2]);
    meshing::validateOptions(m);

    std::vector<char> flips;
    meshing::TriSurface surface =
        meshing::validateSurface(meshing::readPolygonFile(o->surface), o->surface, &flips);
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
    // The scene must satisfy the contract: parse our own output before writing.
    const std::string json = sceneToJson(res.scene);
    try {
      parseScene(json, o->output);
    } catch (const InputError& e) {
      throw std::runtime_error(std::string("internal error: the generated scene is invalid: ") + e.what());
    }
    writeSceneFile(res.scene, o->output);
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
