#include "solver/relaxation.hh"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "solver/newton.hh"

namespace rodmesh {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Fictitious masses from the Gershgorin row sums of the (lower-triangular)
// Hessian; a row without stiffness gets a small floor.
void gershgorinMasses(const Eigen::SparseMatrix<double>& H, double safety, Eigen::VectorXd& m) {
  const int n = static_cast<int>(H.rows());
  m.setZero(n);
  for (int c = 0; c < n; ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(H, c); it; ++it) {
      const double a = std::abs(it.value());
      m[it.row()] += a;
      if (it.row() != c) m[c] += a;
    }
  const double mean = n > 0 ? m.sum() / n : 1.0;
  const double floor = std::max(1e-8 * mean, 1e-300);
  for (int i = 0; i < n; ++i) m[i] = safety * std::max(m[i], floor);
}

}  // namespace

std::string RelaxationOptions::isValid() const {
  if (maxIterations < 1) return "maxIterations must be at least 1";
  if (!(tolerance > 0 && tolerance < 1)) return "tolerance must lie in (0, 1)";
  if (!(timeLimit >= 0)) return "time limit must be non-negative";
  if (!(massSafety > 0.25)) return "massSafety must exceed 1/4 (explicit stability)";
  if (!(minStep > 0 && initialStep >= minStep && maxStep >= initialStep))
    return "need 0 < minStep <= initialStep <= maxStep";
  if (!(stepGrowth >= 1)) return "stepGrowth must be at least 1";
  if (massUpdateInterval < 1) return "massUpdateInterval must be at least 1";
  if (historyStride < 1) return "historyStride must be at least 1";
  return "";
}

