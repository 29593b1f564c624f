#include "solver/minimizer.hh"

#include "solver/format.hh"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

namespace rodmesh {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr double kPi = 3.14159265358979323846;
// Test (3): a Newton correction within this many units of round-off of every
// unknown cannot improve the state.
constexpr double kCorrectionUlps = 4.0;
// The first Newton step from a state may not displace a vertex by more than
// this many times the structure's size: such loads are beyond what double
// precision can represent in equilibrium (energies ~ stiffness x size^2 x
// this^2 would overflow).
constexpr double kAbsurdDisplacement = 1e100;

// Phi's matrix for a time step: the energy Hessian's values with the inertia
// diagonal added (same pattern; the Hessian's pattern has the full diagonal).
const Eigen::SparseMatrix<double>& timeStepMatrix(MinimizerWorkspace& ws, const InertiaTerm& in) {
  const Eigen::SparseMatrix<double>& H = ws.hessian;
  const int n = static_cast<int>(H.rows());
  if (ws.matrix.rows() != n || ws.matrix.nonZeros() != H.nonZeros() ||
      ws.diagonal.size() != static_cast<std::size_t>(n)) {
    ws.matrix = H;
    ws.matrix.makeCompressed();
    ws.diagonal.assign(n, -1);
    for (int c = 0; c < n; ++c)
      for (int k = ws.matrix.outerIndexPtr()[c]; k < ws.matrix.outerIndexPtr()[c + 1]; ++k)
        if (ws.matrix.innerIndexPtr()[k] == c) ws.diagonal[c] = k;
  }
  std::copy(H.valuePtr(), H.valuePtr() + H.nonZeros(), ws.matrix.valuePtr());
  double* a = ws.matrix.valuePtr();
  for (int c = 0; c < n; ++c) a[ws.diagonal[c]] += in.invH2 * (*in.mass)[c];
  return ws.matrix;
}

}  // namespace

double maxVertexStep(const PoseSystem& sys, const Eigen::VectorXd& d) {
  const int D = sys.dofsPerVertex();
  double m = 0.0;
  for (int k = 0; k + D <= sys.numVertexDofs(); k += D) m = std::max(m, d.segment(k, D).stableNorm());
  return m;
}

double structureSize(const PoseSystem& sys, const Design& design, const PoseState& state) {
  const std::vector<Vec3> x = sys.positions(state, design);
  if (x.empty()) return sys.momentArm();
  Vec3 lo = x.front(), hi = x.front();
  for (const Vec3& p : x) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double s = (hi - lo).norm();
  return std::isfinite(s) ? std::max(s, sys.momentArm()) : sys.momentArm();
}

