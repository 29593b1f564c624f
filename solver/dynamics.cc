#include "solver/dynamics.hh"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "solver/mass.hh"
#include "solver/minimizer.hh"
#include "solver/modified_ldlt.hh"
#include "solver/newton.hh"

namespace rodmesh {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

std::string formatTime(double t) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g s", t);
  return buf;
}

}  // namespace

std::string DynamicsOptions::isValid() const {
  if (!(initialStep > 0)) return "initial time step must be positive";
  if (!(minStep > 0)) return "minimum time step must be positive";
  if (!(maxStep >= minStep)) return "maximum time step must be at least the minimum time step";
  if (!(growFactor >= 1)) return "step growth factor must be at least 1";
  if (!(shrinkFactor > 0 && shrinkFactor < 1)) return "step shrink factor must lie in (0, 1)";
  if (easyIterations < 0) return "easyIterations must be non-negative";
  if (maxNewtonIterations < 1) return "maxNewtonIterations must be at least 1";
  if (!(tolerance > 0 && tolerance < 1)) return "tolerance must lie in (0, 1)";
  if (!(maxDisplacement > 0)) return "maxDisplacement must be positive";
  if (!(maxTwistChange > 0)) return "maxTwistChange must be positive";
  if (!(loadRampTime >= 0) || !std::isfinite(loadRampTime)) return "load ramp time must be finite and non-negative";
  if (!(armijo > 0 && armijo < 0.5)) return "armijo must lie in (0, 0.5)";
  if (maxBacktracks < 1) return "maxBacktracks must be at least 1";
  if (maxSteps < 1) return "maxSteps must be at least 1";
  if (!(timeLimit >= 0) || !std::isfinite(timeLimit)) return "timeLimit must be finite and non-negative";
  if (!std::isfinite(initialStep) || !std::isfinite(maxStep)) return "time steps must be finite";
  return "";
}

std::string checkDynamicRun(const DynamicsOptions& o, double duration, double fps, double maxFrames) {
  char buf[512];
  if (!(duration > 0) || !std::isfinite(duration)) {
    std::snprintf(buf, sizeof buf, "the duration must be a finite positive number of seconds, got %g", duration);
    return buf;
  }
  if (!(fps > 0) || !std::isfinite(fps)) {
    std::snprintf(buf, sizeof buf, "the frame rate must be a finite positive number per second, got %g", fps);
    return buf;
  }
  if (duration * fps > maxFrames) {
    std::snprintf(buf, sizeof buf, "duration x frame rate asks for %g frames; at most %g", duration * fps, maxFrames);
    return buf;
  }
  const double smallest = duration / static_cast<double>(o.maxSteps);
  if (!(o.maxStep >= smallest) || !std::isfinite(o.maxStep)) {
    std::snprintf(buf, sizeof buf,
                  "the largest time step %g s cannot cover %g s within %lld steps; allowed range [%g, inf) s",
                  o.maxStep, duration, o.maxSteps, smallest);
    return buf;
  }
  return o.isValid();
}

BackwardEuler::BackwardEuler(const PoseSystem& system, const Design& design, Eigen::VectorXd dofMass,
                             const DynamicsOptions& options)
    : sys_(system), design_(design), mass_(std::move(dofMass)), opt_(options) {
  rep_.loadScale = loadScale(sys_, design_);
  state_ = sys_.restState(design_);
  state_.loadFactor = loadFactorAt(0.0);
  v_ = Eigen::VectorXd::Zero(sys_.numDofs());
  h_ = std::min(opt_.initialStep, opt_.maxStep);
}

void BackwardEuler::start(const PoseState& state, const Eigen::VectorXd& v, double t) {
  state_ = state;
  state_.loadFactor = loadFactorAt(t);
  v_ = v;
  v_.tail(sys_.numDofs() - sys_.numVertexDofs()).setZero();
  t_ = t;
  rep_.time = t;
}

double BackwardEuler::loadFactorAt(double t) const {
  if (opt_.loadRampTime <= 0) return 1.0;
  return std::clamp(t / opt_.loadRampTime, 0.0, 1.0);
}

double BackwardEuler::kineticEnergy() const { return 0.5 * (mass_.array() * v_.array().square()).sum(); }

double BackwardEuler::potentialEnergy() const { return sys_.energy(state_, design_); }

