#include "solver/design_monitor.hh"

#include <algorithm>
#include <cmath>
#include <exception>

namespace rodmesh {

double simulationObjective(const Scene& scene, const SimulationResult& sim, double* sumSquared) {
  double f = 0.0, ss = 0.0;
  for (std::size_t k = 0; k < sim.poses.size() && k < scene.poses.size(); ++k) {
    const std::vector<Vec3>& target = scene.poses[k].target;
    const std::vector<Vec3>& x = sim.poses[k].positions;
    double s = 0.0;
    for (std::size_t v = 0; v < x.size() && v < target.size(); ++v) s += (x[v] - target[v]).squaredNorm();
    f += 0.5 * scene.poses[k].weight * s;
    ss += s;
  }
  if (sumSquared) *sumSquared = ss;
  return f;
}

bool confirmsIteration(int iteration) {
  if (iteration < 1) return false;
  if (iteration <= 10) return true;
  int n = 10;
  while (n < iteration) n = std::max(n + 1, static_cast<int>(std::floor(1.2 * n)));
  return n == iteration;
}

DesignMonitor::DesignMonitor(const Scene& scene, const DesignSpace& space, const NewtonOptions& newton,
                             double initialObjective, Clock::time_point t0,
                             std::function<void(const ConfirmedDesign&)> onConfirmed)
    : scene_(scene),
      space_(space),
      newton_(newton),
      t0_(t0),
      onConfirmed_(std::move(onConfirmed)),
      bestObjective_(initialObjective) {
  newton_.cancel = &cancel_;
  thread_ = std::thread([this] { run(); });
}

DesignMonitor::~DesignMonitor() { stop(); }

void DesignMonitor::offer(const ControlValues& controls, int iteration, const std::string& label) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return;
    queue_.push_back(Offer{controls, iteration, label});
  }
  wake_.notify_one();
}

void DesignMonitor::drain() {
  std::unique_lock<std::mutex> lock(mutex_);
  idle_.wait(lock, [this] { return stopping_ || (queue_.empty() && !busy_); });
}

bool DesignMonitor::drain(const std::function<bool()>& abandon) {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    if (stopping_ || (queue_.empty() && !busy_)) return !stopping_;
    if (abandon && abandon()) return false;
    idle_.wait_for(lock, std::chrono::milliseconds(20));
  }
}

void DesignMonitor::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    queue_.clear();
  }
  cancel_.store(true);
  wake_.notify_all();
  idle_.notify_all();
  if (thread_.joinable()) thread_.join();
}

std::optional<ConfirmedDesign> DesignMonitor::best() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return best_;
}

bool DesignMonitor::bestSummary(double& rms, int& iteration) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!best_) return false;
  rms = best_->rms;
  iteration = best_->iteration;
  return true;
}

void DesignMonitor::run() {
  // The monitor's own model: PoseSystems keep solver workspaces, so the
  // optimizer's model cannot be shared with another thread.
  std::unique_ptr<SceneModel> model;
  try {
    model = std::make_unique<SceneModel>(scene_);
  } catch (const std::exception&) {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    idle_.notify_all();
    return;
  }
  try {
    // The initial design from rest: the design a run holds before any other
    // is confirmed.
    if (std::optional<ConfirmedDesign> c = fromRest(*model, space_.initialControls(scene_))) {
      c->label = "the initial design";
      c->initial = true;
      if (onConfirmed_) onConfirmed_(*c);
    }
  } catch (const std::exception&) {
  }
  for (;;) {
    Offer offer;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (stopping_) break;
      offer = std::move(queue_.back());  // the newest first: what a run cut short can use
      queue_.pop_back();
      busy_ = true;
    }
    try {
      check(offer, *model);
    } catch (const std::exception&) {
      // A design the model rejects is one that is not confirmed.
    }
    checked_.fetch_add(1);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      busy_ = false;
    }
    idle_.notify_all();
  }
  idle_.notify_all();
}

std::optional<ConfirmedDesign> DesignMonitor::fromRest(const SceneModel& model, const ControlValues& controls) const {
  // As `rodmesh simulate` and the archive solve it. No warm start: a
  // design's check does not depend on which designs were checked before it,
  // so the best design after every offer was checked is the same whatever
  // the order (the newest is checked first).
  const Design d = space_.toDesign(controls);
  SimulationResult sim = simulateAll(model, d, newton_);
  if (cancel_.load() || !sim.allConverged) return std::nullopt;
  ConfirmedDesign c;
  for (const PoseResult& pr : sim.poses) {
    if (pr.state.loadFactor != 1.0) return std::nullopt;
    c.states.push_back(pr.state);
  }
  double ss = 0.0;
  c.objective = simulationObjective(scene_, sim, &ss);
  const double n = static_cast<double>(scene_.poses.size() * scene_.vertices.size());
  c.rms = n > 0 ? std::sqrt(ss / n) : 0.0;
  c.controls = controls;
  c.design = d;
  c.simulation = std::move(sim);
  c.elapsed = std::chrono::duration<double>(Clock::now() - t0_).count();
  return c;
}

void DesignMonitor::check(const Offer& offer, const SceneModel& model) {
  if (!offer.controls.radii.allFinite() || !offer.controls.displacement.allFinite()) return;
  std::optional<ConfirmedDesign> c = fromRest(model, offer.controls);
  if (!c) return;
  c->iteration = offer.iteration;
  c->label = offer.label;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // Lower objective, or the same with an earlier iteration (an order-free rule).
    const bool better =
        c->objective < bestObjective_ || (best_ && c->objective == bestObjective_ && offer.iteration < best_->iteration);
    if (!better) return;
    bestObjective_ = c->objective;
    best_ = *c;
  }
  confirmed_.fetch_add(1);
  if (onConfirmed_) onConfirmed_(*c);
}

}  // namespace rodmesh