NewtonReport minimizeEnergy(const PoseSystem& system, const Design& design, PoseState& state,
                            const MinimizerSettings& opt, MinimizerWorkspace& ws) {
  const auto t0 = Clock::now();
  NewtonReport rep;
  double scale = opt.scale;
  rep.loadScale = scale;
  rep.loadSteps = 1;
  rep.loadFactor = state.loadFactor;
  const int n = system.numDofs();
  const int nv = system.numVertexDofs();
  const InertiaTerm* inertia = opt.inertia;
  Eigen::VectorXd& u = state.u;
  // Trial points of the line searches share the state's charts and load factor.
  PoseState trial = state;
  Eigen::VectorXd& uTrial = trial.u;
  Eigen::VectorXd g(n), gTrial(n), d(n);
  Eigen::SparseMatrix<double>& H = ws.hessian;  // the Hessian of E at u (lower triangle)
  ModifiedLdlt& factor = ws.factor;
  // Phi and its gradient at a state (the Hessian of E when asked for).
  auto inertiaEnergy = [&](const Eigen::VectorXd& x) {
    return inertia ? inertia->energy(x) : 0.0;
  };
  auto evaluate = [&](const PoseState& s, Eigen::VectorXd* grad, Eigen::SparseMatrix<double>* hess) {
    double e = system.evaluate(s, design, grad, hess);
    if (inertia) {
      e += inertiaEnergy(s.u);
      if (grad) *grad += inertia->invH2 * inertia->mass->cwiseProduct(s.u - inertia->predicted);
    }
    return e;
  };
  auto energyAt = [&](const PoseState& s) { return system.energy(s, design) + inertiaEnergy(s.u); };
  double E = 0.0;
  if (n == 0) {
    E = evaluate(state, &g, nullptr);
    rep.outcome = Outcome::Converged;
    rep.usable = true;
    rep.energy = E;
    rep.message = "no unknowns";
    return rep;
  }

  int escapes = 0;
  const bool debug = std::getenv("RODMESH_DEBUG_NEWTON") != nullptr;
  const double size = structureSize(system, design, state);
  // Trust radius on vertex displacements (m) for every step; grows after a
  // full step that it limited, shrinks to what the line search accepted.
  double radius = size;

  auto ta = Clock::now();
  E = evaluate(state, &g, &H);
  rep.assemblySeconds += since(ta);
  if (!std::isfinite(E) || !g.allFinite()) {
    rep.outcome = Outcome::NumericalFailure;
    rep.message = "energy or forces are not finite at the initial guess";
    rep.timeSeconds = since(t0);
    return rep;
  }

  const double energyAtStart = E;
  double energyAtTenth = E;
  for (int it = 0;; ++it) {
    if (it == opt.maxIterations - std::max(1, opt.maxIterations / 10)) energyAtTenth = E;
    const double res = system.forceResidual(g).norm();
    if (it == 0 && opt.scaleFromStart) {
      // A time step's own force imbalance: the pose's load scale can dwarf
      // the forces that drive the motion (prescribed displacements).
      scale = res;
      rep.loadScale = scale;
    }
    rep.residualNorm = res;
    rep.relativeResidual = scale > 0 ? res / scale : res;
    rep.residualHistory.push_back(rep.relativeResidual);
    rep.energy = E;
    const bool small = res <= opt.tolerance * scale;
    if (small && !opt.stableOnly) {
      rep.outcome = Outcome::Converged;
      rep.message = "force residual below tolerance";
      break;
    }
    // Checked before the factorization: a refused corrector costs none.
    if (opt.stopOutsideNewtonRegion && it > 0 && !(rep.residualHistory[it] < rep.residualHistory[it - 1]) && !small) {
      rep.outcome = Outcome::Stalled;
      rep.message = "left Newton's region of convergence (the force residual rose)";
      break;
    }

    // Factorize Phi's Hessian at the current point (solver/modified_ldlt.hh).
    const Eigen::SparseMatrix<double>& H0 = inertia ? timeStepMatrix(ws, *inertia) : H;
    ta = Clock::now();
    const int factorizationsBefore = factor.factorizations();
    const bool factorOk = factor.factorize(H0);
    rep.factorizations += factor.factorizations() - factorizationsBefore;
    const int negative = factorOk ? factor.negative() : 0;
    const int singular = factorOk ? factor.singular() : 0;
    rep.factorSeconds += since(ta);
    rep.negativePivots = negative;
    rep.singularPivots = singular;
    if (negative > 0) rep.negativeIterations++;
    const bool modified = negative > 0 || singular > 0;

    // Direction: Newton, or modified Newton (|D|, floored) where the Hessian
    // is indefinite or singular.
    bool haveDir = false;
    double tau = 0.0;
    if (factorOk) {
      d = factor.solve(-g);
      haveDir = d.allFinite() && d.dot(g) < 0;
    }

    // Round-off floor at this state (test 2). For a time step, the inertia
    // term's own round-off is that of u - u_pred, eps (|u| + |u_pred|) per
    // unknown, not the kernels' (a falling rod at u = 0 moves by g h^2 per
    // step, however small: 1e-17 m at h = 1e-9 s).
    const Eigen::VectorXd a = roundoff::unknownScale(system, u);
    Eigen::VectorXd rho = roundoff::residualFloor(H, a);
    Eigen::ArrayXd inertiaFloor;
    if (inertia) {
      inertiaFloor =
          kEps * inertia->invH2 * inertia->mass->array() * (u.array().abs() + inertia->predicted.array().abs());
      rho = (rho.array().square() + inertiaFloor.square()).sqrt().matrix();
    }
    double floorForce = system.forceResidual(rho).norm();
    if (!std::isfinite(floorForce)) floorForce = 0.0;
    rep.roundoffFloor = floorForce;

    if (opt.stopAtNegative && negative > 0) {
      // A load step of the loading path that meets negative curvature is too
      // long, or crosses a critical point: the caller shortens it.
      rep.outcome = Outcome::Stalled;
      rep.message = "met negative curvature";
      break;
    }
    // For statics, test (1) also asks the Newton correction (the first-order
    // estimate of the position error) to move no vertex by more than
    // tolerance x the structure's size: along a soft mode of stiffness k a
    // residual r leaves an error r / k, and a near-mechanism (the optimizers'
    // designs reach k of 1e-3 N/m) held far from rest (a large load scale)
    // would otherwise pass with errors up to tolerance x scale / k. With a
    // modified factorization, or a residual at its round-off floor (then the
    // correction along a soft mode is noise / k, not an error the next
    // iterate can remove), the correction says nothing about the error.
    // The correction is measured only once the residual test passes.
    const bool test1Met = small && negative == 0 &&
                          (inertia || !factorOk || !haveDir || modified || res <= floorForce ||
                           maxVertexStep(system, d) <= opt.tolerance * size);
    if (test1Met) {
      rep.outcome = Outcome::Converged;
      rep.message = "force residual below tolerance";
      break;
    }
    if (factorOk && negative == 0 && haveDir) {
      // Along zero-stiffness modes, and for a time step (where the inertia of
      // a coordinate far from the origin must not hide the residual of one
      // near it), every component of the residual must be within its own
      // round-off (a light part hinged to a heavy one is not judged by the
      // heavy part's floor); otherwise the norm is compared.
      const bool componentwise = singular > 0 || inertia;
      const bool floorReached =
          componentwise ? (system.forceResidual(g).cwiseAbs().array() <= system.forceResidual(rho).array()).all()
                        : res <= floorForce;
      if (floorReached) {
        // The decrement over the modes with stiffness: along a zero-stiffness
        // mode the floored pivot says nothing, and the residual there is
        // already judged by the floor.
        double noiseDecrement = roundoff::energyFloor(H, a);
        if (inertia)
          noiseDecrement += (inertiaFloor.square() / (inertia->invH2 * inertia->mass->array()).max(1e-300)).sum();
        const double decrement = factor.stiffDecrement(-g);
        if (debug)
          std::fprintf(stderr, "it %3d  at floor: res %.3e N floor %.3e N decrement %.3e J noise %.3e J\n", it, res,
                       floorForce, decrement, noiseDecrement);
        if (decrement <= noiseDecrement) {
          rep.outcome = Outcome::Converged;
          rep.roundoff = true;
          rep.message = "force residual " + formatNumber("%.3g", res) + " N at the round-off floor of this problem (" +
                        formatNumber("%.3g", floorForce) +
                        " N) with a Newton decrement below the energy of rounding the unknowns";
          break;
        }
      }
      // For a time step also when, after two Newton steps or more, the
      // residual is at its floor in norm and stopped falling, and the
      // correction moves no unknown by more than the round-off of the
      // largest (a structure at rest under large internal forces: the force
      // round-off of a vertex at the origin exceeds its own componentwise
      // floor, and the steps were rejected down to microseconds). Not before
      // Newton moved: a rod falling from the origin moves by g h^2 per step,
      // far below the round-off of its other coordinates.
      const std::vector<double>& hist = rep.residualHistory;
      const bool settledStep = inertia && it >= 2 && res <= floorForce && hist.size() >= 2 &&
                               hist[hist.size() - 1] >= 0.5 * hist[hist.size() - 2] &&
                               d.lpNorm<Eigen::Infinity>() <= kCorrectionUlps * kEps * a.maxCoeff();
      if (!modified &&
          (settledStep || (d.cwiseAbs().array() <= kCorrectionUlps * kEps * u.cwiseAbs().array()).all())) {
        rep.outcome = Outcome::Converged;
        rep.roundoff = true;
        rep.message = std::string(settledStep ? "time step settled: residual at its round-off floor and Newton "
                                                "correction below the round-off of the largest unknown"
                                              : "Newton correction below the round-off of every unknown") +
                      " (force residual " + formatNumber("%.3g", res) +
                      " N, round-off floor " + formatNumber("%.3g", floorForce) + " N)";
        break;
      }
    }
    const bool atFloor = res <= floorForce;
    if (it >= opt.maxIterations) {
      // Still progressing (a long descent such as a mechanism's rigid swing,
      // not a stall): over the last tenth of the iterations the energy fell
      // by more than its round-off, and either the residual reached a new
      // low or that tenth (of a run of at least 20 iterations) still gained
      // at least 0.1 % of the energy the whole run gained (1 % stopped a
      // hinged sheet's swing out of its plane 26 iterations from its end,
      // its last tenth at 0.35 %). The second case is
      // a soft structure swinging into its loaded shape from a state near
      // equilibrium under a small load (the rest state, or one small load
      // step beyond an equilibrium): its residual grows during the swing and
      // is not below its initial value until the end, while a stall gains
      // ever less energy. Or the last tenth ends converging: its last
      // residual a tenth of its largest or less (a descent from an unstable
      // equilibrium, whose small initial residual the run cannot undercut
      // before it arrives, settling into the state it fell towards).
      {
        const auto& hist = rep.residualHistory;
        const std::size_t tenth = std::max<std::size_t>(1, hist.size() / 10);
        const double before = *std::min_element(hist.begin(), hist.end() - tenth);
        const double recent = *std::min_element(hist.end() - tenth, hist.end());
        const double recentMax = *std::max_element(hist.end() - tenth, hist.end());
        const double gainedRecently = energyAtTenth - E;
        rep.progressing = hist.size() > tenth && gainedRecently > 1e-12 * std::max(std::abs(E), 1e-300) &&
                          (recent < before || (tenth >= 2 && gainedRecently >= 0.001 * (energyAtStart - E)) ||
                           (tenth >= 2 && hist.back() <= 0.1 * recentMax));
      }
      const bool saddle = opt.stableOnly && (small || atFloor) && negative > 0;
      rep.message = saddle ? "reached an unstable equilibrium (negative curvature persists) at the iteration limit"
                           : "iteration limit reached";
      rep.unstable = saddle;
      rep.outcome = saddle ? Outcome::Stalled : Outcome::MaxIterations;
      break;
    }
    if ((opt.deadline && Clock::now() > *opt.deadline) || (opt.cancel && opt.cancel->load())) {
      rep.outcome = Outcome::TimeLimit;
      rep.message = "time limit reached";
      break;
    }

    // At an unstable equilibrium (a saddle, e.g. a perfectly straight column
    // above its buckling load), step along a direction of negative curvature:
    // z = P^T L^-T e_k has z^T H z = D_k < 0.
    if (opt.stableOnly && factorOk && negative > 0 && (small || atFloor || res <= 1e-6 * scale) &&
        escapes < opt.maxEscapes) {
      Eigen::VectorXd z = factor.negativeCurvatureDirection();
      if (z.dot(g) > 0) z = -z;
      z *= 0.1 * system.momentArm() / std::max(z.head(nv).lpNorm<Eigen::Infinity>(), 1e-300);
      if (!z.allFinite() || nv == 0) z.setZero();
      double best = E;
      Eigen::VectorXd uBest;
      for (double s = 1.0; s > 1e-6; s *= 0.5) {
        uTrial = u + s * z;
        const double Et = energyAt(trial);
        if (std::isfinite(Et) && Et < best) {
          best = Et;
          uBest = uTrial;
          break;
        }
      }
      ++escapes;
      rep.escapes++;
      if (uBest.size() > 0) {
        if (debug) std::fprintf(stderr, "it %3d  escape along negative curvature, E %.6e -> %.6e\n", it, E, best);
        u = uBest;
        ta = Clock::now();
        E = evaluate(state, &g, &H);
        rep.assemblySeconds += since(ta);
        rep.iterations++;
        continue;
      }
    }
    if (opt.stableOnly && negative > 0 && (small || (atFloor && escapes >= opt.maxEscapes))) {
      // An equilibrium, but a saddle that the escapes could not leave: not a
      // solution (a perturbation would carry the structure away from it).
      rep.outcome = Outcome::Stalled;
      rep.unstable = true;
      rep.message = "reached an unstable equilibrium (negative curvature persists after " + std::to_string(escapes) +
                    " steps along it)";
      break;
    }
    rep.iterations++;

    // A diagonal shift as the last resort when the factorization itself fails.
    if (!haveDir) {
      Eigen::VectorXd diag = H0.diagonal().cwiseAbs();
      const double meanDiag = diag.sum() > 0 ? diag.sum() / n : 1.0;
      diag = diag.cwiseMax(1e-8 * meanDiag);
      ta = Clock::now();
      for (tau = opt.minShift; tau <= opt.maxShift; tau *= 10) {
        const int before = factor.factorizations();
        const bool ok = factor.factorizeShifted(H0, tau * diag);
        rep.factorizations += factor.factorizations() - before;
        if (!ok) continue;
        d = factor.solve(-g);
        if (d.allFinite() && d.dot(g) < 0) {
          haveDir = true;
          break;
        }
      }
      rep.factorSeconds += since(ta);
      if (!haveDir) {
        rep.outcome = Outcome::NumericalFailure;
        rep.message = "could not find a descent direction (Hessian shift exceeded its limit)";
        break;
      }
    }
    if (modified || tau > 0) rep.hessianModifications++;
    // The first unmodified Newton step from an equilibrium at a smaller load
    // is the tangent (linear) prediction of the loading path.
    if (opt.firstStep && it == 0 && !modified && tau == 0) *opt.firstStep = d;

    // Loads far beyond what the model can hold: the linear response to them
    // is itself beyond double precision.
    const double stepLength = maxVertexStep(system, d);
    if (it == 0 && !modified && tau == 0 && !(stepLength <= kAbsurdDisplacement * size)) {
      rep.outcome = Outcome::NumericalFailure;
      rep.message = "the loads are beyond double precision: the linear response to them moves a vertex by " +
                    formatNumber("%.3g", stepLength) + " m, a structure of " + formatNumber("%.3g", size) + " m";
      break;
    }
    // Trust radius on the vertex displacements; a modified step's twist
    // components are limited to a quarter turn.
    double cap = 1.0;
    if (opt.trustRegion) {
      if (stepLength > radius) cap = radius / stepLength;
      if (modified && n > nv) {
        const double dth = d.tail(n - nv).lpNorm<Eigen::Infinity>();
        if (dth * cap > 0.5 * kPi) cap = 0.5 * kPi / dth;
      }
    }
    const bool capped = cap < 1.0;
    if (capped) d *= cap;

    // Backtracking line search on Phi; near convergence, where its
    // differences drown in round-off, a step that reduces the residual is
    // accepted instead.
    double alpha = 1.0;
    const double slope = g.dot(d);
    bool accepted = false, anyFinite = false, outsideRegion = false;
    double Etrial = 0.0;
    for (int b = 0; b <= opt.maxBacktracks; ++b) {
      uTrial = u + alpha * d;
      ta = Clock::now();
      Etrial = energyAt(trial);
      rep.assemblySeconds += since(ta);
      if (std::isfinite(Etrial)) {
        anyFinite = true;
        if (Etrial <= E + opt.armijo * alpha * slope) {
          accepted = true;
        } else if (std::abs(Etrial - E) <= 1e-12 * std::max(std::abs(E), 1e-300)) {
          // Differences at round-off: judge the step by the residual.
          evaluate(trial, &gTrial, nullptr);
          accepted = gTrial.allFinite() && system.forceResidual(gTrial).norm() < res;
        }
        if (accepted) break;
      }
      if (opt.stopOutsideNewtonRegion) {
        outsideRegion = true;
        break;
      }
      alpha *= 0.5;
      rep.backtracks++;
    }
    if (outsideRegion) {
      rep.outcome = Outcome::Stalled;
      rep.message = "left Newton's region of convergence (the full Newton step did not lower the energy enough)";
      break;
    }
    if (accepted) {
      ta = Clock::now();
      Etrial = evaluate(trial, &gTrial, &H);
      rep.assemblySeconds += since(ta);
      accepted = std::isfinite(Etrial) && gTrial.allFinite();
    }
    if (!accepted) {
      if (!anyFinite) {
        rep.outcome = Outcome::NumericalFailure;
        rep.message = "line search failed: the energy is not finite anywhere along the step";
      } else {
        rep.outcome = Outcome::Stalled;
        rep.message = "line search failed: no step along the descent direction lowers the energy";
      }
      break;
    }
    if (debug)
      std::fprintf(stderr,
                   "it %3d  E %.12e  res %.3e  floor %.3e  neg %d  sing %d  tau %.1e  cap %.2e  alpha %.3e  |dx| %.3e "
                   "|dth| %.3e\n",
                   it, E, rep.relativeResidual, scale > 0 ? floorForce / scale : floorForce, negative, singular, tau,
                   cap, alpha, alpha * maxVertexStep(system, d),
                   n > nv ? alpha * d.tail(n - nv).lpNorm<Eigen::Infinity>() : 0.0);
    if (capped) radius = alpha == 1.0 ? 4.0 * radius : std::max(alpha * radius, 1e-6 * size);
    u = uTrial;
    E = Etrial;
    g = gTrial;
    // Edges that turned far from their reference-frame chart get a new one
    // (same energy, new coordinates): the derivatives are re-evaluated.
    if (opt.reanchor) {
      if (std::optional<PoseState> moved = system.reanchored(state, design)) {
        rep.chartUpdates++;
        state = std::move(*moved);
        trial.charts = state.charts;
        E = evaluate(state, &g, &H);
      }
    }
  }
  rep.usable = rep.outcome != Outcome::NumericalFailure && std::isfinite(E) && u.allFinite();
  rep.timeSeconds = since(t0);
  return rep;
}

}  // namespace rodmesh
