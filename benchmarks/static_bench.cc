// Static-solve benchmarks (not a test): writes CSV files and a markdown
// summary naming the machine.
//
//   rodmesh_bench [--out DIR] [--quick] [--repeat N]
//
// 1. scaling:  time of a static solve and per Newton iteration against vertex
//              count (rods of 100 vertices sagging under gravity, 3D with twist),
//              100 to 100,000 vertices; fitted exponent of time per iteration.
// 2. accuracy: cantilever tip deflection error against vertices per rod and
//              solve time (what accuracy costs in time), against the closed
//              form P L^3 / (3 E I) at a load small enough for linear theory.
// 3. planar:   the same planar scene solved with in-plane unknowns and with
//              full 3D unknowns: unknowns and time.
// 4. target:   20 rods x 85 vertices under gravity (about 7,000 unknowns).
#include "solver/equilibrium.hh"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <sys/stat.h>
#include <vector>

using namespace rodmesh;

namespace {

std::string machineName() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown CPU";
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// `rods` parallel rods of `verts` vertices along x, spaced in y, clamped at
// x = 0, under gravity with a small sideways component (so the scene is 3D).
Scene gravityRods(int rods, int verts, double length, bool planar = false) {
  Scene s;
  s.sourcePath = "<bench>";
  s.material = Material{3.2e7, 0.48, 1200.0};
  Pose p;
  p.name = "gravity";
  for (int r = 0; r < rods; ++r) {
    Rod rod;
    for (int i = 0; i < verts; ++i) {
      rod.vertices.push_back(static_cast<int>(s.vertices.size()));
      s.vertices.push_back(Vec3(length * i / (verts - 1), 0.02 * r, 0.0));
    }
    p.clamped.push_back({rod.vertices.front()});
    s.rods.push_back(rod);
  }
  s.radii.assign(s.vertices.size(), Vec2(0.002, 0.0015));
  s.gravity = planar ? Vec3(0.0, 0.0, 0.0) : Vec3(0.0, 0.5, -9.81);
  if (planar) {
    // In-plane load at the tips instead of gravity.
    for (const Rod& rod : s.rods) p.forces.push_back({rod.vertices.back(), Vec3(0.0, -0.02, 0.0)});
    s.gravity.reset();
  }
  s.poses.push_back(p);
  return s;
}

struct Timing {
  double solve = 0, perIteration = 0, assembly = 0, factor = 0;
  int iterations = 0, dofs = 0;
  bool converged = false;
  double relResidual = 0;
  std::vector<Vec3> x;
};

Timing timeSolve(const Scene& scene, int repeat) {
  std::vector<double> t, ti, ta, tf;
  Timing out;
  for (int k = 0; k < repeat; ++k) {
    SceneModel model(scene);
    Design d = Design::fromScene(scene);
    const PoseSystem& sys = model.pose(0);
    Eigen::VectorXd u = sys.restDofs(d);
    NewtonOptions opt;
    const auto t0 = std::chrono::steady_clock::now();
    NewtonReport r = solveEquilibrium(sys, d, u, opt);
    const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    t.push_back(sec);
    ti.push_back(sec / std::max(1, r.iterations));
    ta.push_back(r.assemblySeconds);
    tf.push_back(r.factorSeconds);
    out.iterations = r.iterations;
    out.dofs = sys.numDofs();
    out.converged = r.converged();
    out.relResidual = r.relativeResidual;
    out.x = sys.positions(PoseState{u, sys.restCharts(d), 1.0, {}}, d);
  }
  out.solve = median(t);
  out.perIteration = median(ti);
  out.assembly = median(ta);
  out.factor = median(tf);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::string outDir = "benchmarks/results";
  bool quick = false;
  int repeat = 3;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--out" && i + 1 < argc) outDir = argv[++i];
    else if (a == "--quick") quick = true;
    else if (a == "--repeat" && i + 1 < argc) repeat = std::stoi(argv[++i]);
    else {
      std::cerr << "usage: rodmesh_bench [--out DIR] [--quick] [--repeat N]\n";
      return 2;
    }
  }
  mkdir(outDir.c_str(), 0755);
  const std::string machine = machineName();
  std::ostringstream md;
  md << "# Static solve benchmarks\n\nMachine: " << machine << " (one thread). Medians of " << repeat
     << " runs. Regenerate with `./build/benchmarks/rodmesh_bench --out benchmarks/results`.\n\n";

  // 1. Scaling.
  {
    std::ofstream csv(outDir + "/static_scaling.csv");
    csv << "vertices,unknowns,iterations,solve_s,per_iteration_s,assembly_s,factor_s,converged\n";
    md << "## Solve time against vertex count\n\nRods of 100 vertices, 0.1 m long, clamped, sagging under gravity "
          "(3D, twist on).\n\n| vertices | unknowns | Newton iterations | solve (s) | per iteration (ms) | assembly (s) | "
          "factorization (s) |\n|---|---|---|---|---|---|---|\n";
    std::vector<int> counts = quick ? std::vector<int>{1, 10, 100} : std::vector<int>{1, 10, 100, 1000};
    std::vector<double> lx, ly;
    for (int rods : counts) {
      const Scene s = gravityRods(rods, 100, 0.1);
      const Timing t = timeSolve(s, rods >= 1000 ? 1 : repeat);
      const int nv = static_cast<int>(s.vertices.size());
      csv << nv << "," << t.dofs << "," << t.iterations << "," << t.solve << "," << t.perIteration << "," << t.assembly
          << "," << t.factor << "," << t.converged << "\n";
      char row[256];
      std::snprintf(row, sizeof row, "| %d | %d | %d | %.4f | %.3f | %.4f | %.4f |\n", nv, t.dofs, t.iterations, t.solve,
                    t.perIteration * 1e3, t.assembly, t.factor);
      md << row;
      std::cerr << row;
      lx.push_back(std::log(nv));
      ly.push_back(std::log(t.perIteration));
    }
    // Least-squares slope of log(time per iteration) against log(vertices).
    const double n = lx.size();
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (std::size_t i = 0; i < lx.size(); ++i) { sx += lx[i]; sy += ly[i]; sxx += lx[i] * lx[i]; sxy += lx[i] * ly[i]; }
    const double slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
    char line[128];
    std::snprintf(line, sizeof line, "\nFitted exponent of time per Newton iteration against vertices: **%.2f**.\n\n", slope);
    md << line;
    std::cerr << line;
  }

