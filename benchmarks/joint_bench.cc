// Cost of the derivatives the optimizers call, against a simulation Hessian,
// on a scene (default examples/sheet.json, pose 0, at its equilibrium):
// energy + gradient + Hessian (simulation), joint values in their fixed
// patterns, the third-order directional product, and (dF/dp)^T lambda.
// Prints medians of 15 runs in ms: wall time and the process's CPU time (all
// threads; on a machine shared with other work the CPU time is the steadier
// of the two). With --breakdown, the same per kind of energy term. With
// --only sim|values|third|product, just that evaluation, --runs times (for a
// profiler: perf record rodmesh_joint_bench --only values --runs 300), and
// with --term stretch|bend|connection|gravity, for that kind of term only.
// usage: rodmesh_joint_bench [--breakdown] [--only WHAT] [--runs N] [--term T] [SCENE.json]
#include "io/scene_reader.hh"
#include "solver/equilibrium.hh"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

using namespace rodmesh;

namespace {

struct Timing {
  double wall = 0.0, cpu = 0.0;  // medians, ms
};

double cpuMs() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

Timing median(const std::function<void()>& fn, int runs = 15) {
  std::vector<double> w, c;
  for (int i = 0; i < runs; ++i) {
    const double c0 = cpuMs();
    const auto t0 = std::chrono::steady_clock::now();
    fn();
    w.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    c.push_back(cpuMs() - c0);
  }
  std::sort(w.begin(), w.end());
  std::sort(c.begin(), c.end());
  return {w[w.size() / 2], c[c.size() / 2]};
}

void row(const char* name, const Timing& t, const Timing& sim) {
  std::printf("%-36s %8.2f ms  (%5.2fx)   cpu %8.2f ms  (%5.2fx)\n", name, t.wall, t.wall / sim.wall, t.cpu,
              t.cpu / sim.cpu);
}

}  // namespace

int main(int argc, char** argv) {
  bool breakdown = false;
  std::string only;
  int runs = 15;
  std::string term;
  std::string path = RODMESH_SOURCE_DIR "/examples/sheet.json";
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--breakdown") == 0) breakdown = true;
    else if (std::strcmp(argv[i], "--only") == 0 && i + 1 < argc) only = argv[++i];
    else if (std::strcmp(argv[i], "--runs") == 0 && i + 1 < argc) runs = std::max(1, std::atoi(argv[++i]));
    else if (std::strcmp(argv[i], "--term") == 0 && i + 1 < argc) term = argv[++i];
    else path = argv[i];
  }
  const Scene scene = readSceneFile(path);
  SceneModel model(scene);
  const Design d = Design::fromScene(scene);
  const PoseSystem& sys = model.pose(0);
  PoseState state = sys.restState(d);
  solveEquilibrium(sys, d, state, NewtonOptions{});
  Eigen::VectorXd g;
  Eigen::SparseMatrix<double> H;
  const Eigen::VectorXd lambda = Eigen::VectorXd::Ones(sys.numDofs());
  JointDerivatives j;
  if (!only.empty()) {
    using Terms = PoseSystem::Terms;
    Terms terms = Terms::All;
    if (!term.empty()) {
      try {
        terms = Terms::named(term == "bend" ? "bend_twist" : term);
      } catch (const std::invalid_argument& e) {
        std::fprintf(stderr, "--term: %s\n", e.what());
        return 2;
      }
    }
    std::function<void()> fn;
    if (only == "sim") fn = [&] { sys.evaluate(state, d, &g, &H, terms); };
    else if (only == "values") fn = [&] { sys.evaluateJoint(state, d, j, nullptr, terms); };
    else if (only == "third") fn = [&] { sys.evaluateJoint(state, d, j, &lambda, terms); };
    else if (only == "product") fn = [&] { sys.designForceProduct(state, d, lambda, nullptr, terms); };
    else {
      std::fprintf(stderr, "--only: sim, values, third or product, not '%s'\n", only.c_str());
      return 2;
    }
    const Timing t = median(fn, runs);
    std::printf("%s: %d runs, median %.2f ms, cpu %.2f ms\n", only.c_str(), runs, t.wall, t.cpu);
    return 0;
  }
  const Timing sim = median([&] { sys.evaluate(state, d, &g, &H); });
  const Timing values = median([&] { sys.evaluateJoint(state, d, j); });
  const Timing third = median([&] { sys.evaluateJoint(state, d, j, &lambda); });
  const Timing product = median([&] { sys.designForceProduct(state, d, lambda); });
  std::printf("unknowns %d, design parameters %d, pattern nnz: Huu %ld (full), Hup %ld, Hpp %ld (lower)\n",
              sys.numDofs(), d.numParameters(), static_cast<long>(j.Huu.nonZeros()),
              static_cast<long>(j.Hup.nonZeros()), static_cast<long>(j.Hpp.nonZeros()));
  std::printf("stencils:");
  for (std::size_t t = 0; t < PoseSystem::termKinds().size(); ++t)
    std::printf("%s %d %s", t ? "," : "", sys.termCount(static_cast<int>(t)), PoseSystem::termKinds()[t].name);
  std::printf("\n");
  row("simulation energy+gradient+Hessian", sim, sim);
  row("joint values (fixed patterns)", values, sim);
  row("joint third-order directional", third, sim);
  row("(dF/dp)^T lambda, first order", product, sim);
  if (breakdown) {
    using Terms = PoseSystem::Terms;
    std::printf("per term, cpu ms: simulation / joint values / third order / product\n");
    for (std::size_t k = 0; k < PoseSystem::termKinds().size(); ++k) {
      if (sys.termCount(static_cast<int>(k)) == 0) continue;
      const Terms t = Terms::only(static_cast<int>(k));
      const char* name = PoseSystem::termKinds()[k].name;
      const Timing s = median([&] { sys.evaluate(state, d, &g, &H, t); });
      const Timing v = median([&] { sys.evaluateJoint(state, d, j, nullptr, t); });
      const Timing th = median([&] { sys.evaluateJoint(state, d, j, &lambda, t); });
      const Timing p = median([&] { sys.designForceProduct(state, d, lambda, nullptr, t); });
      std::printf("  %-12s %8.2f %8.2f %8.2f %8.2f\n", name, s.cpu, v.cpu, th.cpu, p.cpu);
    }
  }
  return 0;
}
