#include "solver/newton.hh"

#include <Eigen/SparseCholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "solver/modified_ldlt.hh"

namespace rodmesh {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

using Ldlt = Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>>;

constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr double kPi = 3.14159265358979323846;
// Rule 3: a Newton correction within this many units of round-off of every
// unknown cannot improve the state.
constexpr double kCorrectionUlps = 4.0;
// The first Newton step from a state may not displace a vertex by more than
// this many times the structure's size: such loads are beyond what double
// precision can represent in equilibrium (energies ~ stiffness x size^2 x
// this^2 would overflow).
constexpr double kAbsurdDisplacement = 1e100;

// Deterministic pseudo-random signs (splitmix64 of the index).
double pseudoSign(std::uint64_t i) {
  std::uint64_t z = i + 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return (z >> 63) ? 1.0 : -1.0;
}

// Largest vertex displacement of a step (Euclidean per vertex).
double maxVertexStep(const PoseSystem& sys, const Eigen::VectorXd& d) {
  const int D = sys.dofsPerVertex();
  double m = 0.0;
  for (int k = 0; k + D <= sys.numVertexDofs(); k += D) m = std::max(m, d.segment(k, D).stableNorm());
  return m;
}

// Diagonal of the structure's bounding box at u (at least one mean edge).
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

std::string format(const char* fmt, double a) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, a);
  return buf;
}