BackwardEuler::Trial BackwardEuler::solveStep(double h, double loadFactor) {
  Trial tr;
  const Eigen::VectorXd& u0 = state_.u;
  const int n = sys_.numDofs();
  const int nv = sys_.numVertexDofs();
  InertiaTerm inertia;
  inertia.mass = &mass_;
  inertia.invH2 = 1.0 / (h * h);
  inertia.predicted = u0;
  inertia.predicted.head(nv) += h * v_.head(nv);
  const Eigen::VectorXd& uPred = inertia.predicted;

  // The step's unknowns at its end's load factor, in the state's charts
  // (re-anchored only between steps). It starts from the prediction or from
  // the current state, whichever has the lower incremental potential.
  PoseState at{uPred, state_.charts, loadFactor, state_.internal};
  {
    auto phi = [&](const Eigen::VectorXd& w) {
      at.u = w;
      return sys_.energy(at, design_) + inertia.energy(w);
    };
    const double phiPred = phi(uPred);
    const double phiCur = phi(u0);
    at.u = (!std::isfinite(phiPred) || (std::isfinite(phiCur) && phiCur < phiPred)) ? u0 : uPred;
  }

  // The minimizer's time-step settings: the tolerance relative to the step's
  // own force imbalance, any curvature (the inertia term makes small steps
  // definite; a step that is not is rejected by its size limits), no trust
  // radius (the step size limits the motion) and fixed charts.
  MinimizerSettings s;
  s.scaleFromStart = true;
  s.tolerance = opt_.tolerance;
  s.maxIterations = opt_.maxNewtonIterations;
  s.armijo = opt_.armijo;
  s.maxBacktracks = opt_.maxBacktracks;
  s.stableOnly = false;
  s.maxEscapes = 0;
  s.trustRegion = false;
  s.reanchor = false;
  s.inertia = &inertia;
  const int before = ws_.factor.factorizations();
  const NewtonReport r = minimizeEnergy(sys_, design_, at, s, ws_);
  rep_.factorizations += ws_.factor.factorizations() - before;
  rep_.assemblySeconds += r.assemblySeconds;
  rep_.factorSeconds += r.factorSeconds;
  tr.iterations = r.iterations;
  tr.residual = r.residualNorm;
  if (r.outcome != Outcome::Converged) {
    std::ostringstream os;
    if (r.outcome == Outcome::MaxIterations)
      os << "Newton did not converge in " << opt_.maxNewtonIterations << " iterations (residual " << r.residualNorm
         << " N)";
    else
      os << "the incremental potential: " << r.message;
    tr.failure = os.str();
    return tr;
  }

  // How much the step changed: deviation from the prediction (vertex
  // distance, in mean edge lengths) and twist change.
  const Eigen::VectorXd& w = at.u;
  const int D = sys_.dofsPerVertex();
  double dev = 0.0;
  for (int k = 0; k < nv; k += D) dev = std::max(dev, (w.segment(k, D) - uPred.segment(k, D)).norm());
  tr.deviation = dev / sys_.momentArm();
  if (n > nv) tr.twistChange = (w.tail(n - nv) - u0.tail(n - nv)).lpNorm<Eigen::Infinity>();
  tr.u = std::move(at.u);
  return tr;
}

