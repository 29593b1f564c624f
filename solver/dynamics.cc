#include "solver/dynamics.hh"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "solver/mass.hh"
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
  return "";
}

BackwardEuler::BackwardEuler(PoseSystem& system, const Design& design, Eigen::VectorXd dofMass,
                             const DynamicsOptions& options)
    : sys_(system), design_(design), mass_(std::move(dofMass)), opt_(options) {
  const double saved = sys_.loadFactor();
  sys_.setLoadFactor(1.0);
  rep_.loadScale = loadScale(sys_, design_);
  sys_.setLoadFactor(saved);
  floorForce_ = sys_.roundoffForce(design_);
  u_ = sys_.restDofs(design_);
  v_ = Eigen::VectorXd::Zero(sys_.numDofs());
  h_ = std::min(opt_.initialStep, opt_.maxStep);
}

void BackwardEuler::setState(const Eigen::VectorXd& u, const Eigen::VectorXd& v, double t) {
  u_ = u;
  v_ = v;
  v_.tail(sys_.numDofs() - sys_.numVertexDofs()).setZero();
  t_ = t;
  rep_.time = t;
  sys_.setLoadFactor(loadFactorAt(t));
}

double BackwardEuler::loadFactorAt(double t) const {
  if (opt_.loadRampTime <= 0) return 1.0;
  return std::clamp(t / opt_.loadRampTime, 0.0, 1.0);
}

double BackwardEuler::kineticEnergy() const { return 0.5 * (mass_.array() * v_.array().square()).sum(); }

double BackwardEuler::potentialEnergy() const { return sys_.energy(u_, design_); }

void BackwardEuler::assemble(double invH2) {
  const Eigen::SparseMatrix<double>& H = sys_.hessian();
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
    analysed_ = false;
  }
  double* a = A_.valuePtr();
  std::fill(a, a + A_.nonZeros(), 0.0);
  const double* hv = H.valuePtr();
  for (std::size_t k = 0; k < hessToA_.size(); ++k) a[hessToA_[k]] += hv[k];
  for (int c = 0; c < n; ++c) a[diagA_[c]] += invH2 * mass_[c];
  if (!analysed_) {
    ldlt_.analyzePattern(A_);
    analysed_ = true;
  }
}

