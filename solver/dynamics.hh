// Dynamics of one pose: backward Euler with Newton's method and adaptive time
// steps (the paper's dynamic simulation, §5 "Simulation Performance", after
// Bergou et al. 2010).
//
// Unknowns u are those of PoseSystem (free vertex positions [m], then one
// twist angle per edge [rad]); velocities v have the same layout [m/s], and
// their twist entries are always zero: the material frames are massless and
// follow the centreline quasi-statically (Bergou 2010, §4.1).
//
// One step of size h from (u_n, v_n) minimises the incremental potential
//   Phi(u) = 1/(2 h^2) (u - u_pred)^T M (u - u_pred) + E(u),  u_pred = u_n + h v_n,
// with M the lumped mass on the position unknowns (solver/mass.hh) and zero on
// the twists; then v_{n+1} = (u_{n+1} - u_n) / h on the positions. grad Phi = 0
// is exactly backward Euler: M (v_{n+1} - v_n) / h = -grad E(u_{n+1}). For a
// convex energy the total energy (kinetic + potential) never increases.
// Phi is minimised by the same Newton code as the static solve
// (solver/minimizer.hh, with the inertia term, the tolerance relative to the
// step's own force imbalance and fixed charts within the step).
//
// Held (fixed, clamped) vertices are not unknowns: they sit at their
// prescribed positions, reached at time loadRampTime if that is positive (the
// loads ramp with them), at once otherwise.
//
// Adaptive steps: a step is rejected and retried at half the size when Newton
// does not converge within maxNewtonIterations, when it finds no descent
// direction, or when the step changes too much: a vertex moves more than
// maxDisplacement mean edge lengths away from the prediction u_n + h v_n (the
// local error of backward Euler is half that deviation) or a twist angle
// changes by more than maxTwistChange (unless the change did not shrink when
// the step was cut for it: the quasi-static response of the massless twists
// to a sudden load, see advanceTo). After an easy step (at most
// easyIterations Newton iterations and well inside those limits) the step
// grows by growFactor, up to maxStep. Below minStep the integrator stops,
// keeps the last accepted state (never NaN) and says why.
//
// Every loop is bounded: Newton by maxNewtonIterations per step, the line
// search by maxBacktracks, the steps of a run by maxSteps (accepted and
// rejected together) and optionally by timeLimit seconds of wall-clock time;
// the integrator stops with a message when a bound is reached.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <functional>
#include <string>
#include <vector>

#include "model/outcome.hh"
#include "model/pose_system.hh"
#include "solver/minimizer.hh"

namespace rodmesh {

struct DynamicsOptions {
  double initialStep = 1e-3;      // s, first step tried
  double maxStep = 1e-2;          // s, largest step
  double minStep = 1e-9;          // s, the integrator gives up below this step
  double growFactor = 1.5;        // step growth after an easy step
  double shrinkFactor = 0.5;      // step reduction after a rejected step
  int easyIterations = 4;         // Newton iterations at or below which a step is easy
  int maxNewtonIterations = 15;   // per step; a step needing more is rejected
  double tolerance = 1e-8;        // |grad Phi| <= tolerance * |grad Phi| at the step's start (or round-off)
  double maxDisplacement = 0.25;  // per step, in mean rest edge lengths, from the prediction u_n + h v_n
  double maxTwistChange = 0.5;    // rad per step
  double loadRampTime = 0.0;      // s; loads and held displacements grow linearly to 1 over this time (0: at once)
  double armijo = 1e-4;           // sufficient-decrease constant of the line search
  int maxBacktracks = 30;         // step halvings of the line search
  long long maxSteps = 100000;    // time steps attempted (accepted + rejected) over a whole run
  double timeLimit = 0.0;         // s of wall-clock time over a whole run; 0: none
  std::string isValid() const;    // empty if valid, else what is wrong
};

// The checks of a whole run (empty if valid, else what is wrong, with the
// allowed range): the options, a finite positive duration, a positive frame
// rate, at most maxFrames frames, and a largest step that can cover the
// duration within maxSteps steps (maxStep >= duration / maxSteps).
std::string checkDynamicRun(const DynamicsOptions& options, double duration, double fps, double maxFrames);

// A dynamic run: the summary every solve reports (model/outcome.hh;
// iterations are Newton iterations over all steps, rejected ones included;
// residualNorm is |grad Phi| at the end of the last step attempted, N;
// timeSeconds is wall clock) and the integrator's own counters. The outcome
// is Converged when the run reached its end, else why it stopped early:
// NumericalFailure (a step fell below minStep), MaxIterations (maxSteps
// spent), TimeLimit. The state is always the last accepted one (usable).
struct DynamicsReport : SolveSummary {
  DynamicsReport() {
    outcome = Outcome::Converged;
    usable = true;
  }
  int steps = 0;  // accepted time steps
  int rejectedSteps = 0;
  int factorizations = 0;
  int chartUpdates = 0;       // steps after which reference-frame charts moved
  double time = 0.0;          // simulated time reached [s]
  double minStepTaken = 0.0;  // smallest and largest accepted step [s]
  double maxStepTaken = 0.0;
};

// Backward Euler integrator for one pose. It keeps its own state (unknowns,
// charts, load factor at the current time) and re-anchors the charts after
// every accepted step; the pose model is only read.
class BackwardEuler {
 public:
  // dofMass: mass per unknown (solver/mass.hh dofMasses), zero on twists.
  BackwardEuler(const PoseSystem& system, const Design& design, Eigen::VectorXd dofMass,
                const DynamicsOptions& options);