RelaxationReport relaxEquilibrium(const PoseSystem& sys, const Design& design, Eigen::VectorXd& uInOut,
                                  const RelaxationOptions& opt, Charts* chartsOut) {
  const auto t0 = Clock::now();
  RelaxationReport rep;
  // The full load, twists measured from the design's rest frames.
  PoseState state{uInOut, sys.restCharts(design), 1.0, {}};
  Eigen::VectorXd& u = state.u;
  Eigen::SparseMatrix<double> H;  // the Hessian last evaluated (for the masses)
  const double scale = loadScale(sys, design);
  const double floorForce = sys.roundoffForce(design);
  rep.loadScale = scale;
  const int n = sys.numDofs();

  Eigen::VectorXd g(n), m(n), v = Eigen::VectorXd::Zero(n);
  double E = 0.0;
  E = sys.evaluate(state, design, &g, n > 0 ? &H : nullptr);
  if (n > 0) {
    gershgorinMasses(H, opt.massSafety, m);
    rep.massUpdates = 1;
  }
  double res = sys.forceResidual(g).norm();
  auto record = [&](bool force) {
    if (!force && rep.iterations % opt.historyStride != 0) return;
    if (!rep.historyIteration.empty() && rep.historyIteration.back() == rep.iterations) return;
    rep.residualHistory.push_back(scale > 0 ? res / scale : res);
    rep.historyIteration.push_back(rep.iterations);
    rep.historySeconds.push_back(since(t0));
  };

  double h = opt.initialStep;
  bool fromRest = true;
  double kePrev = 0.0, keMax = 0.0, E0 = E;
  Eigen::VectorXd uStart = u, mOld;
  Charts chartsStart = state.charts;
  int lastMassUpdate = 0;
  auto kinetic = [&]() { return 0.5 * (m.array() * v.array().square()).sum(); };
  // New fictitious masses from the Hessian just evaluated; the velocities
  // keep their momentum m v.
  auto refreshMasses = [&]() {
    mOld = m;
    gershgorinMasses(H, opt.massSafety, m);
    v.array() *= mOld.array() / m.array();
    rep.massUpdates++;
    lastMassUpdate = rep.iterations;
  };
  // Stops the motion at u: the start of a new cycle.
  auto restartHere = [&]() {
    v.setZero();
    kePrev = keMax = 0.0;
    fromRest = true;
    E0 = E;
    uStart = u;
    chartsStart = state.charts;
  };

  double nextProgress = opt.progressInterval;
  for (;;) {
    record(false);
    if (!std::isfinite(E) || !g.allFinite()) {
      rep.outcome = Outcome::NumericalFailure;
      rep.message = "energy or forces are not finite";
      break;
    }
    if (n == 0 || res <= opt.tolerance * scale || res <= floorForce) {
      rep.outcome = Outcome::Converged;
      rep.message = n == 0                ? "no unknowns"
                    : scale <= floorForce ? "no load: rest configuration"
                                          : "force residual below tolerance";
      break;
    }
    if (rep.iterations >= opt.maxIterations) {
      rep.outcome = Outcome::MaxIterations;
      rep.message = "iteration limit reached";
      break;
    }
    if (opt.timeLimit > 0 && since(t0) > opt.timeLimit) {
      rep.outcome = Outcome::TimeLimit;
      rep.message = "time limit reached";
      break;
    }
    // A progress report every progressInterval seconds: a relaxation can
    // take minutes, and a silent one looks hung.
    if (opt.progress && since(t0) >= nextProgress) {
      nextProgress = since(t0) + opt.progressInterval;
      rep.residualNorm = res;
      rep.relativeResidual = scale > 0 ? res / scale : res;
      rep.timeSeconds = since(t0);
      rep.finalStep = h;
      opt.progress(rep);
    }

    // Leapfrog velocity update (half a step from rest).
    if (fromRest)
      v = (0.5 * h) * (-g).cwiseQuotient(m);
    else
      v += h * (-g).cwiseQuotient(m);
    const double ke = kinetic();

    if (!fromRest && ke < kePrev) {
      // Kinetic-energy peak at the current u: stop, restart from rest with a
      // slightly longer step.
      rep.restarts++;
      h = std::min(h * opt.stepGrowth, opt.maxStep);
      std::optional<PoseState> reanchored = sys.reanchored(state, design);
      const bool moved = reanchored.has_value();
      if (moved) {
        rep.chartUpdates++;
        state.charts = std::move(reanchored->charts);
      }
      const bool refresh = rep.iterations - lastMassUpdate >= opt.massUpdateInterval;
      if (moved || refresh) {
        E = sys.evaluate(state, design, &g, refresh ? &H : nullptr);
        res = sys.forceResidual(g).norm();
        if (refresh) refreshMasses();
      }
      restartHere();
      continue;
    }
    fromRest = false;

    u += h * v;
    const bool refresh = rep.iterations + 1 - lastMassUpdate >= opt.massUpdateInterval;
    E = sys.evaluate(state, design, &g, refresh ? &H : nullptr);
    res = sys.forceResidual(g).norm();
    rep.iterations++;
    if (refresh && std::isfinite(E) && g.allFinite()) refreshMasses();
    kePrev = kinetic();
    keMax = std::max(keMax, kePrev);

    if (!std::isfinite(E) || !g.allFinite()) {
      // Blown up: back to the start of the cycle with half the step.
      rep.instabilities++;
      h *= 0.5;
      u = uStart;
      state.charts = chartsStart;
      E = sys.evaluate(state, design, &g, &H);
      res = sys.forceResidual(g).norm();
      v.setZero();
      refreshMasses();
      restartHere();
    } else if (E - E0 > 0.5 * keMax + 1e-12 * std::max(std::abs(E0), std::abs(E))) {
      // The potential energy rose above the cycle's start: a mode is
      // growing (explicit step too long). Stop here with half the step.
      rep.instabilities++;
      h *= 0.5;
      E = sys.evaluate(state, design, &g, &H);
      v.setZero();
      refreshMasses();
      restartHere();
    }
    if (h < opt.minStep) {
      std::ostringstream os;
      os << "pseudo-time step fell below " << opt.minStep << " (unstable cycles)";
      rep.outcome = Outcome::Stalled;
      rep.message = os.str();
      break;
    }
  }
  record(true);
  rep.finalStep = h;
  rep.residualNorm = res;
  rep.relativeResidual = scale > 0 ? res / scale : res;
  rep.energy = E;
  rep.usable = rep.outcome != Outcome::NumericalFailure && std::isfinite(E) && u.allFinite();
  rep.timeSeconds = since(t0);
  uInOut = u;
  if (chartsOut) *chartsOut = std::move(state.charts);
  return rep;
}

}  // namespace rodmesh
