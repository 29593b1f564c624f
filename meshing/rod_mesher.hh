// From a surface to a rod-mesh scene (paper §4.1 and §5 "Design pipeline").
//
//   surface --(CVT or dual of a decimation)--> layout (connections + links)
//           --(geodesics, resampling)--------> rods, each vertex with its
//                                              face + barycentric location
//           --(same locations on deformed copies)--> pose targets
//
// Every rod vertex is a point of the input surface (its SurfacePoint), so its
// target in a pose is the same point of the deformed copy, exactly.
#pragma once

#include "meshing/cvt.hh"
#include "meshing/layout.hh"
#include "meshing/surface.hh"
#include "model/limits.hh"
#include "model/scene.hh"

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace rodmesh::meshing {

enum class MeshMethod { Cells, Dual };

struct FixBox {
  Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();
};

struct DeformedPose {
  std::string name;
  TriSurface surface;  // same connectivity as the input surface
};

struct MeshOptions {
  MeshMethod method = MeshMethod::Cells;
  CvtOptions cvt;              // --cells, boundary handling
  int dualFaces = 200;         // --faces: target face count of the decimated surface
  double edgeLength = 0.0;     // rod edge length [m]; 0: mean link length / 10
  int minEdgesPerRod = 2;      // every rod gets at least this many edges
  Material material{32e6, 0.48, 1200.0};  // TPU 92A (paper Table 1)
  Vec2 radius{0.002, 0.002};   // initial [r_t, r_n] [m]
  double radiusMin = 0.001, radiusMax = 0.005;  // design bounds [m]
  bool designRadii = true, designRestShape = true;
  int controlPointsPerRod = 4;
  std::optional<Vec3> gravity;
  std::vector<FixBox> fixBoxes;        // rod vertices whose rest position lies inside
  std::vector<int> fixSurfaceVertices; // input vertices -> nearest rod vertex
};

// Limits checked by validateOptions (docs/meshing.md): beyond them the work,
// or the result, is unreasonable. The CVT's refined mesh is capped at
// CvtOptions::maxWorkFaces whatever the refinement, so its cost is bounded by
// maxWorkFaces x iterations x restarts.
constexpr int kMaxCells = 10000;           // --cells
constexpr int kMaxLloydIterations = 1000;  // --iterations
constexpr int kMaxRestarts = 20;           // --restarts
constexpr double kMinRefinement = 1.0;     // --refinement
constexpr double kMaxRefinement = 20.0;
constexpr int kMaxDualFaces = 1000000;     // --faces
// The material, radius, gravity, force and control point limits are the
// plausible ranges every scene is checked against (model/limits.hh).
constexpr double kMaxLength = limits::kMaxRadius;              // --edge-length, --radius, --radius-bounds [m]
constexpr double kMaxYoungModulus = limits::kMaxYoungModulus;  // [Pa]
constexpr double kMaxDensity = limits::kMaxDensity;            // --material-density [kg/m^3]
constexpr double kMaxGravity = limits::kMaxGravity;            // per component [m/s^2]
constexpr int kMaxControlPoints = limits::kMaxControlPoints;   // --control-points
constexpr double kMaxRodVertices = 1e6;    // rod vertices of one mesh (edge length vs rod lengths)
// meshSurface: the surface's bounding-box diagonal, in metres (after --scale).
constexpr double kMinSurfaceSize = 1e-6;
constexpr double kMaxSurfaceSize = limits::kMaxCoordinate;

// Throws InputError naming the flag and the value for options out of range or
// inconsistent (NaN and infinities are out of every range).
void validateOptions(const MeshOptions& o);

struct MeshReport {
  int cells = 0;                      // Voronoi cells / dual polygons
  std::map<int, int> polygonSides;    // sides -> number of closed cells
  int closedCells = 0, openCells = 0;
  double hexagonShare = 0.0;          // hexagons / closed cells
  int interiorCells = 0, interiorHexagons = 0;  // closed cells not touching the surface boundary
  double interiorHexagonShare = 0.0;
  std::map<int, int> valence;         // rods at a node -> number of nodes
  int connections = 0, freeEnds = 0;
  int vertices = 0, rods = 0, edges = 0;
  double edgeLength = 0.0;
  double minRodLength = 0.0, maxRodLength = 0.0, meanRodLength = 0.0;
  double maxSurfaceDistance = 0.0;    // max distance of a rod vertex to the surface point it maps to
  int fixedVertices = 0;
  CvtReport cvt;
  double seconds = 0.0;
};

struct MeshResult {
  Scene scene;
  MeshReport report;
  std::vector<SurfacePoint> locations;  // per scene vertex, on the input surface
};

// Builds the layout (CVT or dual) for the surface.
Layout buildLayout(const TriSurface& surface, const SurfaceTopology& topo, const MeshOptions& opt,
                   const std::vector<double>& density, CvtReport* cvtReport);

// The whole pipeline. `density` is empty or one value per input vertex.
MeshResult meshSurface(const TriSurface& surface, const std::vector<DeformedPose>& poses,
                       const std::vector<double>& density, const MeshOptions& opt);

// Human-readable summary (several lines, millimetres).
std::string formatReport(const MeshReport& r);

// One positive finite value per surface vertex, whitespace separated ('#'
// comments allowed). Throws InputError naming the file and the value.
std::vector<double> readDensityFile(const std::string& path, int numSurfaceVertices);
// Zero-based surface vertex indices, whitespace or comma separated.
std::vector<int> readVertexListFile(const std::string& path, int numSurfaceVertices);

}  // namespace rodmesh::meshing