// Newton from state.u at state.loadFactor; the state's unknowns and charts
// are updated in place.
NewtonReport newtonSolveUntil(const PoseSystem& system, const Design& design, PoseState& state, double scale,
                              double tolerance, const NewtonOptions& opt, Clock::time_point deadline,
                              bool hasDeadline, Eigen::VectorXd* firstStep = nullptr, bool stopAtNegative = false) {
  const auto t0 = Clock::now();
  NewtonReport rep;
  rep.loadScale = scale;
  rep.loadSteps = 1;
  rep.loadFactor = state.loadFactor;
  const int n = system.numDofs();
  const int nv = system.numVertexDofs();
  Eigen::VectorXd& u = state.u;
  // Trial points of the line searches share the state's charts and load factor.
  PoseState trial = state;
  Eigen::VectorXd& uTrial = trial.u;
  Eigen::VectorXd g(n), gTrial(n), d(n);
  Eigen::SparseMatrix<double> H;  // the Hessian at u (lower triangle)
  double E = 0.0;
  if (n == 0) {
    E = system.evaluate(state, design, &g, nullptr);
    rep.converged = true;
    rep.outcome = Outcome::Converged;
    rep.energy = E;
    rep.message = "no unknowns";
    return rep;
  }

  ModifiedLdlt factor;
  int escapes = 0;
  const bool debug = std::getenv("RODMESH_DEBUG_NEWTON") != nullptr;
  const double size = structureSize(system, design, state);
  // Trust radius on vertex displacements (m) for every step; grows after a
  // full step that it limited, shrinks to what the line search accepted.
  double radius = size;

  auto ta = Clock::now();
  E = system.evaluate(state, design, &g, &H);
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
    rep.residualNorm = res;
    rep.relativeResidual = scale > 0 ? res / scale : res;
    rep.residualHistory.push_back(rep.relativeResidual);
    rep.energy = E;

    // Factorize the Hessian at the current point (solver/modified_ldlt.hh).
    const Eigen::SparseMatrix<double>& H0 = H;
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

    // Round-off floor at this state (rule 2).
    const Eigen::VectorXd a = roundoff::unknownScale(system, u);
    const Eigen::VectorXd rho = roundoff::residualFloor(H0, a);
    double floorForce = system.forceResidual(rho).norm();
    if (!std::isfinite(floorForce)) floorForce = 0.0;
    rep.roundoffFloor = floorForce;

    const bool small = res <= tolerance * scale;
    if (stopAtNegative && negative > 0) {
      // A load step of the loading path that meets negative curvature is too
      // long, or crosses a critical point: the caller shortens it.
      rep.outcome = Outcome::Stalled;
      rep.message = "met negative curvature";
      break;
    }
    if (small && negative == 0) {
      rep.converged = true;
      rep.outcome = Outcome::Converged;
      rep.message = "force residual below tolerance";
      break;
    }
    if (factorOk && negative == 0 && haveDir) {
      if (res <= floorForce) {
        // The decrement over the modes with stiffness: along a zero-stiffness
        // mode the floored pivot says nothing, and the residual there is
        // already judged by the floor.
        // Along zero-stiffness modes, every component of the residual must be
        // within its own round-off (a light part hinged to a heavy one is not
        // judged by the heavy part's floor).
        const double noiseDecrement = roundoff::energyFloor(H0, a);
        const double decrement = factor.stiffDecrement(-g);
        const bool componentsAtFloor =
            singular == 0 || (system.forceResidual(g).cwiseAbs().array() <= system.forceResidual(rho).array()).all();
        if (debug)
          std::fprintf(stderr, "it %3d  at floor: res %.3e N floor %.3e N decrement %.3e J noise %.3e J\n", it, res,
                       floorForce, decrement, noiseDecrement);
        if (decrement <= noiseDecrement && componentsAtFloor) {
          rep.converged = true;
          rep.outcome = Outcome::Converged;
          rep.roundoff = true;
          rep.message = "force residual " + format("%.3g", res) + " N at the round-off floor of this problem (" +
                        format("%.3g", floorForce) +
                        " N) with a Newton decrement below the energy of rounding the unknowns";
          break;
        }
      }
      if (!modified && (d.cwiseAbs().array() <= kCorrectionUlps * kEps * u.cwiseAbs().array()).all()) {
        rep.converged = true;
        rep.outcome = Outcome::Converged;
        rep.roundoff = true;
        rep.message = "Newton correction below the round-off of every unknown (force residual " + format("%.3g", res) +
                      " N, round-off floor " + format("%.3g", floorForce) + " N)";
        break;
      }
    }
    const bool atFloor = res <= floorForce;
    if (it >= opt.maxIterations) {
      // Still progressing (a long descent such as a mechanism's rigid swing,
      // not a stall): over the last tenth of the iterations the energy fell
      // by more than its round-off, and either the residual reached a new
      // low or that tenth (of a run of at least 20 iterations) still gained
      // at least 1 % of the energy the whole run gained. The second case is
      // a soft structure swinging into its loaded shape from a state near
      // equilibrium under a small load (the rest state, or one small load
      // step beyond an equilibrium): its residual grows during the swing and
      // is not below its initial value until the end, while a stall gains
      // ever less energy.
      {
        const auto& hist = rep.residualHistory;
        const std::size_t tenth = std::max<std::size_t>(1, hist.size() / 10);
        const double before = *std::min_element(hist.begin(), hist.end() - tenth);
        const double recent = *std::min_element(hist.end() - tenth, hist.end());
        const double gainedRecently = energyAtTenth - E;
        rep.progressing = hist.size() > tenth && gainedRecently > 1e-12 * std::max(std::abs(E), 1e-300) &&
                          (recent < before || (tenth >= 2 && gainedRecently >= 0.01 * (energyAtStart - E)));
      }
      const bool saddle = (small || atFloor) && negative > 0;
      rep.message = saddle ? "reached an unstable equilibrium (negative curvature persists) at the iteration limit"
                           : "iteration limit reached";
      rep.unstable = saddle;
      rep.outcome = saddle ? Outcome::Stalled : Outcome::MaxIterations;
      break;
    }
    if ((hasDeadline && Clock::now() > deadline) || (opt.cancel && opt.cancel->load())) {
      rep.outcome = Outcome::TimeLimit;
      rep.message = "time limit reached";
      break;
    }

    // At an unstable equilibrium (a saddle, e.g. a perfectly straight column
    // above its buckling load), step along a direction of negative curvature:
    // z = P^T L^-T e_k has z^T H z = D_k < 0.
    if (factorOk && negative > 0 && (small || atFloor || res <= 1e-6 * scale) && escapes < opt.maxEscapes) {
      Eigen::VectorXd z = factor.negativeCurvatureDirection();
      if (z.dot(g) > 0) z = -z;
      z *= 0.1 * system.momentArm() / std::max(z.head(nv).lpNorm<Eigen::Infinity>(), 1e-300);
      if (!z.allFinite() || nv == 0) z.setZero();
      double best = E;
      Eigen::VectorXd uBest;
      for (double s = 1.0; s > 1e-6; s *= 0.5) {
        uTrial = u + s * z;
        const double Et = system.energy(trial, design);
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
        E = system.evaluate(state, design, &g, &H);
        rep.assemblySeconds += since(ta);
        rep.iterations++;
        continue;
      }
    }
    if (small || (atFloor && negative > 0 && escapes >= opt.maxEscapes)) {
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
    if (firstStep && it == 0 && !modified && tau == 0) *firstStep = d;

    // Loads far beyond what the model can hold: the linear response to them
    // is itself beyond double precision.
    const double stepLength = maxVertexStep(system, d);
    if (it == 0 && !modified && tau == 0 && !(stepLength <= kAbsurdDisplacement * size)) {
      rep.outcome = Outcome::NumericalFailure;
      rep.message = "the loads are beyond double precision: the linear response to them moves a vertex by " +
                    format("%.3g", stepLength) + " m, a structure of " + format("%.3g", size) + " m";
      break;
    }
    // Trust radius on the vertex displacements; a modified step's twist
    // components are limited to a quarter turn.
    double cap = 1.0;
    if (stepLength > radius) cap = radius / stepLength;
    if (modified && n > nv) {
      const double dth = d.tail(n - nv).lpNorm<Eigen::Infinity>();
      if (dth * cap > 0.5 * kPi) cap = 0.5 * kPi / dth;
    }
    const bool capped = cap < 1.0;
    if (capped) d *= cap;

    // Backtracking line search on the energy; near convergence, where energy
    // differences drown in round-off, a step that reduces the residual is
    // accepted instead.
    double alpha = 1.0;
    const double slope = g.dot(d);
    bool accepted = false, anyFinite = false;
    double Etrial = 0.0;
    for (int b = 0; b <= opt.maxBacktracks; ++b) {
      uTrial = u + alpha * d;
      ta = Clock::now();
      Etrial = system.energy(trial, design);
      rep.assemblySeconds += since(ta);
      if (std::isfinite(Etrial)) {
        anyFinite = true;
        if (Etrial <= E + opt.armijo * alpha * slope) {
          accepted = true;
        } else if (std::abs(Etrial - E) <= 1e-12 * std::max(std::abs(E), 1e-300)) {
          // Energy differences at round-off: judge the step by the residual.
          system.evaluate(trial, design, &gTrial, nullptr);
          accepted = gTrial.allFinite() && system.forceResidual(gTrial).norm() < res;
        }
        if (accepted) break;
      }
      alpha *= 0.5;
      rep.backtracks++;
    }
    if (accepted) {
      ta = Clock::now();
      Etrial = system.evaluate(trial, design, &gTrial, &H);
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
    if (std::optional<PoseState> moved = system.reanchored(state, design)) {
      rep.chartUpdates++;
      state = std::move(*moved);
      trial.charts = state.charts;
      E = system.evaluate(state, design, &g, &H);
    }
  }
  rep.timeSeconds = since(t0);
  return rep;
}

}  // namespace