  // 4. The 7,000-unknown target.
  {
    const Scene s = gravityRods(20, 85, 0.1);
    const Timing t = timeSolve(s, repeat);
    char line[256];
    std::snprintf(line, sizeof line,
                  "## 20 rods x 85 vertices under gravity\n\n%d unknowns: %d Newton iterations, **%.3f s** per static "
                  "solve (assembly %.3f s, factorization %.3f s), relative residual %.1e.\n\n",
                  t.dofs, t.iterations, t.solve, t.assembly, t.factor, t.relResidual);
    md << line;
    std::cerr << line;
    std::ofstream csv(outDir + "/static_target.csv");
    csv << "unknowns,iterations,solve_s,assembly_s,factor_s,relative_residual\n"
        << t.dofs << "," << t.iterations << "," << t.solve << "," << t.assembly << "," << t.factor << "," << t.relResidual
        << "\n";
  }

  // 2. Accuracy against time: cantilever tip deflection.
  {
    std::ofstream csv(outDir + "/cantilever_accuracy.csv");
    csv << "vertices_per_rod,unknowns,solve_s,tip_deflection_m,exact_m,relative_error\n";
    md << "## Cantilever: error against vertices per rod against time\n\nClamped cantilever, L = 0.1 m, r = [2, 1] mm, "
          "E = 32 MPa, tip load along the normal with P L^2 / (E I) = 1e-4 (linear regime), exact P L^3 / (3 E I).\n\n"
          "| vertices per rod | unknowns | solve (ms) | relative error |\n|---|---|---|---|\n";
    const double L = 0.1, rt = 0.002, rn = 0.001, E = 3.2e7;
    const double I = M_PI * rt * rn * rn * rn / 4;
    const double P = 1e-4 * E * I / (L * L);
    const double exact = P * L * L * L / (3 * E * I);
    std::vector<int> verts = quick ? std::vector<int>{5, 9, 17, 33} : std::vector<int>{3, 5, 9, 17, 33, 65, 129, 257};
    for (int nvr : verts) {
      Scene s;
      s.sourcePath = "<bench>";
      s.material = Material{E, 0.48, 1200.0};
      Rod rod;
      for (int i = 0; i < nvr; ++i) { rod.vertices.push_back(i); s.vertices.push_back(Vec3(L * i / (nvr - 1), 0, 0)); }
      rod.normal = Vec3(0, 0, 1);
      s.rods.push_back(rod);
      s.radii.assign(nvr, Vec2(rt, rn));
      Pose p;
      p.name = "tip";
      p.clamped.push_back({0});
      p.forces.push_back({nvr - 1, Vec3(0, 0, -P)});
      s.poses.push_back(p);
      const Timing t = timeSolve(s, repeat);
      const double defl = -t.x.back().z();
      const double err = std::abs(defl - exact) / exact;
      csv << nvr << "," << t.dofs << "," << t.solve << "," << defl << "," << exact << "," << err << "\n";
      char row[160];
      std::snprintf(row, sizeof row, "| %d | %d | %.3f | %.2e |\n", nvr, t.dofs, t.solve * 1e3, err);
      md << row;
      std::cerr << row;
    }
    md << "\n";
  }

  // 3. Planar reduction.
  {
    std::ofstream csv(outDir + "/planar_reduction.csv");
    csv << "model,unknowns,iterations,solve_s\n";
    md << "## Planar scene: in-plane unknowns against full 3D\n\n50 rods x 100 vertices in a plane, tip loads in the "
          "plane.\n\n| model | unknowns | Newton iterations | solve (s) |\n|---|---|---|---|\n";
    Scene planar = gravityRods(50, 100, 0.1, true);
    Scene full = planar;
    full.effects = std::vector<Effect>{Effect::Stretch, Effect::Bend, Effect::Twist};
    for (int k = 0; k < 2; ++k) {
      const Timing t = timeSolve(k == 0 ? planar : full, repeat);
      const char* name = k == 0 ? "planar (2 per vertex)" : "3D with twist";
      csv << name << "," << t.dofs << "," << t.iterations << "," << t.solve << "\n";
      char row[160];
      std::snprintf(row, sizeof row, "| %s | %d | %d | %.4f |\n", name, t.dofs, t.iterations, t.solve);
      md << row;
      std::cerr << row;
    }
  }
  std::ofstream(outDir + "/static.md") << md.str();
  std::cerr << "wrote " << outDir << "/static.md\n";
  return 0;
}
