// A static partition of independent per-pose work over threads: pose p runs
// on thread p mod threads, so results never depend on the thread count.
#pragma once

#include <algorithm>
#include <thread>
#include <vector>

namespace rodmesh {

template <class Fn>
void forEachPose(int poses, int threads, Fn&& fn) {
  threads = std::max(1, std::min(threads, poses));
  if (threads == 1) {
    for (int p = 0; p < poses; ++p) fn(p);
    return;
  }
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t)
    pool.emplace_back([&, t] {
      for (int p = t; p < poses; p += threads) fn(p);
    });
  for (std::thread& th : pool) th.join();
}

}  // namespace rodmesh
