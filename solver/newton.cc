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

#include "solver/minimizer.hh"
#include "solver/format.hh"
#include "solver/modified_ldlt.hh"

namespace rodmesh {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

using Ldlt = Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>>;

constexpr double kEps = std::numeric_limits<double>::epsilon();

// Whether two states measure their twists in the same charts.
bool sameCharts(const Charts& a, const Charts& b) { return a.tangent == b.tangent && a.director == b.director; }
// Deterministic pseudo-random signs (splitmix64 of the index).
double pseudoSign(std::uint64_t i) {
  std::uint64_t z = i + 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return (z >> 63) ? 1.0 : -1.0;
}

// Newton from state.u at state.loadFactor (solver/minimizer.hh with the
// static settings: stable equilibria only, a trust radius, charts
// re-anchored); the state's unknowns and charts are updated in place.
NewtonReport newtonSolveUntil(const PoseSystem& system, const Design& design, PoseState& state, double scale,
                              double tolerance, const NewtonOptions& opt, Clock::time_point deadline,
                              bool hasDeadline, Eigen::VectorXd* firstStep = nullptr, bool stopAtNegative = false,
                              bool stopOutsideNewtonRegion = false) {
  MinimizerSettings s;
  s.scale = scale;
  s.tolerance = tolerance;
  s.maxIterations = opt.maxIterations;
  s.armijo = opt.armijo;
  s.maxBacktracks = opt.maxBacktracks;
  s.minShift = opt.minShift;
  s.maxShift = opt.maxShift;
  s.maxEscapes = opt.maxEscapes;
  s.stopAtNegative = stopAtNegative;
  s.stopOutsideNewtonRegion = stopOutsideNewtonRegion;
  s.firstStep = firstStep;
  if (hasDeadline) s.deadline = deadline;
  s.cancel = opt.cancel;
  MinimizerWorkspace workspace;
  return minimizeEnergy(system, design, state, s, workspace);
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
// measured in the given charts. Where it is not finite, the residual at the
// largest load factor 2^-k (k <= 40) where it is, over that factor: a held
// vertex prescribed past its neighbour along a straight rod makes that edge
// antiparallel to its rest tangent at the full load with the free vertices
// at rest, where its frame is undefined, though every state of the loading
// path is well defined (the free vertices move along). Infinite only when no load factor gives a finite
// residual (loads that overflow double precision).
double loadScaleIn(const PoseSystem& system, const Design& design, const Charts& charts) {
  const Eigen::VectorXd rest = system.restDofs(design);
  double factor = 1.0;
  for (int k = 0; k <= 40; ++k, factor *= 0.5) {
    Eigen::VectorXd g;
    system.evaluate(PoseState{rest, charts, factor, {}}, design, &g, nullptr);
    const Eigen::VectorXd r = system.forceResidual(g);
    if (r.allFinite()) return r.stableNorm() / factor;
  }
  return std::numeric_limits<double>::infinity();
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
  // Pivots classified as Newton's solver classifies them (solver/
  // modified_ldlt.hh): a pivot within round-off of its row's scale is a
  // zero-stiffness mode, not negative curvature, so that a mechanism's rigid
  // rotation about a hinge (a sheet held at two corners), whose eigenvalue
  // is round-off of either sign, does not make an equilibrium Newton
  // converged on unstable.
  ModifiedLdlt ldlt;
  if (!ldlt.factorize(K)) return out;
  out.ok = true;
  out.negative = ldlt.negative();
  // A pivot's sign says which side of zero its eigenvalue lies only up to
  // round-off: with a zero-stiffness mode the scaled matrix can show a
  // negative pivot that Newton's (unscaled) factorization did not. Negative
  // eigenvalues are those below minus the zero-mode round-off (zeroMode()),
  // counted by the pivots of K shifted up by it (Sylvester's law of inertia).
  if (out.negative > 0) {
    Eigen::SparseMatrix<double> shifted = K;
    for (int i = 0; i < n; ++i) shifted.coeffRef(i, i) += kPivotRoundoff * kEps * out.largestDiagonal;
    ModifiedLdlt check;
    if (check.factorize(shifted)) out.negative = std::min(out.negative, check.negative());
  }
  // Inverse iteration: converges to the eigenvalue of smallest magnitude.
  Eigen::VectorXd x(n);
  for (int i = 0; i < n; ++i) x[i] = pseudoSign(static_cast<std::uint64_t>(i)) * (1.0 + 0.5 * std::sin(0.37 * i));
  x.normalize();
  const Eigen::SparseMatrix<double> Kfull = K.selfadjointView<Eigen::Lower>();
  double lambda = 0.0;
  for (int k = 0; k < 60; ++k) {
    Eigen::VectorXd y = ldlt.solveUnmodified(x);
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
                     Eigen::VectorXd* firstStep = nullptr, bool stopAtNegative = false,
                     bool stopOutsideNewtonRegion = false) {
    PoseState s{std::move(uIn), std::move(charts), lf, state.internal};
    NewtonReport rs = newtonSolveUntil(system, design, s, scale, tol, o, deadline, hasDeadline, firstStep,
                                       stopAtNegative, stopOutsideNewtonRegion);
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
    // Beyond double precision, but finite: archives hold finite numbers.
    total.residualNorm = std::numeric_limits<double>::max();
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
  // (Internal variables other than the initial ones, e.g. a yielded tie's
  // rest length, can leave the rest configuration out of equilibrium
  // without any load: such a state is always solved.)
  const bool initialInternal =
      state.internal.size() == 0 ||
      (state.internal.size() == system.numInternal() && state.internal == system.initialInternal());
  bool noLoad = scale == 0.0 && initialInternal;
  if (!noLoad && initialInternal && state.loadFactor <= 0.0) {
    Eigen::VectorXd g0, g1;
    system.evaluate(PoseState{rest.u, state.charts, 0.0, {}}, design, &g0, nullptr);
    system.evaluate(PoseState{rest.u, state.charts, 1.0, {}}, design, &g1, nullptr);
    const Eigen::VectorXd r0 = system.forceResidual(g0), r1 = system.forceResidual(g1);
    noLoad = r0.allFinite() && r1.allFinite() && (r1 - r0).stableNorm() <= r0.stableNorm();
    // And that force is round-off: no larger than the stiffness times the
    // structure's size at a relative 1e6 machine epsilons. A rest state out
    // of equilibrium without any load (a model inconsistent at rest) is
    // solved, not returned as its own equilibrium.
    if (noLoad && r0.stableNorm() > 0.0) {
      Eigen::SparseMatrix<double> K;
      system.evaluate(PoseState{rest.u, state.charts, 0.0, {}}, design, nullptr, &K);
      const double stiffness = K.diagonal().cwiseAbs().maxCoeff();
      noLoad = r0.stableNorm() <= 1e6 * kEps * stiffness * structureSize(system, design, rest);
    }
  }
  if (noLoad) {
    // No load at all: the rest configuration is the equilibrium.
    total.outcome = Outcome::Converged;
    total.usable = true;
    total.message = "no load: rest configuration";
    u = rest.u;
    charts = rest.charts;
    Eigen::VectorXd g;
    const double e = system.evaluate(PoseState{u, charts, 1.0, {}}, design, &g, nullptr);
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
  // within opt.pathDeviation of the predicted displacement `prediction` from
  // the prediction: a state found much farther away belongs to another
  // branch, or the step was too long to tell. Returns the deviation ratio
  // (< 0: not on the path).
  auto pathDeviation = [&](const NewtonReport& rs, const Eigen::VectorXd& from, const Eigen::VectorXd& to,
                           const Eigen::VectorXd& prediction) -> double {
    if (!rs.converged() || rs.negativeIterations > 0 || rs.escapes > 0) return -1.0;
    if (prediction.size() != from.size()) return -1.0;
    const double dev = maxVertexStep(system, to - from - prediction);
    if (dev <= 1e-9 * size) return 0.0;
    const double ratio = dev / maxVertexStep(system, prediction);
    return ratio <= opt.pathDeviation ? ratio : -1.0;
  };

  // The tangent of the loading path at the equilibrium `from` (load factor
  // lamFrom): du/dlam = -K^-1 dF/dlam, with K the stiffness there (positive
  // definite: the equilibrium is stable) and dF/dlam the rate at which the
  // load factor changes the forces at fixed free unknowns (applied loads,
  // and the held vertices moving towards their prescribed positions), by a
  // central difference in the load factor (F is smooth in it; the step
  // keeps round-off and truncation far below the forces). Empty when `from`
  // is not an equilibrium within the intermediate steps' tolerance or K is
  // not positive definite: the caller then predicts with Newton's first
  // step instead.
  //
  // Why not Newton's first step from `from` at the new load: its stiffness
  // is that of a state whose held vertices have moved and whose free ones
  // have not. Edges next to a moved handle are stretched there by the
  // square of its sideways motion over their length, which the path never
  // sees (the free vertices follow), so the step is far from the path's
  // direction and, where edges are compressed, meets negative curvature at
  // once, so that the path's first step is shortened far below what the path
  // allows and has to double back to the full load.
  const double pathTol = std::min(std::max(opt.tolerance, 1e-6), 1e-4);
  auto pathTangent = [&](const Eigen::VectorXd& from, const Charts& fromCharts, double lamFrom) -> Eigen::VectorXd {
    Eigen::VectorXd g, gp, gm;
    Eigen::SparseMatrix<double> K;
    system.evaluate(PoseState{from, fromCharts, lamFrom, state.internal}, design, &g, &K);
    if (!(system.forceResidual(g).norm() <= pathTol * scale)) return {};
    const double h = 1e-6;
    system.evaluate(PoseState{from, fromCharts, lamFrom + h, state.internal}, design, &gp, nullptr);
    system.evaluate(PoseState{from, fromCharts, lamFrom - h, state.internal}, design, &gm, nullptr);
    const Eigen::VectorXd rate = (gp - gm) / (2 * h);
    if (!rate.allFinite()) return {};
    ModifiedLdlt ldlt;
    if (!ldlt.factorize(K) || ldlt.modified()) return {};
    Eigen::VectorXd du = -ldlt.solve(rate);
    if (!du.allFinite()) return {};
    return du;
  };

  // A step predicted by the tangent is only as long as Newton's corrector
  // can tell its branch: its corrector stops (and the step is shortened)
  // at the first iteration whose full Newton step does not lower the energy
  // enough or whose force residual rises (stopOutsideNewtonRegion,
  // solver/minimizer.hh). A corrector that wanders may settle on another
  // branch well within pathDeviation of a long prediction (a buckled one,
  // for a handle that is pushed as well as lifted; docs/model.md).
  // Only where held vertices are prescribed away from rest: under applied
  // loads alone the stiffness at fixed free unknowns does not depend on the
  // load factor, so Newton's first step is this tangent already.
  bool heldMove = false;
  if (path && !warm) {
    const std::vector<Vec3> x0 = system.positions(PoseState{rest.u, rest.charts, 0.0, {}}, design);
    const std::vector<Vec3> x1 = system.positions(PoseState{rest.u, rest.charts, 1.0, {}}, design);
    for (std::size_t v = 0; v < x0.size() && !heldMove; ++v)
      heldMove = system.isHeld(static_cast<int>(v)) && x0[v] != x1[v];
  }
  Eigen::VectorXd uTry = u, tangent;
  const bool fullFromState = !path || warm;
  bool tangentPredicted = false;
  if (path && !warm && heldMove) {
    tangent = pathTangent(u, charts, state.loadFactor);
    tangentPredicted = tangent.size() == u.size();
    if (tangent.size() == u.size()) {
      tangent *= 1.0 - state.loadFactor;
      uTry += tangent;
    } else {
      tangent.resize(0);
    }
  }
  NewtonReport r = solveAt(1.0, uTry, opt.tolerance, fullFromState ? opt : stepOpt,
                           tangent.size() > 0 ? nullptr : &tangent, path && !warm, tangentPredicted);
  merge(r);
  for (int resume = 0; fullFromState && !r.converged() && r.outcome == Outcome::MaxIterations && r.progressing &&
                       resume < opt.maxLoadHalvings;
       ++resume) {
    r = solveAt(1.0, uTry, opt.tolerance, opt);
    merge(r);
    total.resumes++;
  }
  bool accepted = false;
  if (!path)
    accepted = r.converged();
  else if (warm)
    accepted = r.converged();
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
    const double startLam = lam;
    double step = 0.5 * (1.0 - lam);
    const double minStep = std::ldexp(1.0, -opt.maxLoadHalvings);
    // Intermediate load steps need not be tight, but never sloppy.
    const double stepTol = std::min(std::max(opt.tolerance, 1e-6), 1e-4);
    bool failed = false, timedOut = false;
    bool negativeBeyond = false;  // a failed step beyond lam met negative curvature
    int pathSteps = 0;            // load steps kept (jumps past critical points included)
    // The prediction of a load step: the secant through the last two
    // equilibria of the path, scaled to the step, when there are two
    // (`lastKept`: the last step kept, its twists only where no chart was
    // re-anchored along it, over
    // `lastKeptLength` of load; not after a critical point, `afterJump`),
    // the corrector starting from the predicted state; the
    // tangent otherwise (the first Newton step from the last equilibrium).
    // The tangent alone misjudges a path along which stiff members turn (a
    // handle rolled through a large angle): Newton's linear step stretches
    // the turning rods to second order, and their axial stiffness, thousands
    // of times the bending stiffness that governs the motion, throws the
    // corrector far from that prediction however smooth the path, so that
    // every step was rejected down to the smallest. And starting the
    // corrector from the last equilibrium with the held vertices already at
    // their next positions compresses the rods next to them: negative
    // curvature at the first iterate, on a path that has none. The secant
    // follows a turning path to second order and moves the free vertices
    // with the held ones.
    // The last kept step is kept whatever it was (jumps included), to tell a
    // jump from a step along the path (below).
    Eigen::VectorXd lastKept;  // empty before the first step
    double lastKeptLength = 0.0;
    bool afterJump = false;  // the last kept step passed a critical point
    const int nv = system.numVertexDofs();
    if (unloaded.zeroMode() && r.outcome != Outcome::NumericalFailure) {
      if (path && !r.converged()) {
        // The path step stopped at negative curvature (or the warm start
        // failed): a mechanism's answer is the full load from rest, wherever
        // its rigid motion leads.
        charts = rest.charts;
        uTry = rest.u;
        r = solveAt(1.0, uTry, opt.tolerance, opt);
        merge(r);
        for (int resume = 0;
             !r.converged() && r.outcome == Outcome::MaxIterations && r.progressing && resume < opt.maxLoadHalvings;
             ++resume) {
          r = solveAt(1.0, uTry, opt.tolerance, opt);
          merge(r);
          total.resumes++;
        }
        // Loads far below the structure's stiffness move it along its
        // mechanism in Newton steps that shrink with the load (straight
        // steps along a rigid swing stretch the rods to second order), so
        // that the swing is not completed within the iterations. Its answer
        // does not depend on how large the loads are, beyond the elastic
        // part: with no held vertex moving (the load factor then only
        // scales gravity, forces and moments), the loads times 100, 1e4 or
        // 1e6 from rest, the first that converges, then brought back to
        // the given loads in steps of a tenth (each Newton from the last
        // equilibrium, a step halved in the logarithm where one fails).
        for (double scaleUp = 100.0; !heldMove && !r.converged() && r.outcome != Outcome::TimeLimit &&
                                     r.outcome != Outcome::NumericalFailure && scaleUp <= 1e6;
             scaleUp *= 100.0) {
          charts = rest.charts;
          Eigen::VectorXd uUp = rest.u;
          NewtonReport up = solveAt(scaleUp, uUp, stepTol, opt);
          merge(up);
          if (!up.converged()) continue;
          Eigen::VectorXd uDown = uUp;
          PoseSystem::Charts chartsDown = charts;
          double at = scaleUp, ratio = 10.0;
          NewtonReport down = up;
          while (at > 1.0 && ratio > 1.01) {
            const double next = std::max(1.0, at / ratio);
            Eigen::VectorXd uNext = uDown;
            charts = chartsDown;
            NewtonReport rs = solveAt(next, uNext, next > 1.0 ? stepTol : opt.tolerance, opt);
            merge(rs);
            if (rs.outcome == Outcome::TimeLimit || rs.outcome == Outcome::NumericalFailure) {
              down = rs;
              break;
            }
            if (!rs.converged()) {
              ratio = std::sqrt(ratio);
              continue;
            }
            down = rs;
            uDown = std::move(uNext);
            chartsDown = charts;
            at = next;
          }
          if (at == 1.0 && down.converged()) {
            uTry = std::move(uDown);
            charts = chartsDown;
            r = down;
            total.mechanismScale = scaleUp;
          } else if (down.outcome == Outcome::TimeLimit || down.outcome == Outcome::NumericalFailure) {
            r = down;
          }
        }
      }
      if (path && r.converged()) {
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
      Eigen::VectorXd prediction;
      if (path && !afterJump && lastKept.size() == uCur.size()) {
        prediction = ((next - lam) / lastKeptLength) * lastKept;
        uTry += prediction;
      }
      NewtonReport rs = solveAt(next, uTry, next < 1.0 ? stepTol : opt.tolerance, stepOpt,
                                prediction.size() > 0 ? nullptr : &tangent, path);
      merge(rs);
      // A step that ran out of iterations while still descending, without
      // meeting negative curvature, is resumed: a long descent along a soft
      // mode (a design nearly a mechanism at rest) needs the same motion at
      // any load, and shorter steps do not shorten it.
      for (int resume = 0; path && !rs.converged() && rs.outcome == Outcome::MaxIterations && rs.progressing &&
                           rs.negativeIterations == 0 && rs.escapes == 0 && resume < opt.maxLoadHalvings;
           ++resume) {
        rs = solveAt(next, uTry, next < 1.0 ? stepTol : opt.tolerance, stepOpt, nullptr, path);
        merge(rs);
        total.resumes++;
      }
      r = rs;
      if (prediction.size() == 0) prediction = tangent;
      const double deviation = path ? pathDeviation(rs, uCur, uTry, prediction) : (rs.converged() ? 0.0 : -1.0);
      if (deviation >= 0.0) {
        ++pathSteps;
        lastKept = uTry - uCur;
        // Twists are angles in their edges' charts: their change along the
        // step predicts the next one unless a chart was re-anchored.
        if (!sameCharts(charts, chartsCur)) lastKept.tail(lastKept.size() - nv).setZero();
        lastKeptLength = next - lam;
        afterJump = false;
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
             !rj.converged() && rj.outcome == Outcome::MaxIterations && rj.progressing && resume < opt.maxLoadHalvings;
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
        if (rj.converged()) {
          const Stability there = stability(system, design, PoseState{uCur, chartsCur, lam, state.internal});
          const bool soft = there.ok && unloaded.ok && unloaded.smallestEigenvalue > 0 &&
                            there.smallestEigenvalue <= kCriticalStiffnessRatio * unloaded.smallestEigenvalue;
          // Negative curvature met beyond lam marks a critical point unless
          // the state beyond is where the path was heading: within
          // pathDeviation of the last kept step's displacement scaled to
          // this one, or no farther than that displacement (a path whose
          // every longer step starts at negative curvature without passing
          // one, e.g. a rod whose end is carried round while it is
          // compressed, is not a string of jumps; nor is a step shorter than
          // the path's own pace).
          bool heading = false;
          if (lastKept.size() == uCur.size()) {
            const Eigen::VectorXd expected = ((beyond - lam) / lastKeptLength) * lastKept;
            const double along = maxVertexStep(system, expected);
            heading = along > 0 && (maxVertexStep(system, uTry - uCur - expected) <= opt.pathDeviation * along ||
                                    maxVertexStep(system, uTry - uCur) <= along);
          }
          // Nor is the first step from a stable start: a positive definite
          // stiffness there keeps the equilibrium under small enough loads;
          // the negative curvature met by longer steps is that of their
          // starting states (the held vertices moved, the free ones not).
          if (lam == startLam && there.ok && there.smallestEigenvalue > 0) heading = true;
          const bool critical = soft || (negativeBeyond && !heading);
          if (critical) {
            CriticalPoint cp;
            cp.loadFactor = lam;
            cp.smallestEigenvalue = there.smallestEigenvalue;
            cp.jump = maxVertexStep(system, uTry - uCur);
            total.criticalPoints.push_back(cp);
          }
          ++pathSteps;
          // No secant across a jump; a smallest step that passed no critical
          // point is as good a secant as any.
          lastKept = uTry - uCur;
          if (!sameCharts(charts, chartsCur)) lastKept.tail(lastKept.size() - nv).setZero();
          lastKeptLength = beyond - lam;
          afterJump = critical;
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
      r.outcome = Outcome::Converged;
      if (path && pathSteps > 0) {
        std::ostringstream os;
        os << r.message << "; loading path followed in " << pathSteps << " load steps";
        for (const CriticalPoint& cp : total.criticalPoints)
          os << "; passed a critical point at load factor " << formatNumber("%.4g", cp.loadFactor)
             << " (smallest stiffness eigenvalue " << formatNumber("%.3g", cp.smallestEigenvalue)
             << " N/m): the structure left its branch there and jumped by " << formatNumber("%.3g", cp.jump)
             << " m to the equilibrium beyond (snap-through or buckling)";
        r.message = os.str();
      }
    }
    if (timedOut) {
      r.outcome = Outcome::TimeLimit;
      r.message = "time limit reached at load factor " + formatNumber("%.6g", lam) + "; the returned state is the " +
                  (lam > 0 ? "equilibrium at load factor " + formatNumber("%.6g", lam) + ", not at the full load"
                           : std::string("rest state"));
    } else if (failed) {
      const std::string last = r.message;
      const Outcome lastOutcome = r.outcome;
      std::ostringstream os;
      const std::string returned = lam > 0 ? "the returned state is the equilibrium at load factor " +
                                                 formatNumber("%.6g", lam) + ", not at the full load"
                                           : std::string("the returned state is the rest state (load factor 0)");
      if (lastOutcome == Outcome::NumericalFailure && lam == 0.0) {
        // Even the smallest load step cannot be represented.
        r.outcome = Outcome::NumericalFailure;
        os << "failed at every load step down to " << minStep << " of the full load (" << last << "); " << returned;
      } else {
        const Stability here =
            lam == 0.0 ? unloaded : stability(system, design, PoseState{uCur, chartsCur, lam, state.internal});
        total.smallestEigenvalue = here.smallestEigenvalue;
        const bool lost = negativeBeyond || (here.ok && unloaded.ok && unloaded.smallestEigenvalue > 0 &&
                                             here.smallestEigenvalue <= kCriticalStiffnessRatio * unloaded.smallestEigenvalue);
        r.outcome = Outcome::Stalled;
        if (unloaded.zeroMode()) {
          os << "the unloaded structure has a mode without stiffness that double precision resolves (smallest "
                "eigenvalue "
             << formatNumber("%.3g", unloaded.smallestEigenvalue) << " N/m, at the round-off of stiffnesses up to "
             << formatNumber("%.3g", unloaded.largestDiagonal)
             << " N/m): either a mechanism, which the loads must carry through a large rigid motion that Newton did "
                "not complete (vertices held by 'fixed' along one straight line act as a hinge: clamp one, or hold "
                "one off that line; an unsupported part moves freely), or a discretization too fine for double "
                "precision (the bending stiffness of a rod of N edges spans ~N^4); "
             << returned << " (last attempt: " << last << ")";
        } else if (lost) {
          os << "the equilibrium path was lost at load factor " << formatNumber("%.6g", lam)
             << ": no equilibrium was found within a load step of " << minStep
             << " beyond it (a limit or bifurcation point; smallest stiffness eigenvalue there "
             << formatNumber("%.4g", here.smallestEigenvalue) << " N/m, unloaded "
             << formatNumber("%.4g", unloaded.smallestEigenvalue) << " N/m"
             << (negativeBeyond ? "; negative curvature beyond it" : "") << "); " << returned
             << " (last attempt: " << last << ")";
        } else {
          os << "did not reach the full load: the load step fell below " << minStep << " at load factor "
             << formatNumber("%.6g", lam) << " (smallest stiffness eigenvalue there "
             << formatNumber("%.4g", here.smallestEigenvalue) << " N/m); " << returned << " (last attempt: " << last << ")";
        }
      }
      r.message = os.str();
    }
  }
  // The final verdict is judged at the full load, whatever the last step said.
  Eigen::VectorXd g;
  const double e = system.evaluate(PoseState{u, charts, 1.0, state.internal}, design, &g, nullptr);
  total.residualNorm = system.forceResidual(g).stableNorm();
  total.relativeResidual = total.residualNorm / scale;
  total.energy = e;
  if (!std::isfinite(total.residualNorm) || !std::isfinite(e)) {
    r.outcome = Outcome::NumericalFailure;
    r.message = "the final state has non-finite energy or forces (" + r.message + ")";
  } else if (r.converged() && !r.roundoff &&
             !(total.residualNorm <= std::max(1e3 * opt.tolerance, std::sqrt(opt.tolerance)) * scale ||
               total.residualNorm <= r.roundoffFloor)) {
    r.outcome = Outcome::Stalled;
    r.message = "the final state does not satisfy equilibrium at the full load (" + r.message + ")";
  }
  total.outcome = r.outcome;
  total.usable = reached >= 1.0 && std::isfinite(total.residualNorm) && std::isfinite(e) && u.allFinite() &&
                 r.outcome != Outcome::NumericalFailure && r.outcome != Outcome::InvalidProblem;
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