std::string NewtonOptions::isValid() const {
  if (maxIterations < 1) return "maxIterations must be at least 1";
  if (!(tolerance > 0 && tolerance < 1)) return "tolerance must lie in (0, 1)";
  if (!(armijo > 0 && armijo < 0.5)) return "armijo must lie in (0, 0.5)";
  if (maxBacktracks < 1) return "maxBacktracks must be at least 1";
  if (!(minShift > 0 && maxShift > minShift)) return "need 0 < minShift < maxShift";
  if (maxLoadHalvings < 0 || maxLoadHalvings > 60) return "maxLoadHalvings must lie in [0, 60]";
  if (maxEscapes < 0) return "maxEscapes must be non-negative";
  if (!(timeLimit >= 0) || !std::isfinite(timeLimit)) return "timeLimit must be finite and non-negative";
  return "";
}

namespace {
// The force residual of the rest unknowns under the full load, twists
// measured in the given charts.
double loadScaleIn(const PoseSystem& system, const Design& design, const Charts& charts) {
  Eigen::VectorXd g;
  system.evaluate(PoseState{system.restDofs(design), charts, 1.0}, design, &g, nullptr);
  const Eigen::VectorXd r = system.forceResidual(g);
  if (!r.allFinite()) return std::numeric_limits<double>::infinity();
  return r.stableNorm();
}
}  // namespace

double loadScale(const PoseSystem& system, const Design& design) {
  return loadScaleIn(system, design, system.restCharts(design));
}

