#include "solver/dynamics.hh"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "solver/mass.hh"
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

void BackwardEuler::assemble(double invH2) {
  const Eigen::SparseMatrix<double>& H = H_;
  const int n = sys_.numDofs();
  if (A_.rows() != n || hessToA_.size() != static_cast<std::size_t>(H.nonZeros())) {
    // Pattern of A: the Hessian's (lower triangle) plus the full diagonal.
    std::vector<Eigen::Triplet<double>> pattern;
    pattern.reserve(H.nonZeros() + n);
    for (int c = 0; c < n; ++c) {
      pattern.emplace_back(c, c, 0.0);
      for (Eigen::SparseMatrix<double>::InnerIterator it(H, c); it; ++it) pattern.emplace_back(it.row(), c, 0.0);
    }
    A_.resize(n, n);
    A_.setFromTriplets(pattern.begin(), pattern.end());
    A_.makeCompressed();
    hessToA_.assign(H.nonZeros(), -1);
    diagA_.assign(n, -1);
    for (int c = 0; c < n; ++c) {
      int k = A_.outerIndexPtr()[c];
      for (int kh = H.outerIndexPtr()[c]; kh < H.outerIndexPtr()[c + 1]; ++kh) {
        while (A_.innerIndexPtr()[k] != H.innerIndexPtr()[kh]) ++k;
        hessToA_[kh] = k;
      }
      for (int ka = A_.outerIndexPtr()[c]; ka < A_.outerIndexPtr()[c + 1]; ++ka)
        if (A_.innerIndexPtr()[ka] == c) diagA_[c] = ka;
    }
  }
  double* a = A_.valuePtr();
  std::fill(a, a + A_.nonZeros(), 0.0);
  const double* hv = H.valuePtr();
  for (std::size_t k = 0; k < hessToA_.size(); ++k) a[hessToA_[k]] += hv[k];
  for (int c = 0; c < n; ++c) a[diagA_[c]] += invH2 * mass_[c];
}

