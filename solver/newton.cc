#include "solver/newton.hh"

#include <Eigen/SparseCholesky>

#include <chrono>
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
    rep.energy = E;
    rep.message = "no unknowns";
    return rep;
  }

  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt;
  bool analysed = false;
  double shift = 0.0;  // last shift that worked, carried over (reduced) between iterations
  Eigen::SparseMatrix<double> H;
  std::vector<int> diagSlot;

  auto ta = Clock::now();
  system.evaluate(u, design, E, g, true);
  rep.assemblySeconds += since(ta);
  if (!std::isfinite(E) || !finite(g)) {
    rep.message = "energy or forces are not finite at the initial guess";
    rep.timeSeconds = since(t0);
    return rep;
  }
  for (int it = 0;; ++it) {
    const double res = system.forceResidual(g).norm();
    rep.residualNorm = res;
    rep.relativeResidual = scale > 0 ? res / scale : res;
    rep.residualHistory.push_back(rep.relativeResidual);
    rep.energy = E;
    if (res <= tolerance * scale) {
      rep.converged = true;
      rep.message = "force residual below tolerance";
      break;
    }
    if (it >= opt.maxIterations) {
      rep.message = "iteration limit reached";
      break;
    }
    rep.iterations++;

    // Factorize H + shift * diag(|H_ii|), raising the shift until the factor
    // is positive definite, so that d is a descent direction.
    const Eigen::SparseMatrix<double>& H0 = system.hessian();
    if (!analysed) {
      H = H0;
      diagSlot.assign(n, -1);
      for (int c = 0; c < n; ++c)
        for (int k = H.outerIndexPtr()[c]; k < H.outerIndexPtr()[c + 1]; ++k)
          if (H.innerIndexPtr()[k] == c) diagSlot[c] = k;
    }
    std::copy(H0.valuePtr(), H0.valuePtr() + H0.nonZeros(), H.valuePtr());
    Eigen::VectorXd diag(n);
    double meanDiag = 0.0;
    for (int c = 0; c < n; ++c) { diag[c] = std::abs(H.valuePtr()[diagSlot[c]]); meanDiag += diag[c]; }
    meanDiag = meanDiag > 0 ? meanDiag / n : 1.0;
    for (int c = 0; c < n; ++c) diag[c] = std::max(diag[c], 1e-8 * meanDiag);

    double tau = shift > 0 ? std::max(opt.minShift, shift / 4) : 0.0;
    bool factored = false;
    ta = Clock::now();
    while (true) {
      for (int c = 0; c < n; ++c) H.valuePtr()[diagSlot[c]] = H0.valuePtr()[diagSlot[c]] + tau * diag[c];
      if (!analysed) { ldlt.analyzePattern(H); analysed = true; }
      ldlt.factorize(H);
      rep.factorizations++;
      bool ok = ldlt.info() == Eigen::Success && (ldlt.vectorD().array() > 0).all() && ldlt.vectorD().allFinite();
      if (ok) {
        d = ldlt.solve(-g);
        ok = finite(d) && d.dot(g) < 0;
      }
      if (ok) { factored = true; break; }
      tau = tau == 0 ? opt.minShift : tau * 10;
      if (tau > opt.maxShift) break;
    }
    rep.factorSeconds += since(ta);
    if (tau > 0) rep.hessianModifications++;
    shift = tau;
    if (!factored) {
      rep.message = "could not find a descent direction (Hessian shift exceeded its limit)";
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
      system.evaluate(uTrial, design, Etrial, gTrial, true);
      rep.assemblySeconds += since(ta);
      if (std::isfinite(Etrial) && finite(gTrial)) {
        const bool armijo = Etrial <= E + opt.armijo * alpha * slope;
        const bool roundoff = std::abs(Etrial - E) <= 1e-12 * std::max(std::abs(E), 1e-300) &&
                              system.forceResidual(gTrial).norm() < res;
        if (armijo || roundoff) { accepted = true; break; }
      }
      alpha *= 0.5;
      rep.backtracks++;
    }
    if (!accepted) {
      // Re-evaluate the Hessian at the current point for the next attempt
      // with a larger shift.
      system.evaluate(u, design, E, g, true);
      shift = std::max(shift * 100, 1e-6);
      if (shift > opt.maxShift) {
        rep.message = "line search failed";
        break;
      }
      continue;
    }
    u = uTrial;
    E = Etrial;
    g = gTrial;
  }
  rep.timeSeconds = since(t0);
  return rep;
}

NewtonReport solveEquilibrium(PoseSystem& system, const Design& design, Eigen::VectorXd& u,
                              const NewtonOptions& opt) {
  const auto t0 = Clock::now();
  const double saved = system.loadFactor();
  system.setLoadFactor(1.0);
  const double scale = loadScale(system, design);
  NewtonReport total;
  total.loadScale = scale;
  auto merge = [&](const NewtonReport& r) {
    total.iterations += r.iterations;
    total.factorizations += r.factorizations;
    total.hessianModifications += r.hessianModifications;
    total.backtracks += r.backtracks;
    total.assemblySeconds += r.assemblySeconds;
    total.factorSeconds += r.factorSeconds;
    total.residualHistory.insert(total.residualHistory.end(), r.residualHistory.begin(), r.residualHistory.end());
    total.loadSteps++;
  };
  if (scale == 0.0) {
    // No load at all: the rest configuration is the equilibrium.
    total.converged = true;
    total.message = "no load: rest configuration";
    Eigen::VectorXd g;
    double e;
    system.evaluate(u, design, e, g, false);
    total.residualNorm = system.forceResidual(g).norm();
    total.energy = e;
    total.timeSeconds = since(t0);
    system.setLoadFactor(saved);
    return total;
  }

  // Full load first.
  Eigen::VectorXd uTry = u;
  NewtonReport r = newtonSolve(system, design, uTry, scale, opt.tolerance, opt);
  merge(r);
  if (r.converged) {
    u = uTry;
  } else {
    // Adaptive continuation in the load factor, from the rest state.
    Eigen::VectorXd uCur = system.restDofs(design);
    double lam = 0.0, step = 0.5;
    const double minStep = std::ldexp(1.0, -opt.maxLoadHalvings);
    const double stepTol = std::max(opt.tolerance, 1e-6);
    bool failed = false;
    while (lam < 1.0) {
      const double next = std::min(1.0, lam + step);
      system.setLoadFactor(next);
      uTry = uCur;
      NewtonReport rs = newtonSolve(system, design, uTry, scale, next < 1.0 ? stepTol : opt.tolerance, opt);
      merge(rs);
      r = rs;
      if (rs.converged) {
        lam = next;
        uCur = uTry;
        step = std::min(2 * step, 1.0);
      } else {
        step *= 0.5;
        if (step < minStep) { failed = true; break; }
      }
    }
    u = uCur;
    if (failed) {
      std::ostringstream os;
      os << "did not converge: the load step fell below " << minStep << " at load factor " << lam << " (last: "
         << r.message << ")";
      r.message = os.str();
      r.converged = false;
    }
  }
  total.converged = r.converged;
  total.message = r.message;
  system.setLoadFactor(1.0);
  Eigen::VectorXd g;
  double e;
  system.evaluate(u, design, e, g, false);
  total.residualNorm = system.forceResidual(g).norm();
  total.relativeResidual = total.residualNorm / scale;
  total.energy = e;
  total.timeSeconds = since(t0);
  system.setLoadFactor(saved);
  return total;
}

}  // namespace rodmesh