double roundoffFloor(const PoseSystem& system, const Eigen::SparseMatrix<double>& hessian, const Eigen::VectorXd& u) {
  if (system.numDofs() == 0) return 0.0;
  const double f = system.forceResidual(roundoff::residualFloor(hessian, roundoff::unknownScale(system, u))).norm();
  return std::isfinite(f) ? f : 0.0;
}

bool Stability::zeroMode() const {
  return ok && std::abs(smallestEigenvalue) <= kPivotRoundoff * kEps * largestDiagonal;
}

Stability stability(const PoseSystem& system, const Design& design, const PoseState& state) {
  Stability out;
  const int n = system.numDofs(), nv = system.numVertexDofs();
  if (n == 0) {
    out.ok = true;
    return out;
  }
  Eigen::VectorXd g;
  Eigen::SparseMatrix<double> H;
  system.evaluate(state, design, &g, &H);
  // K = S H S with S = 1 on coordinates, 1/momentArm on twists.
  Eigen::VectorXd s = Eigen::VectorXd::Ones(n);
  s.tail(n - nv).setConstant(1.0 / system.momentArm());
  Eigen::SparseMatrix<double> K = s.asDiagonal() * H * s.asDiagonal();
  if (!Eigen::Map<const Eigen::VectorXd>(K.valuePtr(), K.nonZeros()).allFinite()) return out;
  for (int k = 0; k < K.outerSize(); ++k)
    for (Eigen::SparseMatrix<double>::InnerIterator it(K, k); it; ++it)
      if (it.row() == it.col()) out.largestDiagonal = std::max(out.largestDiagonal, std::abs(it.value()));
  Ldlt ldlt;
  ldlt.compute(K);
  Eigen::VectorXd D = ldlt.vectorD();
  if (ldlt.info() != Eigen::Success || !D.allFinite()) {
    // Exactly singular: shift by round-off and retry.
    double maxDiag = 0.0;
    for (int k = 0; k < K.outerSize(); ++k)
      for (Eigen::SparseMatrix<double>::InnerIterator it(K, k); it; ++it)
        if (it.row() == it.col()) maxDiag = std::max(maxDiag, std::abs(it.value()));
    Eigen::SparseMatrix<double> I(n, n);
    I.setIdentity();
    K += (kPivotRoundoff * kEps * std::max(maxDiag, 1e-300)) * I;
    ldlt.compute(K);
    D = ldlt.vectorD();
    if (ldlt.info() != Eigen::Success || !D.allFinite()) return out;
  }
  out.ok = true;
  for (int i = 0; i < n; ++i)
    if (D[i] < 0) ++out.negative;
  // Inverse iteration: converges to the eigenvalue of smallest magnitude.
  Eigen::VectorXd x(n);
  for (int i = 0; i < n; ++i) x[i] = pseudoSign(static_cast<std::uint64_t>(i)) * (1.0 + 0.5 * std::sin(0.37 * i));
  x.normalize();
  const Eigen::SparseMatrix<double> Kfull = K.selfadjointView<Eigen::Lower>();
  double lambda = 0.0;
  for (int k = 0; k < 60; ++k) {
    Eigen::VectorXd y = ldlt.solve(x);
    const double ny = y.norm();
    if (!(ny > 0) || !std::isfinite(ny)) break;
    x = y / ny;
    const double next = x.dot(Kfull * x);
    const bool settled = k > 3 && std::abs(next - lambda) <= 1e-10 * std::abs(next);
    lambda = next;
    if (settled) break;
  }
  out.smallestEigenvalue = lambda;
  return out;
}

NewtonReport newtonSolve(const PoseSystem& system, const Design& design, PoseState& state, double scale,
                         double tolerance, const NewtonOptions& opt) {
  return newtonSolveUntil(system, design, state, scale, tolerance, opt, Clock::now(), false);
}

NewtonReport solveEquilibrium(const PoseSystem& system, const Design& design, Eigen::VectorXd& u,
                              const NewtonOptions& opt) {
  PoseState state = system.restState(design);
  state.u = u;
  const NewtonReport r = solveEquilibrium(system, design, state, opt);
  u = state.u;
  return r;
}