bool BackwardEuler::advanceTo(double t) {
  const auto t0 = Clock::now();
  const int n = sys_.numDofs();
  const int nv = sys_.numVertexDofs();
  auto finish = [&](bool ok) {
    state_.loadFactor = loadFactorAt(t_);
    rep_.time = t_;
    rep_.loadFactor = state_.loadFactor;
    rep_.relativeResidual = rep_.loadScale > 0 ? rep_.residualNorm / rep_.loadScale : rep_.residualNorm;
    rep_.usable = state_.u.allFinite();
    rep_.timeSeconds += since(t0);
    return ok;
  };
  if (n == 0) {
    // Nothing moves: every vertex is held.
    t_ = std::max(t_, t);
    return finish(true);
  }
  while (t - t_ > 1e-12 * std::max(1.0, std::abs(t))) {
    if (rep_.steps + rep_.rejectedSteps >= opt_.maxSteps) {
      std::ostringstream os;
      os << "stopped at t = " << formatTime(t_) << ": the budget of " << opt_.maxSteps
         << " time steps is spent (last step " << formatTime(h_) << ")";
      rep_.message = os.str();
      rep_.outcome = Outcome::MaxIterations;
      return finish(false);
    }
    if (opt_.timeLimit > 0 && rep_.timeSeconds + since(t0) > opt_.timeLimit) {
      rep_.message = "stopped at t = " + formatTime(t_) + ": the time limit of " + formatTime(opt_.timeLimit) +
                     " (wall clock) is reached";
      rep_.outcome = Outcome::TimeLimit;
      return finish(false);
    }
    const double remaining = t - t_;
    const bool clipped = remaining <= h_ * (1.0 + 1e-9);
    const double h = clipped ? remaining : h_;
    const double stepLoadFactor = loadFactorAt(t_ + h);
    Trial tr = solveStep(h, stepLoadFactor);
    rep_.iterations += tr.iterations;
    rep_.residualNorm = tr.residual;
    std::string why = tr.failure;
    if (why.empty() && !tr.u.allFinite()) why = "non-finite state";
    if (why.empty() && tr.deviation > opt_.maxDisplacement) {
      std::ostringstream os;
      os << "a vertex moved " << tr.deviation << " edge lengths from the prediction (limit " << opt_.maxDisplacement
         << ")";
      why = os.str();
    }
    // The twists are massless: their change within a step is partly the
    // quasi-static response to a load that changed (at once, for loads that
    // are not ramped), which no step size makes smaller. A twist change that
    // did not shrink by a quarter when the step was cut for it is such a
    // response, not an integration error, and is accepted.
    const bool quasiStaticTwist = twistRejected_ > 0 && tr.twistChange >= 0.75 * twistRejected_;
    if (why.empty() && tr.twistChange > opt_.maxTwistChange && !quasiStaticTwist) {
      std::ostringstream os;
      os << "a twist angle changed by " << tr.twistChange << " rad (limit " << opt_.maxTwistChange << ")";
      why = os.str();
      twistRejected_ = tr.twistChange;
    }
    if (why.empty()) {
      v_.head(nv) = (tr.u.head(nv) - state_.u.head(nv)) / h;
      state_.u = std::move(tr.u);
      t_ = clipped ? t : t_ + h;
      state_.loadFactor = stepLoadFactor;
      rep_.steps++;
      twistRejected_ = -1.0;
      rep_.minStepTaken = rep_.steps == 1 ? h : std::min(rep_.minStepTaken, h);
      rep_.maxStepTaken = std::max(rep_.maxStepTaken, h);
      if (std::optional<PoseState> moved = sys_.reanchored(state_, design_)) {
        state_ = std::move(*moved);
        rep_.chartUpdates++;
      }
      // Internal variables follow the accepted step (a tie's rest length
      // after yielding, model/terms/tie.hh); the next step starts from them.
      if (std::optional<PoseState> advanced = sys_.advancedInternal(state_, design_)) state_ = std::move(*advanced);
      const bool easy = tr.iterations <= opt_.easyIterations && tr.deviation <= 0.5 * opt_.maxDisplacement &&
                        tr.twistChange <= 0.5 * opt_.maxTwistChange;
      if (easy && !clipped) h_ = std::min(h_ * opt_.growFactor, opt_.maxStep);
    } else {
      rep_.rejectedSteps++;
      h_ = h * opt_.shrinkFactor;
      if (h_ < opt_.minStep) {
        rep_.message = "time step fell below " + formatTime(opt_.minStep) + " at t = " + formatTime(t_) +
                       " (last rejection: " + why + ")";
        rep_.outcome = Outcome::NumericalFailure;
        return finish(false);
      }
    }
  }
  t_ = std::max(t_, t);
  return finish(true);
}

DynamicsReport simulateDynamics(const PoseSystem& system, const Design& design,
                                const std::vector<double>& vertexMasses, const DynamicsOptions& options,
                                double duration, double fps, DynamicFrames& frames, const FrameProgress& progress) {
  BackwardEuler be(system, design, dofMasses(system, vertexMasses), options);
  be.start(system.restState(design), Eigen::VectorXd::Zero(system.numDofs()), 0.0);
  frames = DynamicFrames{};
  const int last = std::max(0, static_cast<int>(std::ceil(duration * fps - 1e-9)));
  for (int k = 0; k <= last; ++k) {
    const double t = std::min(k / fps, duration);
    const bool ok = k == 0 || be.advanceTo(t);
    if (!ok) {
      // Keep the last state reached, with its own time.
      if (frames.time.empty() || be.time() > frames.time.back()) {
        frames.time.push_back(be.time());
        frames.positions.push_back(system.positions(be.state(), design));
      }
      break;
    }
    frames.time.push_back(t);
    frames.positions.push_back(system.positions(be.state(), design));
    if (progress) progress(k, t, be.report());
  }
  frames.finalDofs = be.dofs();
  frames.finalState = be.state();
  DynamicsReport rep = be.report();
  if (rep.converged()) rep.message = "reached t = " + formatTime(rep.time);
  return rep;
}

}  // namespace rodmesh
