// Where the time of a `rodmesh simulate` process goes, inside the process:
// the steps of the command run one after the other on a scene, each repeated
// and timed (median; wall-clock and CPU time of this thread):
//   read       readSceneFile
//   model      SceneModel (network, effects, one PoseSystem per pose)
//   solve      every pose by Newton from rest (solveEquilibrium)
//   stability  the out-of-plane stability check of every pose (planar scenes)
//   write      writeArchive of ARCHIVE's content (an archive `simulate` wrote
//              for this scene), to a temporary file next to OUT
// Process start-up and the whole process are timed from outside by
// benchmarks/process_overhead.sh.
//
// usage: rodmesh_overhead_bench SCENE.json ARCHIVE.h5 OUT.h5 [REPEAT]
// Prints one line per step: "step wall_ms cpu_ms" (medians).
#include "io/archive.hh"
#include "io/scene_reader.hh"
#include "solver/equilibrium.hh"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <functional>
#include <memory>
#include <string>
#include <vector>

using namespace rodmesh;

namespace {

double threadCpuMs() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return 1e3 * static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_nsec);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

void timeStep(const char* name, int repeat, const std::function<void()>& fn) {
  std::vector<double> wall, cpu;
  for (int i = 0; i < repeat; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = threadCpuMs();
    fn();
    cpu.push_back(threadCpuMs() - c0);
    wall.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::printf("%-10s %9.3f %9.3f\n", name, median(wall), median(cpu));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: rodmesh_overhead_bench SCENE.json ARCHIVE.h5 OUT.h5 [REPEAT]\n");
    return 2;
  }
  const std::string scenePath = argv[1], archivePath = argv[2], out = argv[3];
  const int repeat = argc > 4 ? std::max(1, std::atoi(argv[4])) : 15;

  Scene scene;
  timeStep("read", repeat, [&] { scene = readSceneFile(scenePath); });
  std::unique_ptr<SceneModel> model;
  timeStep("model", repeat, [&] { model = std::make_unique<SceneModel>(scene); });
  const Design design = Design::fromScene(scene);
  std::vector<std::vector<Vec3>> positions(model->numPoses());
  timeStep("solve", repeat, [&] {
    for (int p = 0; p < model->numPoses(); ++p) {
      const PoseSystem& sys = model->pose(p);
      PoseState state = sys.restState(design);
      solveEquilibrium(sys, design, state, NewtonOptions{});
      positions[p] = sys.positions(PoseState{state.u, state.charts, 1.0, {}}, design);
    }
  });
  if (model->effects().planar) {
    int stable = 0;
    timeStep("stability", repeat, [&] {
      for (int p = 0; p < model->numPoses(); ++p)
        stable += outOfPlaneStable(scene, model->network(), model->effects(), p, design, positions[p]);
    });
    if (stable == 0) std::printf("# no pose is stable out of plane\n");
  } else {
    std::printf("%-10s %9.3f %9.3f\n", "stability", 0.0, 0.0);
  }
  const Archive a = readArchive(archivePath);
  timeStep("write", repeat, [&] { writeArchive(a, out); });
  std::remove(out.c_str());
  return 0;
}
