// The stack a derivative evaluation needs, measured on a six-valent
// connection (3D with twist: the largest stencil, 56 local variables with the
// design): every evaluation runs on the calling thread's own stack, so each
// must fit a thread's stack with room to spare. The evaluation runs on a
// thread whose stack is filled with a pattern first; the deepest byte it
// changed gives the stack it used (the thread's start-up included).
#include "model/pose_system.hh"
#include "solver/equilibrium.hh"
#include "tests/testutil/scenes.hh"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <pthread.h>
#include <sys/mman.h>

namespace rodmesh {
namespace {

constexpr std::size_t kStackBytes = std::size_t(16) << 20;
constexpr unsigned char kPattern = 0xA5;

// Bytes of stack fn used, on a fresh thread with a patterned 16 MB stack.
std::size_t stackUse(const std::function<void()>& fn) {
  void* mem = mmap(nullptr, kStackBytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (mem == MAP_FAILED) {
    ADD_FAILURE() << "no memory for the test stack";
    return 0;
  }
  std::memset(mem, kPattern, kStackBytes);
  pthread_attr_t attr;
  pthread_attr_init(&attr);
  pthread_attr_setstack(&attr, mem, kStackBytes);
  pthread_t thread;
  auto trampoline = [](void* arg) -> void* {
    (*static_cast<const std::function<void()>*>(arg))();
    return nullptr;
  };
  const int rc = pthread_create(&thread, &attr, trampoline, const_cast<std::function<void()>*>(&fn));
  pthread_attr_destroy(&attr);
  std::size_t used = 0;
  if (rc == 0) {
    pthread_join(thread, nullptr);
    const unsigned char* p = static_cast<const unsigned char*>(mem);
    std::size_t i = 0;
    while (i < kStackBytes && p[i] == kPattern) ++i;
    used = kStackBytes - i;
  } else {
    ADD_FAILURE() << "pthread_create failed";
  }
  munmap(mem, kStackBytes);
  return used;
}

// Six rods of two edges leaving vertex 0, out of plane, far ends fixed; twist
// and gravity on.
Scene sixValentStar() {
  constexpr double kPi = 3.14159265358979323846;
  std::vector<Vec3> dirs;
  for (int r = 0; r < 6; ++r) {
    const double a = r * kPi / 3 + 0.1 * r * r;
    dirs.push_back(Vec3(std::cos(a), std::sin(a), 0.2 * std::sin(3.0 * a)));
  }
  return testutil::connectionStar(dirs, {}, /*gravity=*/true);
}

TEST(StackUse, SixValentConnectionEvaluations) {
  const Scene scene = sixValentStar();
  SceneModel model(scene);
  const Design d = Design::fromScene(scene);
  const PoseSystem& sys = model.pose(0);
  ASSERT_EQ(sys.termCount(PoseSystem::termKindIndex("connection")), 1);
  PoseState u = sys.restState(d);
  u.loadFactor = 1.0;
  for (int i = 0; i < u.u.size(); ++i) u.u[i] += 1e-4 * std::sin(1.7 * i);
  const Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(u.u.size(), -1.0, 1.0);
  double energy = 0.0;
  Eigen::VectorXd g;
  Eigen::SparseMatrix<double> H;
  JointDerivatives j, jd;
  Eigen::VectorXd prod;
  const std::size_t sim = stackUse([&] { energy = sys.evaluate(u, d, &g, &H); });
  const std::size_t values = stackUse([&] { sys.evaluateJoint(u, d, j); });
  const std::size_t third = stackUse([&] { sys.evaluateJoint(u, d, jd, &v); });
  const std::size_t product = stackUse([&] { prod = sys.designForceProduct(u, d, v); });
  std::printf("stack used (kB): simulation %zu, joint values %zu, third order %zu, product %zu\n", sim / 1024,
              values / 1024, third / 1024, product / 1024);
  // The evaluations did run: the connection is in the results.
  EXPECT_GT(j.Hpp.nonZeros(), 0);
  EXPECT_GT(jd.Huu.norm(), 0.0);
  EXPECT_GT(prod.norm(), 0.0);
#if defined(__OPTIMIZE__) && !defined(__SANITIZE_ADDRESS__)
  // Budgets for optimized builds (unoptimized and sanitizer builds lay out
  // far larger frames): each evaluation well within a thread's stack. A fit
  // formed over all 56 locals (scalars of 13 kB, 26 kB with a direction)
  // takes 1.1 MB for the values and 1.6 MB with a direction.
  constexpr std::size_t kJointBudget = std::size_t(768) << 10;
  constexpr std::size_t kSimBudget = std::size_t(1) << 20;
  EXPECT_LT(values, kJointBudget);
  EXPECT_LT(third, kJointBudget);
  EXPECT_LT(product, kJointBudget);
  EXPECT_LT(sim, kSimBudget);
#endif
}

}  // namespace
}  // namespace rodmesh
