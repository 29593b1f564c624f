// Cost of the derivatives the optimizers call, against a simulation Hessian,
// on a scene (default examples/sheet.json, pose 0, at its equilibrium):
// energy + gradient + Hessian (simulation), joint values in their fixed
// patterns, the third-order directional product, and (dF/dp)^T lambda.
// Prints medians of 15 runs in ms.  usage: rodmesh_joint_bench [SCENE.json]
#include "io/scene_reader.hh"
#include "solver/equilibrium.hh"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <vector>

using namespace rodmesh;

static double medianMs(const std::function<void()>& fn) {
  std::vector<double> t;
  for (int i = 0; i < 15; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    fn();
    t.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

int main(int argc, char** argv) {
  const Scene scene = readSceneFile(argc > 1 ? argv[1] : RODMESH_SOURCE_DIR "/examples/sheet.json");
  SceneModel model(scene);
  const Design d = Design::fromScene(scene);
  PoseSystem& sys = model.pose(0);
  Eigen::VectorXd u = sys.restDofs(d);
  solveEquilibrium(sys, d, u, NewtonOptions{});
  Eigen::VectorXd g;
  double e;
  const Eigen::VectorXd lambda = Eigen::VectorXd::Ones(sys.numDofs());
  JointDerivatives j;
  const double sim = medianMs([&] { sys.evaluate(u, d, e, g, true); });
  const double values = medianMs([&] { sys.evaluateJoint(u, d, j); });
  const double third = medianMs([&] { sys.evaluateJoint(u, d, j, &lambda); });
  const double product = medianMs([&] { sys.designForceProduct(u, d, lambda); });
  std::printf("unknowns %d, design parameters %d, pattern nnz: Huu %ld (full), Hup %ld, Hpp %ld (lower)\n",
              sys.numDofs(), d.numParameters(), static_cast<long>(j.Huu.nonZeros()),
              static_cast<long>(j.Hup.nonZeros()), static_cast<long>(j.Hpp.nonZeros()));
  std::printf("simulation energy+gradient+Hessian  %8.2f ms\n", sim);
  std::printf("joint values (fixed patterns)        %8.2f ms  (%.2fx)\n", values, values / sim);
  std::printf("joint third-order directional        %8.2f ms  (%.2fx)\n", third, third / sim);
  std::printf("(dF/dp)^T lambda, first order        %8.2f ms  (%.2fx)\n", product, product / sim);
  return 0;
}