BackwardEuler::Trial BackwardEuler::solveStep(double h) {
  Trial tr;
  const int n = sys_.numDofs();
  const int nv = sys_.numVertexDofs();
  const double invH2 = 1.0 / (h * h);
  const double eps = std::numeric_limits<double>::epsilon();
  Eigen::VectorXd uPred = u_;
  uPred.head(nv) += h * v_.head(nv);
  auto phi = [&](const Eigen::VectorXd& w, double E) {
    return E + 0.5 * invH2 * (mass_.array() * (w - uPred).array().square()).sum();
  };

  // Start from the prediction or from the current state, whichever is lower.
  Eigen::VectorXd w = uPred;
  {
    const double phiPred = phi(uPred, sys_.energy(uPred, design_));
    const double phiCur = phi(u_, sys_.energy(u_, design_));
    if (!std::isfinite(phiPred) || (std::isfinite(phiCur) && phiCur < phiPred)) w = u_;
  }

  Eigen::VectorXd gE(n), g(n), d(n), wTrial(n);
  double E = 0.0, ref = 0.0;
  for (int it = 0;; ++it) {
    auto ta = Clock::now();
    sys_.evaluate(w, design_, E, gE, true);
    rep_.assemblySeconds += since(ta);
    if (!std::isfinite(E) || !gE.allFinite()) {
      tr.failure = "energy or forces are not finite";
      return tr;
    }
    g = gE + invH2 * mass_.cwiseProduct(w - uPred);
    const double res = sys_.forceResidual(g).norm();
    tr.residual = res;
    // Relative to the step's own force imbalance: the pose's load scale can
    // dwarf the forces that drive the motion (prescribed displacements).
    if (it == 0) ref = res;
    if (res <= opt_.tolerance * ref || res <= floorForce_) break;
    if (it >= opt_.maxNewtonIterations) {
      std::ostringstream os;
      os << "Newton did not converge in " << opt_.maxNewtonIterations << " iterations (residual " << res << " N)";
      tr.failure = os.str();
      return tr;
    }
    ++tr.iterations;

    ta = Clock::now();
    assemble(invH2);
    ldlt_.factorize(A_);
    rep_.factorizations++;
    bool ok = ldlt_.info() == Eigen::Success;
    if (ok) {
      // Modified Newton where the matrix is indefinite (a buckling rod with
      // a large step, or massless twists): pivots replaced by
      // max(|D_i|, 1e-10 max|D|), a descent direction for Phi.
      Eigen::VectorXd D = ldlt_.vectorD();
      ok = D.allFinite() && D.size() == n;
      if (ok) {
        const double delta = 1e-10 * D.cwiseAbs().maxCoeff();
        bool modified = false;
        for (int i = 0; i < n; ++i)
          if (!(D[i] > delta)) {
            D[i] = std::max(std::abs(D[i]), std::max(delta, 1e-300));
            modified = true;
          }
        if (!modified) {
          d = ldlt_.solve(-g);
        } else {
          Eigen::VectorXd y = ldlt_.permutationP() * (-g);
          ldlt_.matrixL().solveInPlace(y);
          y.array() /= D.array();
          ldlt_.matrixU().solveInPlace(y);
          d = ldlt_.permutationPinv() * y;
        }
      }
    }
    rep_.factorSeconds += since(ta);
    const double slope = ok ? g.dot(d) : 0.0;
    if (!ok || !d.allFinite() || !(slope < 0)) {
      tr.failure = "no descent direction for the incremental potential";
      return tr;
    }
    if (d.lpNorm<Eigen::Infinity>() <= 1e3 * eps * std::max(w.lpNorm<Eigen::Infinity>(), 1e-300)) break;  // round-off

    // Backtracking on Phi; where Phi differences are at round-off, a step
    // that lowers the residual is accepted instead.
    const double phiW = phi(w, E);
    double alpha = 1.0;
    bool accepted = false;
    for (int b = 0; b <= opt_.maxBacktracks && !accepted; ++b, alpha *= 0.5) {
      wTrial = w + alpha * d;
      ta = Clock::now();
      const double Et = sys_.energy(wTrial, design_);
      rep_.assemblySeconds += since(ta);
      if (!std::isfinite(Et)) continue;
      const double phiT = phi(wTrial, Et);
      if (phiT <= phiW + opt_.armijo * alpha * slope) {
        accepted = true;
      } else if (std::abs(phiT - phiW) <= 1e-12 * std::max(std::abs(phiW), 1e-300)) {
        Eigen::VectorXd gt;
        double e;
        sys_.evaluate(wTrial, design_, e, gt, false);
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
  if (n > nv) tr.twistChange = (w.tail(n - nv) - u_.tail(n - nv)).lpNorm<Eigen::Infinity>();
  tr.u = std::move(w);
  return tr;
}

bool BackwardEuler::advanceTo(double t) {
  const auto t0 = Clock::now();
  const int n = sys_.numDofs();
  const int nv = sys_.numVertexDofs();
  auto finish = [&](bool ok) {
    sys_.setLoadFactor(loadFactorAt(t_));
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
    const double remaining = t - t_;
    const bool clipped = remaining <= h_ * (1.0 + 1e-9);
    const double h = clipped ? remaining : h_;
    sys_.setLoadFactor(loadFactorAt(t_ + h));
    Trial tr = solveStep(h);
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
    if (why.empty() && tr.twistChange > opt_.maxTwistChange) {
      std::ostringstream os;
      os << "a twist angle changed by " << tr.twistChange << " rad (limit " << opt_.maxTwistChange << ")";
      why = os.str();
    }
    if (why.empty()) {
      v_.head(nv) = (tr.u.head(nv) - u_.head(nv)) / h;
      u_ = std::move(tr.u);
      t_ = clipped ? t : t_ + h;
      rep_.steps++;
      rep_.minStepTaken = rep_.steps == 1 ? h : std::min(rep_.minStepTaken, h);
      rep_.maxStepTaken = std::max(rep_.maxStepTaken, h);
      if (sys_.reanchorCharts(u_, design_)) rep_.chartUpdates++;
      const bool easy = tr.iterations <= opt_.easyIterations && tr.deviation <= 0.5 * opt_.maxDisplacement &&
                        tr.twistChange <= 0.5 * opt_.maxTwistChange;
      if (easy && !clipped) h_ = std::min(h_ * opt_.growFactor, opt_.maxStep);
    } else {
      rep_.rejectedSteps++;
      h_ = h * opt_.shrinkFactor;
      if (h_ < opt_.minStep) {
        rep_.message = "time step fell below " + formatTime(opt_.minStep) + " at t = " + formatTime(t_) +
                       " (last rejection: " + why + ")";
        return finish(false);
      }
    }
  }
  t_ = std::max(t_, t);
  return finish(true);
}

DynamicsReport simulateDynamics(PoseSystem& system, const Design& design, const std::vector<double>& vertexMasses,
                                const DynamicsOptions& options, double duration, double fps, DynamicFrames& frames,
                                const FrameProgress& progress) {
  system.setLoadFactor(1.0);
  system.resetCharts(design);
  BackwardEuler be(system, design, dofMasses(system, vertexMasses), options);
  be.setState(system.restDofs(design), Eigen::VectorXd::Zero(system.numDofs()), 0.0);
  frames = DynamicFrames{};
  const int last = std::max(0, static_cast<int>(std::ceil(duration * fps - 1e-9)));
  for (int k = 0; k <= last; ++k) {
    const double t = std::min(k / fps, duration);
    const bool ok = k == 0 || be.advanceTo(t);
    if (!ok) {
      // Keep the last state reached, with its own time.
      if (frames.time.empty() || be.time() > frames.time.back()) {
        frames.time.push_back(be.time());
        frames.positions.push_back(system.positions(be.dofs(), design));
      }
      break;
    }
    frames.time.push_back(t);
    frames.positions.push_back(system.positions(be.dofs(), design));
    if (progress) progress(k, t, be.report());
  }
  frames.finalDofs = be.dofs();
  DynamicsReport rep = be.report();
  if (rep.ok) rep.message = "reached t = " + formatTime(rep.time);
  system.setLoadFactor(1.0);
  return rep;
}

}  // namespace rodmesh
