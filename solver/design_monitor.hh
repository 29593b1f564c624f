// A usable design at every moment of an optimization (docs/optimization.md,
// "Confirmed designs"). SAND's iterates are not equilibria, and even the
// reduced method's iterates are equilibria only on the optimizer's own branch
// (warm starts); the archive wants designs whose poses re-solve from rest
// (solver/design_fallback.hh). The monitor takes the optimizer's designs
// the driver offers (the iterations `confirmsIteration` names: all of the
// first ten, then about every fifth part more), re-solves each from rest, as
// `rodmesh simulate` solves it, on a background thread with a model of its
// own (so it runs on the second core while the optimizer goes on), and
// keeps the best design whose every pose converges, with a lower objective
// than the initial design's. Every offer is checked, the newest first (the
// one a run cut short wants), and a check does not depend on the checks
// before it, so once every offer was checked (`drain`) the best design
// depends only on the optimizer's iterates, not on how far the thread got:
// the driver waits for that before it uses it, unless the run is being cut
// short.
#pragma once

#include "model/design_space.hh"
#include "solver/equilibrium.hh"
#include "solver/newton.hh"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <limits>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace rodmesh {

// A design whose poses were re-solved from rest.
struct ConfirmedDesign {
  ControlValues controls;
  Design design;
  SimulationResult simulation;    // every pose from rest (rodmesh simulate's solve), all converged
  std::vector<PoseState> states;  // the equilibria of `simulation` (the loading path's)
  double objective = std::numeric_limits<double>::infinity();  // f (contract §4) on `simulation`
  double rms = 0.0;                                             // m, on `simulation`
  int iteration = 0;                                            // the optimizer iteration that offered it
  std::string label;                                            // e.g. "the design of joint level 2, iteration 37"
  double elapsed = 0.0;                                         // s from the run's start when confirmed
  bool initial = false;                                         // the initial design (see DesignMonitor)
};

// f (contract §4: 1/2 sum_k w_k sum_v |q_kv - target_kv|^2) and the summed
// squared distance of a simulation's positions.
double simulationObjective(const Scene& scene, const SimulationResult& sim, double* sumSquared = nullptr);

// Whether the design of optimizer iteration `iteration` (counted over the
// whole run, from 1) is offered to the monitor: iterations 1 to 10, then
// n_{j+1} = floor(1.2 n_j) (12, 14, 16, 19, 22, ...): about 40 checks in
// 2000 iterations, fewer where a run is long and slow to change.
bool confirmsIteration(int iteration);

class DesignMonitor {
 public:
  using Clock = std::chrono::steady_clock;
  // `initialObjective`: the initial design's f, which a confirmed design must
  // beat; `t0`: the run's start; `onConfirmed` (optional) is called on the
  // monitor's thread, first with the initial design re-solved from rest
  // (`initial` set; what a run stopped before any better design archives),
  // then with every new best design.
  DesignMonitor(const Scene& scene, const DesignSpace& space, const NewtonOptions& newton,
                double initialObjective, Clock::time_point t0,
                std::function<void(const ConfirmedDesign&)> onConfirmed = {});
  ~DesignMonitor();
  DesignMonitor(const DesignMonitor&) = delete;
  DesignMonitor& operator=(const DesignMonitor&) = delete;

  // Queues the optimizer's current design for a check; returns at once.
  void offer(const ControlValues& controls, int iteration, const std::string& label);
  // Waits until every offer made so far has been checked.
  void drain();
  // The same, giving up (false) as soon as `abandon` returns true (polled
  // every 20 ms): a run cut short by its limits does not wait.
  bool drain(const std::function<bool()>& abandon);
  // Stops the thread, abandoning a check under way (Newton is cancelled).
  void stop();

  std::optional<ConfirmedDesign> best() const;
  // The best design's RMS (m) and iteration, without copying it; false if none.
  bool bestSummary(double& rms, int& iteration) const;
  int checked() const { return checked_.load(); }      // designs re-solved (completed checks)
  int confirmed() const { return confirmed_.load(); }  // new bests

 private:
  struct Offer {
    ControlValues controls;
    int iteration = 0;
    std::string label;
  };
  void run();
  void check(const Offer& offer, const SceneModel& model);
  // `controls` solved from rest; empty when a pose fails (or the check is
  // cancelled). Label and iteration are the caller's.
  std::optional<ConfirmedDesign> fromRest(const SceneModel& model, const ControlValues& controls) const;

  const Scene& scene_;
  const DesignSpace& space_;
  NewtonOptions newton_;
  Clock::time_point t0_;
  std::function<void(const ConfirmedDesign&)> onConfirmed_;

  mutable std::mutex mutex_;
  std::condition_variable wake_, idle_;
  std::deque<Offer> queue_;
  bool busy_ = false, stopping_ = false;
  std::atomic<bool> cancel_{false};
  std::optional<ConfirmedDesign> best_;
  double bestObjective_;  // the initial design's objective until a design is confirmed
  std::atomic<int> checked_{0}, confirmed_{0};
  std::thread thread_;
};

}  // namespace rodmesh
