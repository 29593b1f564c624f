#include "solver/newton.hh"

#include <Eigen/SparseCholesky>

#include <chrono>
#include <limits>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <sstream>

namespace rodmesh {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

bool finite(const Eigen::VectorXd& v) { return v.allFinite(); }

}  // namespace

std::string NewtonOptions::isValid() const {
  if (maxIterations < 1) return "maxIterations must be at least 1";
  if (!(tolerance > 0 && tolerance < 1)) return "tolerance must lie in (0, 1)";
  if (!(armijo > 0 && armijo < 0.5)) return "armijo must lie in (0, 0.5)";
  if (maxBacktracks < 1) return "maxBacktracks must be at least 1";
  if (!(minShift > 0 && maxShift > minShift)) return "need 0 < minShift < maxShift";
  if (maxLoadHalvings < 0) return "maxLoadHalvings must be non-negative";
  return "";
}

double loadScale(PoseSystem& system, const Design& design) {
  Eigen::VectorXd u = system.restDofs(design);
  Eigen::VectorXd g;
  double e;
  system.evaluate(u, design, e, g, false);
  return system.forceResidual(g).norm();
}

NewtonReport newtonSolve(PoseSystem& system, const Design& design, Eigen::VectorXd& u, double scale,
                         double tolerance, const NewtonOptions& opt) {
  const auto t0 = Clock::now();
  NewtonReport rep;
  rep.loadScale = scale;
  rep.loadSteps = 1;
  const int n = system.numDofs();
  Eigen::VectorXd g(n), gTrial(n), d(n), uTrial(n);
  double E = 0.0;
  if (n == 0) {
    system.evaluate(u, design, E, g, false);
    rep.converged = true;
    rep.outcome = Outcome::Converged;
    rep.energy = E;
    rep.message = "no unknowns";
    return rep;
  }

  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt;
  bool analysed = false;
  Eigen::SparseMatrix<double> H;
  std::vector<int> diagSlot;
  int escapes = 0;
  const double eps = std::numeric_limits<double>::epsilon();
  const double floorForce = system.roundoffForce(design);
  const bool debug = std::getenv("RODMESH_DEBUG_NEWTON") != nullptr;

  auto ta = Clock::now();
  system.evaluate(u, design, E, g, true);
  rep.assemblySeconds += since(ta);
  if (!std::isfinite(E) || !finite(g)) {
    rep.outcome = Outcome::NumericalFailure;
    rep.message = "energy or forces are not finite at the initial guess";
    rep.timeSeconds = since(t0);
    return rep;
  }

  // Solves (L |D|' L^T) x = b with the current factor, where |D|' replaces
  // every pivot by max(|D_i|, delta max|D|): the modified-Newton system of an
  // indefinite Hessian (positive definite, same scaling as H).
  auto solveModified = [&](const Eigen::VectorXd& b, const Eigen::VectorXd& Dmod) {
    Eigen::VectorXd y = ldlt.permutationP() * b;
    ldlt.matrixL().solveInPlace(y);
    y.array() /= Dmod.array();
    ldlt.matrixU().solveInPlace(y);
    return Eigen::VectorXd(ldlt.permutationPinv() * y);
  };

  for (int it = 0;; ++it) {
    const double res = system.forceResidual(g).norm();
    rep.residualNorm = res;
    rep.relativeResidual = scale > 0 ? res / scale : res;
    rep.residualHistory.push_back(rep.relativeResidual);
    rep.energy = E;

    // Factorize the Hessian at the current point (also needed to judge the
    // stability of a converged state).
    const Eigen::SparseMatrix<double>& H0 = system.hessian();
    if (!analysed) {
      H = H0;
      diagSlot.assign(n, -1);
      for (int c = 0; c < n; ++c)
        for (int k = H.outerIndexPtr()[c]; k < H.outerIndexPtr()[c + 1]; ++k)
          if (H.innerIndexPtr()[k] == c) diagSlot[c] = k;
      ldlt.analyzePattern(H);
      analysed = true;
    }
    ta = Clock::now();
    std::copy(H0.valuePtr(), H0.valuePtr() + H0.nonZeros(), H.valuePtr());
    ldlt.factorize(H);
    rep.factorizations++;
    const Eigen::VectorXd D = ldlt.vectorD();
    const bool factorOk = ldlt.info() == Eigen::Success && D.allFinite();
    const double Dmax = factorOk ? D.cwiseAbs().maxCoeff() : 0.0;
    const double delta = 1e-10 * Dmax;
    // Negative pivots mean negative curvature; pivots within delta of zero
    // are (near) zero-stiffness modes, harmless at convergence but floored in
    // the step.
    int negative = 0, singular = 0, worst = -1;
    if (factorOk)
      for (int i = 0; i < n; ++i) {
        if (D[i] < -delta) {
          ++negative;
          if (worst < 0 || D[i] < D[worst]) worst = i;
        } else if (D[i] <= delta) {
          ++singular;
        }
      }
    rep.factorSeconds += since(ta);
    rep.negativePivots = negative;

    const bool small = res <= tolerance * scale || res <= floorForce;
    if (small && negative == 0) {
      rep.converged = true;
      rep.outcome = Outcome::Converged;
      rep.message = "force residual below tolerance";
      break;
    }
    if (it >= opt.maxIterations) {
      rep.message = small ? "converged to an unstable equilibrium (negative curvature persists)" : "iteration limit reached";
      rep.converged = small;
      rep.outcome = small ? Outcome::Converged : Outcome::MaxIterations;
      break;
    }

    // At an unstable equilibrium (a saddle, e.g. a perfectly straight column
    // above its buckling load), step along a direction of negative curvature:
    // z = P^T L^-T e_k has z^T H z = D_k < 0.
    if (factorOk && negative > 0 && (small || res <= 1e-6 * scale) && escapes < opt.maxEscapes) {
      Eigen::VectorXd y = Eigen::VectorXd::Zero(n);
      y[worst] = 1.0;
      ldlt.matrixU().solveInPlace(y);
      Eigen::VectorXd z = ldlt.permutationPinv() * y;
      if (z.dot(g) > 0) z = -z;
      z *= 0.1 * system.momentArm() / std::max(z.head(system.numVertexDofs()).lpNorm<Eigen::Infinity>(), 1e-300);
      if (!z.allFinite() || system.numVertexDofs() == 0) z.setZero();
      double best = E;
      Eigen::VectorXd uBest;
      for (double a = 1.0; a > 1e-6; a *= 0.5) {
        uTrial = u + a * z;
        const double Et = system.energy(uTrial, design);
        if (std::isfinite(Et) && Et < best) { best = Et; uBest = uTrial; break; }
      }
      ++escapes;
      rep.escapes++;
      if (uBest.size() > 0) {
        if (debug) std::fprintf(stderr, "it %3d  escape along negative curvature, E %.6e -> %.6e\n", it, E, best);
        u = uBest;
        ta = Clock::now();
        system.evaluate(u, design, E, g, true);
        rep.assemblySeconds += since(ta);
        rep.iterations++;
        continue;
      }
    }
    if (small) {
      rep.converged = true;
      rep.outcome = Outcome::Converged;
      rep.unstable = true;
      rep.message = "force residual below tolerance, but the equilibrium is unstable (negative curvature)";
      break;
    }
    rep.iterations++;

    // Direction: Newton, or modified Newton with |D| when indefinite; a
    // diagonal shift as the last resort when the factorization itself fails.
    bool haveDir = false;
    double tau = 0.0;
    if (factorOk) {
      if (negative == 0 && singular == 0) {
        d = ldlt.solve(-g);
      } else {
        Eigen::VectorXd Dmod = D.cwiseAbs().cwiseMax(std::max(delta, 1e-300));
        d = solveModified(-g, Dmod);
        rep.hessianModifications++;
      }
      haveDir = finite(d) && d.dot(g) < 0;
    }
    if (!haveDir) {
      Eigen::VectorXd diag(n);
      double meanDiag = 0.0;
      for (int c = 0; c < n; ++c) { diag[c] = std::abs(H0.valuePtr()[diagSlot[c]]); meanDiag += diag[c]; }
      meanDiag = meanDiag > 0 ? meanDiag / n : 1.0;
      for (int c = 0; c < n; ++c) diag[c] = std::max(diag[c], 1e-8 * meanDiag);
      ta = Clock::now();
      for (tau = opt.minShift; tau <= opt.maxShift; tau *= 10) {
        for (int c = 0; c < n; ++c) H.valuePtr()[diagSlot[c]] = H0.valuePtr()[diagSlot[c]] + tau * diag[c];
        ldlt.factorize(H);
        rep.factorizations++;
        if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().array() > 0).all()) continue;
        d = ldlt.solve(-g);
        if (finite(d) && d.dot(g) < 0) { haveDir = true; break; }
      }
      rep.factorSeconds += since(ta);
      rep.hessianModifications++;
      if (!haveDir) {
        rep.outcome = Outcome::NumericalFailure;
        rep.message = "could not find a descent direction (Hessian shift exceeded its limit)";
        break;
      }
    }
    // A pure Newton correction below the round-off of the unknowns cannot
    // improve the solution: the residual is at the round-off level of the
    // internal forces (stiff stretching against light loads). Only credible
    // when the residual is already small (not, say, for a body drifting away).
    if (negative == 0 && singular == 0 && tau == 0.0 && res <= std::sqrt(tolerance) * scale &&
        d.lpNorm<Eigen::Infinity>() <= 1e3 * eps * u.lpNorm<Eigen::Infinity>()) {
      rep.converged = true;
      rep.outcome = Outcome::Converged;
      rep.roundoff = true;
      rep.message = "Newton correction at the round-off level of the unknowns";
      break;
    }

    // Backtracking line search on the energy; near convergence, where energy
    // differences drown in round-off, a step that reduces the residual is
    // accepted instead.
    double alpha = 1.0;
    const double slope = g.dot(d);
    bool accepted = false;
    double Etrial = 0.0;
    for (int b = 0; b <= opt.maxBacktracks; ++b) {
      uTrial = u + alpha * d;
      ta = Clock::now();
      Etrial = system.energy(uTrial, design);
      rep.assemblySeconds += since(ta);
      if (std::isfinite(Etrial)) {
        if (Etrial <= E + opt.armijo * alpha * slope) {
          accepted = true;
        } else if (std::abs(Etrial - E) <= 1e-12 * std::max(std::abs(E), 1e-300)) {
          // Energy differences at round-off: judge the step by the residual.
          double e;
          system.evaluate(uTrial, design, e, gTrial, false);
          accepted = finite(gTrial) && system.forceResidual(gTrial).norm() < res;
        }
        if (accepted) break;
      }
      alpha *= 0.5;
      rep.backtracks++;
    }
    if (accepted) {
      ta = Clock::now();
      system.evaluate(uTrial, design, Etrial, gTrial, true);
      rep.assemblySeconds += since(ta);
      accepted = std::isfinite(Etrial) && finite(gTrial);
    }
    if (!accepted) {
      rep.outcome = Outcome::Stalled;
      rep.message = "line search failed: no step along the descent direction lowers the energy";
      break;
    }
    if (debug)
      std::fprintf(stderr, "it %3d  E %.12e  res %.3e  neg %d  tau %.1e  alpha %.3e  |d| %.3e  |dx| %.3e |dth| %.3e\n",
                   it, E, rep.relativeResidual, negative, tau, alpha, d.norm(),
                   d.head(system.numVertexDofs()).lpNorm<Eigen::Infinity>(),
                   d.tail(n - system.numVertexDofs()).lpNorm<Eigen::Infinity>());
    u = uTrial;
    E = Etrial;
    g = gTrial;
    // Edges that turned far from their reference-frame chart get a new one
    // (same energy, new coordinates): the derivatives are re-evaluated.
    if (system.reanchorCharts(u, design)) {
      rep.chartUpdates++;
      system.evaluate(u, design, E, g, true);
    }
  }
  rep.timeSeconds = since(t0);
  return rep;
}