BackwardEuler::Trial BackwardEuler::solveStep(double h, double loadFactor) {
  Trial tr;
  const Eigen::VectorXd& u0 = state_.u;
  // Evaluations of the step: at its end's load factor, in the state's charts.
  PoseState at{Eigen::VectorXd(), state_.charts, loadFactor};
  auto with = [&at](const Eigen::VectorXd& x) -> const PoseState& {
    at.u = x;
    return at;
  };
  const int n = sys_.numDofs();
  const int nv = sys_.numVertexDofs();
  const double invH2 = 1.0 / (h * h);
  const double eps = std::numeric_limits<double>::epsilon();
  Eigen::VectorXd uPred = u0;
  uPred.head(nv) += h * v_.head(nv);
  auto phi = [&](const Eigen::VectorXd& w, double E) {
    return E + 0.5 * invH2 * (mass_.array() * (w - uPred).array().square()).sum();
  };

  // Start from the prediction or from the current state, whichever is lower.
  Eigen::VectorXd w = uPred;
  {
    const double phiPred = phi(uPred, sys_.energy(with(uPred), design_));
    const double phiCur = phi(u0, sys_.energy(with(u0), design_));
    if (!std::isfinite(phiPred) || (std::isfinite(phiCur) && phiCur < phiPred)) w = u0;
  }

  Eigen::VectorXd gE(n), g(n), d(n), wTrial(n);
  double E = 0.0, ref = 0.0;
  static const bool debug = std::getenv("RODMESH_DEBUG_DYNAMICS") != nullptr;
  for (int it = 0;; ++it) {
    auto ta = Clock::now();
    E = sys_.evaluate(with(w), design_, &gE, &H_);
    rep_.assemblySeconds += since(ta);
    if (!std::isfinite(E) || !gE.allFinite()) {
      tr.failure = "energy or forces are not finite";
      return tr;
    }
    g = gE + invH2 * mass_.cwiseProduct(w - uPred);
    const double res = sys_.forceResidual(g).stableNorm();
    tr.residual = res;
    if (!std::isfinite(res)) {
      tr.failure = "the force residual is not finite";
      return tr;
    }
    // Relative to the step's own force imbalance: the pose's load scale can
    // dwarf the forces that drive the motion (prescribed displacements).
    if (it == 0) ref = res;
    if (res <= opt_.tolerance * ref) break;

    ta = Clock::now();
    assemble(invH2);
    const int before = factor_.factorizations();
    const bool ok = factor_.factorize(A_);
    rep_.factorizations += factor_.factorizations() - before;
    rep_.factorSeconds += since(ta);
    // Modified Newton where the matrix is indefinite (a buckling rod with a
    // large step) or singular (massless twists without stiffness): a descent
    // direction for Phi (solver/modified_ldlt.hh).
    if (ok) d = factor_.solve(-g);
    const double slope = ok ? g.dot(d) : 0.0;
    if (!ok || !d.allFinite() || !(slope < 0)) {
      tr.failure = "no descent direction for the incremental potential";
      return tr;
    }
    // Round-off (as in solver/newton.hh): the residual at the floor that
    // rounding the unknowns produces with a decrement below the energy of
    // that rounding, or a correction below the round-off of every unknown.
    // The inertia term's own round-off is that of w - u_pred, eps (|w| +
    // |u_pred|) per unknown, not the kernels' (a falling rod at w = 0 moves
    // by g h^2 per step, however small: 1e-17 m at h = 1e-9 s).
    if (factor_.negative() == 0) {
      const Eigen::VectorXd a = roundoff::unknownScale(sys_, w);
      const Eigen::ArrayXd inertia = eps * invH2 * mass_.array() * (w.array().abs() + uPred.array().abs());
      const Eigen::VectorXd rho =
          (roundoff::residualFloor(H_, a).array().square() + inertia.square()).sqrt().matrix();
      const double energyFloor =
          roundoff::energyFloor(H_, a) + (inertia.square() / (invH2 * mass_.array()).max(1e-300)).sum();
      // Component by component: the inertia of a coordinate far from the
      // origin must not hide the residual of one near it.
      if ((sys_.forceResidual(g).cwiseAbs().array() <= sys_.forceResidual(rho).array()).all() &&
          factor_.stiffDecrement(-g) <= energyFloor)
        break;
      if (!factor_.modified() && (d.cwiseAbs().array() <= 4.0 * eps * w.cwiseAbs().array()).all()) break;
    }
    if (debug)
      std::fprintf(stderr, "h %.3e it %d res %.3e E %.6e neg %d sing %d |d| %.3e\n", h, it, res, E, factor_.negative(),
                   factor_.singular(), d.lpNorm<Eigen::Infinity>());
    if (it >= opt_.maxNewtonIterations) {
      std::ostringstream os;
      os << "Newton did not converge in " << opt_.maxNewtonIterations << " iterations (residual " << res << " N)";
      tr.failure = os.str();
      return tr;
    }
    ++tr.iterations;

    // Backtracking on Phi; where Phi differences are at round-off, a step
    // that lowers the residual is accepted instead.
    const double phiW = phi(w, E);
    double alpha = 1.0;
    bool accepted = false;
    for (int b = 0; b <= opt_.maxBacktracks && !accepted; ++b, alpha *= 0.5) {
      wTrial = w + alpha * d;
      ta = Clock::now();
      const double Et = sys_.energy(with(wTrial), design_);
      rep_.assemblySeconds += since(ta);
      if (!std::isfinite(Et)) continue;
      const double phiT = phi(wTrial, Et);
      if (phiT <= phiW + opt_.armijo * alpha * slope) {
        accepted = true;
      } else if (std::abs(phiT - phiW) <= 1e-12 * std::max(std::abs(phiW), 1e-300)) {
        Eigen::VectorXd gt;
        sys_.evaluate(with(wTrial), design_, &gt, nullptr);
        gt += invH2 * mass_.cwiseProduct(wTrial - uPred);
        accepted = gt.allFinite() && sys_.forceResidual(gt).norm() < res;
      }
    }
    if (!accepted) {
      tr.failure = "line search failed on the incremental potential";
      return tr;
    }
    w = wTrial;
  }

  // How much the step changed: deviation from the prediction (vertex
  // distance, in mean edge lengths) and twist change.
  const int D = sys_.dofsPerVertex();
  double dev = 0.0;
  for (int k = 0; k < nv; k += D) dev = std::max(dev, (w.segment(k, D) - uPred.segment(k, D)).norm());
  tr.deviation = dev / sys_.momentArm();
  if (n > nv) tr.twistChange = (w.tail(n - nv) - u0.tail(n - nv)).lpNorm<Eigen::Infinity>();
  tr.u = std::move(w);
  return tr;
}

bool BackwardEuler::advanceTo(double t) {
  const auto t0 = Clock::now();
  const int n = sys_.numDofs();
  const int nv = sys_.numVertexDofs();
  auto finish = [&](bool ok) {
    state_.loadFactor = loadFactorAt(t_);
    rep_.time = t_;
    rep_.wallSeconds += since(t0);
    rep_.ok = rep_.ok && ok;
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
    if (opt_.timeLimit > 0 && rep_.wallSeconds + since(t0) > opt_.timeLimit) {
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
    rep_.newtonIterations += tr.iterations;
    rep_.lastResidual = tr.residual;
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
  if (rep.ok) rep.message = "reached t = " + formatTime(rep.time);
  return rep;
}

}  // namespace rodmesh
