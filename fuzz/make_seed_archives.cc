// Seed corpus for fuzz_archive: writes, for each scene file given, three
// archives shaped like those of `simulate`, `optimize` and `simulate
// --dynamic` (rest and pose positions from the scene, no solve), so that
// the fuzzer starts from every part of the format.
//   make_seed_archives OUTDIR SCENE.json...
#include "io/archive.hh"
#include "io/scene_reader.hh"
#include "model/network.hh"

#include <cstdio>
#include <string>

using namespace rodmesh;

namespace {

MatX3 rows3(const std::vector<Vec3>& v, double shift) {
  MatX3 m(static_cast<Eigen::Index>(v.size()), 3);
  for (std::size_t i = 0; i < v.size(); ++i) m.row(i) = v[i].transpose() + Eigen::RowVector3d(0, 0, shift * i);
  return m;
}

Archive simulateLike(const Scene& s, const std::string& text) {
  const RodNetwork net(s);
  Archive a;
  a.version = "seed";
  a.command = "simulate";
  a.status = "converged";
  a.sceneJson = text;
  a.effects = "stretch,bend,twist";
  a.effectsReason = "seed archive";
  a.nVertices = net.numVertices();
  a.nEdges = net.numEdges();
  a.nRods = net.numRods();
  a.nConnections = net.numConnections();
  a.dofsPerPose = 3 * a.nVertices + a.nEdges;
  a.restPositions = rows3(s.vertices, 0);
  a.radii.resize(a.nVertices, 2);
  for (int i = 0; i < a.nVertices; ++i) a.radii.row(i) = s.radii[i].transpose();
  for (const Pose& p : s.poses) {
    ArchivePose ap;
    ap.name = p.name;
    ap.positions = rows3(s.vertices, -1e-4);
    ap.twist = Eigen::VectorXd::Constant(a.nEdges, 0.01);
    if (!p.target.empty()) {
      ap.target = rows3(p.target, 0);
      ap.rmsError = 1e-4;
    }
    ap.residualNorm = 1e-9;
    ap.status = "converged";
    ap.iterations = 3;
    ap.timeSeconds = 0.01;
    a.poses.push_back(std::move(ap));
  }
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s OUTDIR SCENE.json...\n", argv[0]);
    return 2;
  }
  const std::string out = argv[1];
  int written = 0;
  for (int k = 2; k < argc; ++k) {
    try {
      const std::string text = readInputFile(argv[k], "scene file");
      const Scene s = parseScene(text, argv[k]);
      const std::string stem = out + "/seed" + std::to_string(k - 1);
      Archive a = simulateLike(s, text);
      writeArchive(a, stem + "_simulate.h5");

      Archive o = a;
      o.command = "optimize";
      o.status = "not_converged";
      o.initialRadii = a.radii * 1.5;
      for (ArchivePose& p : o.poses) {
        p.initialPositions = p.positions;
        p.equilibriumGap = 1e-12;
      }
      ArchiveControlPoints c;
      for (int r = 0; r < a.nRods; ++r) {
        c.rod.push_back(-1);  // shared end control point on the rod's first vertex
        c.arcFraction.push_back(0.0);
        c.vertex.push_back(s.rods[r].vertices.front());
        c.rod.push_back(r);  // interior control point in the middle
        c.arcFraction.push_back(0.5);
        c.vertex.push_back(-1);
      }
      c.radii = MatX2::Constant(static_cast<Eigen::Index>(c.rod.size()), 2, 1e-3);
      c.restDisplacement = MatX3::Zero(static_cast<Eigen::Index>(c.rod.size()), 3);
      o.controlPoints = c;
      ArchiveHistory h;
      h.iteration = {0, 1, 2};
      h.timeSeconds = {0.0, 0.5, 1.0};
      h.objective = {1.0, 0.5, 0.25};
      h.rmsError = {1e-3, 5e-4, 2e-4};
      h.level = {0, 1, 2};
      h.constraintViolation = {0, 0, 0};
      h.gradientNorm = {1, 0.1, 0.01};
      h.phase = {"radii", "radii", "rest_shape"};
      o.history = h;
      o.optimize = ArchiveOptimizeSummary{"reduced", 3, 1.0, "seed"};
      writeArchive(o, stem + "_optimize.h5");

      Archive d = a;
      ArchiveFrames f;
      f.name = a.poses.front().name;
      f.time = Eigen::VectorXd::LinSpaced(3, 0.0, 0.1);
      f.positions = {a.restPositions, a.poses.front().positions, a.poses.front().positions};
      d.frames = {f};
      writeArchive(d, stem + "_dynamic.h5");
      written += 3;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s\n", e.what());
      return 1;
    }
  }
  std::printf("%d seed archives in %s\n", written, out.c_str());
  return 0;
}