NewtonReport solveEquilibrium(PoseSystem& system, const Design& design, Eigen::VectorXd& u,
                              const NewtonOptions& opt) {
  PoseState state = system.restState(design);
  state.u = u;
  const double saved = system.loadFactor();
  const NewtonReport r = solveEquilibrium(system, design, state, opt);
  u = state.u;
  system.setLoadFactor(saved);
  return r;
}

NewtonReport solveEquilibrium(PoseSystem& system, const Design& design, PoseState& state,
                              const NewtonOptions& opt) {
  const auto t0 = Clock::now();
  system.setLoadFactor(1.0);
  system.setCharts(state.charts);
  Eigen::VectorXd& u = state.u;
  const PoseState rest = system.restState(design);
  const double scale = loadScale(system, design);
  NewtonReport total;
  total.loadScale = scale;
  auto merge = [&](const NewtonReport& r) {
    total.iterations += r.iterations;
    total.factorizations += r.factorizations;
    total.hessianModifications += r.hessianModifications;
    total.backtracks += r.backtracks;
    total.escapes += r.escapes;
    total.chartUpdates += r.chartUpdates;
    total.assemblySeconds += r.assemblySeconds;
    total.factorSeconds += r.factorSeconds;
    total.residualHistory.insert(total.residualHistory.end(), r.residualHistory.begin(), r.residualHistory.end());
    total.loadSteps++;
  };
  auto finishState = [&](double lam) {
    state.charts = system.charts();
    state.loadFactor = lam;
  };
  if (scale <= system.roundoffForce(design)) {
    // No load at all: the rest configuration is the equilibrium.
    total.converged = true;
    total.outcome = Outcome::Converged;
    total.message = "no load: rest configuration";
    u = rest.u;
    system.setCharts(rest.charts);
    Eigen::VectorXd g;
    double e;
    system.evaluate(u, design, e, g, false);
    total.residualNorm = system.forceResidual(g).norm();
    total.energy = e;
    total.timeSeconds = since(t0);
    finishState(1.0);
    return total;
  }

  // Full load first, from the given state.
  Eigen::VectorXd uTry = u;
  NewtonReport r = newtonSolve(system, design, uTry, scale, opt.tolerance, opt);
  merge(r);
  double reached = 1.0;
  if (r.converged) {
    u = uTry;
  } else {
    // Adaptive continuation in the load factor, from the rest state; the
    // reference-frame charts travel with the state they belong to.
    system.setCharts(rest.charts);
    Eigen::VectorXd uCur = rest.u;
    PoseSystem::Charts chartsCur = rest.charts;
    double lam = 0.0, step = 0.5;
    const double minStep = std::ldexp(1.0, -opt.maxLoadHalvings);
    // Intermediate load steps need not be tight, but never sloppy.
    const double stepTol = std::min(std::max(opt.tolerance, 1e-6), 1e-4);
    bool failed = false;
    while (lam < 1.0) {
      const double next = std::min(1.0, lam + step);
      system.setLoadFactor(next);
      system.setCharts(chartsCur);
      uTry = uCur;
      NewtonReport rs = newtonSolve(system, design, uTry, scale, next < 1.0 ? stepTol : opt.tolerance, opt);
      merge(rs);
      r = rs;
      if (rs.converged) {
        lam = next;
        uCur = uTry;
        chartsCur = system.charts();
        step = std::min(2 * step, 1.0);
      } else {
        step *= 0.5;
        if (step < minStep) { failed = true; break; }
      }
    }
    u = uCur;
    system.setCharts(chartsCur);
    reached = lam;
    if (failed) {
      std::ostringstream os;
      os << "did not converge: the load step fell below " << minStep << " at load factor " << lam << " (last: "
         << r.message << ")";
      r.message = os.str();
      r.converged = false;
      r.outcome = Outcome::Stalled;
    }
  }
  // The final verdict is judged at the full load, whatever the last step said.
  system.setLoadFactor(1.0);
  Eigen::VectorXd g;
  double e;
  system.evaluate(u, design, e, g, false);
  total.residualNorm = system.forceResidual(g).norm();
  total.relativeResidual = total.residualNorm / scale;
  total.energy = e;
  if (!std::isfinite(total.residualNorm) || !std::isfinite(e)) {
    r.converged = false;
    r.outcome = Outcome::NumericalFailure;
    r.message = "the final state has non-finite energy or forces (" + r.message + ")";
  } else if (r.converged && !(total.residualNorm <= std::max(1e3 * opt.tolerance, std::sqrt(opt.tolerance)) * scale ||
                              total.residualNorm <= system.roundoffForce(design))) {
    r.converged = false;
    r.outcome = Outcome::Stalled;
    r.message = "the final state does not satisfy equilibrium at the full load (" + r.message + ")";
  }
  total.converged = r.converged;
  total.outcome = r.converged ? Outcome::Converged : r.outcome;
  if (!r.converged && total.outcome == Outcome::Converged) total.outcome = Outcome::Stalled;
  total.unstable = r.unstable;
  total.roundoff = r.roundoff;
  total.negativePivots = r.negativePivots;
  total.message = r.message;
  total.timeSeconds = since(t0);
  finishState(reached);
  return total;
}

}  // namespace rodmesh