  // Starts from a state's unknowns and charts (its load factor is that of
  // time t) and velocities v (twist entries of v are ignored) at time t.
  void start(const PoseState& state, const Eigen::VectorXd& v, double t = 0.0);
  const PoseState& state() const { return state_; }
  const Eigen::VectorXd& dofs() const { return state_.u; }
  const Eigen::VectorXd& velocities() const { return v_; }
  double time() const { return t_; }
  double nextStep() const { return h_; }

  // Advances to time t (>= time()) with adaptive steps, the last one
  // shortened to land on t. Returns false if a step fell below minStep; the
  // state is then the last accepted one and report().message says why.
  bool advanceTo(double t);

  double kineticEnergy() const;    // 1/2 v^T M v [J]
  double potentialEnergy() const;  // E(u) at the current load factor [J]
  double loadFactorAt(double t) const;
  const DynamicsReport& report() const { return rep_; }

 private:
  struct Trial {
    Eigen::VectorXd u;
    int iterations = 0;
    double residual = 0.0;
    double deviation = 0.0;  // max vertex distance from the prediction, in mean edge lengths
    double twistChange = 0.0;
    std::string failure;  // empty when Newton converged
  };
  Trial solveStep(double h, double loadFactor);

  const PoseSystem& sys_;
  const Design& design_;
  Eigen::VectorXd mass_;
  DynamicsOptions opt_;
  DynamicsReport rep_;
  PoseState state_;
  Eigen::VectorXd v_;
  double t_ = 0.0, h_ = 0.0;
  double twistRejected_ =
      -1.0;  // twist change of the last step rejected for it (-1: none since the last accepted step)
  // The minimizer's buffers (Hessian, Newton matrix of the incremental
  // potential, factorization), kept from step to step.
  MinimizerWorkspace ws_;
};

// Frames of a dynamic run: positions of every vertex at each frame time.
struct DynamicFrames {
  std::vector<double> time;                  // s
  std::vector<std::vector<Vec3>> positions;  // one V-list per frame
  Eigen::VectorXd finalDofs;                 // unknowns at the last frame
  PoseState finalState;                      // the state at the last frame (unknowns, charts, load factor)
};

// Called after each stored frame (frame index, its time, the report so far).
using FrameProgress = std::function<void(int frame, double time, const DynamicsReport&)>;

// Simulates one pose from rest (zero velocity, rest charts) for `duration`
// seconds and stores a frame every 1/fps s starting at t = 0; the last frame
// is at t = duration. Vertex masses from lumpedVertexMasses. The load factor is
// left at 1 on return.
DynamicsReport simulateDynamics(const PoseSystem& system, const Design& design, const std::vector<double>& vertexMasses,
                                const DynamicsOptions& options, double duration, double fps, DynamicFrames& frames,
                                const FrameProgress& progress = {});

}  // namespace rodmesh