NewtonReport solveEquilibrium(const PoseSystem& system, const Design& design, PoseState& state,
                              const NewtonOptions& opt) {
  const auto t0 = Clock::now();
  const bool hasDeadline = opt.timeLimit > 0;
  const auto deadline = t0 + std::chrono::duration_cast<Clock::duration>(
                                 std::chrono::duration<double>(hasDeadline ? std::min(opt.timeLimit, 1e9) : 0.0));
  Eigen::VectorXd& u = state.u;
  const PoseState rest = system.restState(design);
  const double scale = loadScaleIn(system, design, state.charts);
  // The charts of the state being solved: they travel with its unknowns.
  Charts charts = state.charts;
  // Newton from uIn (updated) at load factor lf in `charts` (updated).
  auto solveAt = [&](double lf, Eigen::VectorXd& uIn, double tol, const NewtonOptions& o,
                     Eigen::VectorXd* firstStep = nullptr, bool stopAtNegative = false) {
    PoseState s{std::move(uIn), std::move(charts), lf};
    NewtonReport rs = newtonSolveUntil(system, design, s, scale, tol, o, deadline, hasDeadline, firstStep,
                                       stopAtNegative);
    uIn = std::move(s.u);
    charts = std::move(s.charts);
    return rs;
  };
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
    state.charts = charts;
    state.loadFactor = lam;
    total.loadFactor = lam;
  };
  if (!std::isfinite(scale)) {
    // Loads that overflow: nothing can be solved; the rest state is returned.
    total.outcome = Outcome::NumericalFailure;
    total.message =
        "the loads overflow double precision (their force residual at rest is not finite): no equilibrium "
        "can be computed; the returned state is the rest state";
    u = rest.u;
    charts = rest.charts;
    total.residualNorm = scale;
    total.relativeResidual = 1.0;
    total.timeSeconds = since(t0);
    finishState(0.0);
    return total;
  }
  // A pose whose loads add nothing to the force at rest beyond that force's
  // own round-off (no gravity, force or moment, held vertices at their rest
  // positions: only the rest shape's round-off is left, e.g. 2.5e-15 N) has
  // no load: the rest configuration is its equilibrium, and a loading path
  // towards it would only chase noise (thousands of load steps). The
  // applied part is the difference of the rest residuals at load factors 1
  // and 0, exactly zero when nothing is applied; a straight rod's residual
  // at rest is exactly zero, so a real load however light stays a load.
  // Checked for solves that start at rest (one more gradient there).
  bool noLoad = scale == 0.0;
  if (!noLoad && state.loadFactor <= 0.0) {
    Eigen::VectorXd g0, g1;
    system.evaluate(PoseState{rest.u, state.charts, 0.0}, design, &g0, nullptr);
    system.evaluate(PoseState{rest.u, state.charts, 1.0}, design, &g1, nullptr);
    const Eigen::VectorXd r0 = system.forceResidual(g0), r1 = system.forceResidual(g1);
    noLoad = r0.allFinite() && r1.allFinite() && (r1 - r0).stableNorm() <= r0.stableNorm();
  }
  if (noLoad) {
    // No load at all: the rest configuration is the equilibrium.
    total.converged = true;
    total.outcome = Outcome::Converged;
    total.message = "no load: rest configuration";
    u = rest.u;
    charts = rest.charts;
    Eigen::VectorXd g;
    const double e = system.evaluate(PoseState{u, charts, 1.0}, design, &g, nullptr);
    total.residualNorm = system.forceResidual(g).stableNorm();
    total.energy = e;
    total.timeSeconds = since(t0);
    finishState(1.0);
    return total;
  }

  // Full load first, from the given state. A run that ends at its iteration
  // limit while still descending steadily resumes from where it stopped: a
  // mechanism's large rigid motion (a sheet swinging about a line of pinned
  // vertices) takes many iterations at any load, and smaller load steps do
  // not shorten it.
  //
  // On the loading path (opt.loadingPath), a state given at the full load is
  // the equilibrium of a nearby design, or an optimizer's approximation of
  // one (a warm start): Newton from it continues that equilibrium in the
  // design and is kept when it converges (to a stable state; whether that
  // is the loading path's equilibrium is judged on the final design,
  // solver/design_fallback.hh). From any other state the
  // full load is one step of the path from the state's load factor (rest:
  // 0), kept when it is on the path (onPath below); otherwise the load is
  // applied in adaptive steps.
  const bool path = opt.loadingPath;
  const bool warm = state.loadFactor >= 1.0;
  const double size = structureSize(system, design, rest);
  // Path steps that meet negative curvature are abandoned at once (they are
  // shortened); their correctors are limited to this many iterations.
  const int pathIterations = std::min(opt.maxIterations, 50);
  NewtonOptions stepOpt = opt;
  stepOpt.maxIterations = path ? pathIterations : opt.maxIterations;
  // A load step from the equilibrium `from` to the converged `to` is on the
  // loading path when the corrector met no negative curvature and `to` lies
  // within opt.pathDeviation of the tangent prediction's displacement from
  // that prediction (the first unmodified Newton step `tangent`): a state
  // found much farther away belongs to another branch, or the step was too
  // long to tell. Returns the deviation ratio (< 0: not on the path).
  auto pathDeviation = [&](const NewtonReport& rs, const Eigen::VectorXd& from, const Eigen::VectorXd& to,
                           const Eigen::VectorXd& tangent) -> double {
    if (!rs.converged || rs.negativeIterations > 0 || rs.escapes > 0) return -1.0;
    if (tangent.size() != from.size()) return -1.0;
    const double lin = maxVertexStep(system, tangent);
    const double dev = maxVertexStep(system, to - from - tangent);
    if (dev <= 1e-9 * size) return 0.0;
    const double ratio = dev / lin;
    return ratio <= opt.pathDeviation ? ratio : -1.0;
  };

  Eigen::VectorXd uTry = u, tangent;
  const bool fullFromState = !path || warm;
  NewtonReport r = solveAt(1.0, uTry, opt.tolerance, fullFromState ? opt : stepOpt, &tangent, path && !warm);
  merge(r);
  for (int resume = 0; fullFromState && !r.converged && r.outcome == Outcome::MaxIterations && r.progressing &&
                       resume < opt.maxLoadHalvings;
       ++resume) {
    r = solveAt(1.0, uTry, opt.tolerance, opt);
    merge(r);
    total.resumes++;
  }
  bool accepted = false;
  if (!path)
    accepted = r.converged;
  else if (warm)
    accepted = r.converged;
  else
    accepted = pathDeviation(r, u, uTry, tangent) >= 0.0;
  double reached = 1.0;
  if (accepted) {
    u = uTry;
  } else if (r.outcome == Outcome::TimeLimit) {
    // The initial guess is returned with its own charts.
    reached = state.loadFactor;
    charts = state.charts;
    r.message = "time limit reached at the full load before convergence; the returned state is the initial guess";
  } else {
    // Adaptive continuation in the load factor from the rest state (or the
    // given state below the full load); the reference-frame charts travel
    // with the state they belong to. Not for a structure with a
    // zero-stiffness mode at rest (see the header): smaller loads need the
    // same large motion along it, and the full load from rest is its answer.
    const Stability unloaded = stability(system, design, rest);
    const bool fromGiven = !warm && state.loadFactor > 0.0;
    Eigen::VectorXd uCur = fromGiven ? u : rest.u;
    PoseSystem::Charts chartsCur = fromGiven ? state.charts : rest.charts;
    double lam = fromGiven ? state.loadFactor : 0.0;
    double step = 0.5 * (1.0 - lam);
    const double minStep = std::ldexp(1.0, -opt.maxLoadHalvings);
    // Intermediate load steps need not be tight, but never sloppy.
    const double stepTol = std::min(std::max(opt.tolerance, 1e-6), 1e-4);
    bool failed = false, timedOut = false;
    bool negativeBeyond = false;  // a failed step beyond lam met negative curvature
    int pathSteps = 0;            // load steps kept (jumps past critical points included)
    if (unloaded.zeroMode() && r.outcome != Outcome::NumericalFailure) {
      if (path && !r.converged) {
        // The path step stopped at negative curvature (or the warm start
        // failed): a mechanism's answer is the full load from rest, wherever
        // its rigid motion leads.
        charts = rest.charts;
        uTry = rest.u;
        r = solveAt(1.0, uTry, opt.tolerance, opt);
        merge(r);
        for (int resume = 0;
             !r.converged && r.outcome == Outcome::MaxIterations && r.progressing && resume < opt.maxLoadHalvings;
             ++resume) {
          r = solveAt(1.0, uTry, opt.tolerance, opt);
          merge(r);
          total.resumes++;
        }
      }
      if (path && r.converged) {
        uCur = uTry;
        chartsCur = charts;
        lam = 1.0;
      } else {
        failed = true;
      }
    }
    while (lam < 1.0 && !failed) {
      if ((hasDeadline && Clock::now() > deadline) || (opt.cancel && opt.cancel->load())) {
        timedOut = true;
        break;
      }
      const double next = std::min(1.0, lam + step);
      charts = chartsCur;
      uTry = uCur;
      tangent.resize(0);
      NewtonReport rs = solveAt(next, uTry, next < 1.0 ? stepTol : opt.tolerance, stepOpt, &tangent, path);
      merge(rs);
      r = rs;
      const double deviation = path ? pathDeviation(rs, uCur, uTry, tangent) : (rs.converged ? 0.0 : -1.0);
      if (deviation >= 0.0) {
        ++pathSteps;
        lam = next;
        uCur = uTry;
        chartsCur = charts;
        if (deviation <= 0.25 * opt.pathDeviation) step = std::min(2 * step, 1.0);
        negativeBeyond = false;
        continue;
      }
      if (rs.outcome == Outcome::TimeLimit) {
        timedOut = true;
        break;
      }
      negativeBeyond = negativeBeyond || rs.negativePivots > 0 || rs.escapes > 0 || rs.unstable ||
                       rs.negativeIterations > 0;
      step *= 0.5;
      if (step >= minStep) continue;
      if (path) {
        // No step of at least minStep stays on the branch: a limit or
        // bifurcation point (or a path too steep to follow). Under a load
        // that keeps rising the structure leaves it for the equilibrium it
        // falls into (a snap-through, or buckling into a lateral mode): one
        // unrestricted solve just beyond it, from the last state of the
        // branch.
        const double beyond = std::min(1.0, lam + minStep);
        charts = chartsCur;
        uTry = uCur;
        NewtonReport rj = solveAt(beyond, uTry, beyond < 1.0 ? stepTol : opt.tolerance, opt);
        merge(rj);
        for (int resume = 0;
             !rj.converged && rj.outcome == Outcome::MaxIterations && rj.progressing && resume < opt.maxLoadHalvings;
             ++resume) {
          rj = solveAt(beyond, uTry, beyond < 1.0 ? stepTol : opt.tolerance, opt);
          merge(rj);
          total.resumes++;
        }
        r = rj;
        if (rj.outcome == Outcome::TimeLimit) {
          timedOut = true;
          break;
        }
        if (rj.converged) {
          const Stability there = stability(system, design, PoseState{uCur, chartsCur, lam});
          const bool critical = negativeBeyond || (there.ok && unloaded.ok && unloaded.smallestEigenvalue > 0 &&
                                                   there.smallestEigenvalue <= 1e-2 * unloaded.smallestEigenvalue);
          if (critical) {
            CriticalPoint cp;
            cp.loadFactor = lam;
            cp.smallestEigenvalue = there.smallestEigenvalue;
            cp.jump = maxVertexStep(system, uTry - uCur);
            total.criticalPoints.push_back(cp);
          }
          ++pathSteps;
          lam = beyond;
          uCur = uTry;
          chartsCur = charts;
          step = 2 * minStep;
          negativeBeyond = false;
          continue;
        }
        negativeBeyond = negativeBeyond || rj.negativePivots > 0 || rj.unstable;
      }
      failed = true;
    }
    u = uCur;
    charts = chartsCur;
    reached = lam;
    if (!failed && !timedOut && lam >= 1.0) {
      r.converged = true;
      r.outcome = Outcome::Converged;
      if (path && pathSteps > 0) {
        std::ostringstream os;
        os << r.message << "; loading path followed in " << pathSteps << " load steps";
        for (const CriticalPoint& cp : total.criticalPoints)
          os << "; passed a critical point at load factor " << format("%.4g", cp.loadFactor)
             << " (smallest stiffness eigenvalue " << format("%.3g", cp.smallestEigenvalue)
             << " N/m): the structure left its branch there and jumped by " << format("%.3g", cp.jump)
             << " m to the equilibrium beyond (snap-through or buckling)";
        r.message = os.str();
      }
    }
    if (timedOut) {
      r.converged = false;
      r.outcome = Outcome::TimeLimit;
      r.message = "time limit reached at load factor " + format("%.6g", lam) + "; the returned state is the " +
                  (lam > 0 ? "equilibrium at load factor " + format("%.6g", lam) + ", not at the full load"
                           : std::string("rest state"));
    } else if (failed) {
      const std::string last = r.message;
      const Outcome lastOutcome = r.outcome;
      r.converged = false;
      std::ostringstream os;
      const std::string returned = lam > 0 ? "the returned state is the equilibrium at load factor " +
                                                 format("%.6g", lam) + ", not at the full load"
                                           : std::string("the returned state is the rest state (load factor 0)");
      if (lastOutcome == Outcome::NumericalFailure && lam == 0.0) {
        // Even the smallest load step cannot be represented.
        r.outcome = Outcome::NumericalFailure;
        os << "failed at every load step down to " << minStep << " of the full load (" << last << "); " << returned;
      } else {
        const Stability here = lam == 0.0 ? unloaded : stability(system, design, PoseState{uCur, chartsCur, lam});
        total.smallestEigenvalue = here.smallestEigenvalue;
        const bool lost = negativeBeyond || (here.ok && unloaded.ok && unloaded.smallestEigenvalue > 0 &&
                                             here.smallestEigenvalue <= 1e-2 * unloaded.smallestEigenvalue);
        r.outcome = Outcome::Stalled;
        if (unloaded.zeroMode()) {
          os << "the unloaded structure has a mode without stiffness that double precision resolves (smallest "
                "eigenvalue "
             << format("%.3g", unloaded.smallestEigenvalue) << " N/m, at the round-off of stiffnesses up to "
             << format("%.3g", unloaded.largestDiagonal)
             << " N/m): either a mechanism, which the loads must carry through a large rigid motion that Newton did "
                "not complete (vertices held by 'fixed' along one straight line act as a hinge: clamp one, or hold "
                "one off that line; an unsupported part moves freely), or a discretization too fine for double "
                "precision (the bending stiffness of a rod of N edges spans ~N^4); "
             << returned << " (last attempt: " << last << ")";
        } else if (lost) {
          os << "the equilibrium path was lost at load factor " << format("%.6g", lam)
             << ": no equilibrium was found within a load step of " << minStep
             << " beyond it (a limit or bifurcation point; smallest stiffness eigenvalue there "
             << format("%.4g", here.smallestEigenvalue) << " N/m, unloaded "
             << format("%.4g", unloaded.smallestEigenvalue) << " N/m"
             << (negativeBeyond ? "; negative curvature beyond it" : "") << "); " << returned
             << " (last attempt: " << last << ")";
        } else {
          os << "did not reach the full load: the load step fell below " << minStep << " at load factor "
             << format("%.6g", lam) << " (smallest stiffness eigenvalue there "
             << format("%.4g", here.smallestEigenvalue) << " N/m); " << returned << " (last attempt: " << last << ")";
        }
      }
      r.message = os.str();
    }
  }
  // The final verdict is judged at the full load, whatever the last step said.
  Eigen::VectorXd g;
  const double e = system.evaluate(PoseState{u, charts, 1.0}, design, &g, nullptr);
  total.residualNorm = system.forceResidual(g).stableNorm();
  total.relativeResidual = total.residualNorm / scale;
  total.energy = e;
  if (!std::isfinite(total.residualNorm) || !std::isfinite(e)) {
    r.converged = false;
    r.outcome = Outcome::NumericalFailure;
    r.message = "the final state has non-finite energy or forces (" + r.message + ")";
  } else if (r.converged && !r.roundoff &&
             !(total.residualNorm <= std::max(1e3 * opt.tolerance, std::sqrt(opt.tolerance)) * scale ||
               total.residualNorm <= r.roundoffFloor)) {
    r.converged = false;
    r.outcome = Outcome::Stalled;
    r.message = "the final state does not satisfy equilibrium at the full load (" + r.message + ")";
  }
  total.converged = r.converged;
  total.outcome = r.converged ? Outcome::Converged : r.outcome;
  if (!r.converged && total.outcome == Outcome::Converged) total.outcome = Outcome::Stalled;
  total.unstable = r.unstable;
  total.roundoff = r.roundoff;
  total.roundoffFloor = r.roundoffFloor;
  total.negativePivots = r.negativePivots;
  total.singularPivots = r.singularPivots;
  total.message = r.message;
  total.timeSeconds = since(t0);
  finishState(reached);
  return total;
}

}  // namespace rodmesh
