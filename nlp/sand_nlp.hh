// SandNlp: the simultaneous analysis-and-design problem of one schedule phase
// as a sparse nonlinear program, without any Ipopt type (the Ipopt adapter is
// nlp/sand_tnlp.cc; tests call this class directly).
//
// Variables x = [u_0 | u_1 | ... | u_{K-1} | y]: the unknowns of every pose
// (model/pose_system.hh: free vertex positions, then edge twists) and the
// phase's free design values z (model/design_space.hh) scaled as y = z / s,
// s = SandScaling::variable (radii by their bound range, displacements by a
// tenth of the mean rod length), so that every variable is O(1)..O(0.1).
// The design is affine in y: p = p0 + J diag(s) y (Design::toVector layout).
//
// Constraints, one block per pose k:  c_k = R_k F_k(u_k, p) / L_k = 0, with
// F_k = dE_k/du_k, R_k = 1 on position rows and 1 / momentArm on twist rows
// (the residual in newtons, as the static solver measures it) and L_k the
// pose's force scale (N, sandLoadScales below: the applied loads, or with
// held vertices prescribed away from rest the loads and their reactions): a
// constraint value of 1e-8 is a residual of 1e-8 of the pose's load.
//
// Objective f(x) / f_s, f the contract's 1/2 sum w |q - target|^2 and f_s the
// objective of the initial design (SandScaling::objective), so that Ipopt's
// tolerances are relative to where the optimization started.
//
// Derivatives are exact: the constraint Jacobian is [R Huu / L | R Hup J diag(s) / L]
// per pose, from PoseSystem::evaluateJoint; the Hessian of the Lagrangian
//   sigma/f_s Hess f + sum_k sum_i lambda_ki Hess c_ki
// uses PoseSystem::evaluateJoint with the direction v_k = R_k lambda_k / L_k
// (third derivatives of E_k contracted with v_k, over (u_k, p) jointly),
// mapped to y by the constant design Jacobian. Structures are fixed at
// construction; evaluations write values only.
#pragma once

#include "model/design_space.hh"
#include "model/pose_system.hh"
#include "solver/design_optimizer.hh"
#include "solver/equilibrium.hh"

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <vector>

namespace rodmesh {

struct SandScaling {
  double objective = 1.0;         // f_s
  std::vector<double> load;       // L_k per pose (N)
  Eigen::VectorXd variable;       // s per free design value of the phase
};

// L_k of every pose (N): the size of the forces that hold the initial
// design's equilibrium `states` (full load) together, so that a constraint
// value of 1e-8 means a residual of 1e-8 of what the pose's equilibrium
// balances.
//  - A pose whose held vertices stay at their rest positions: the applied
//    loads (point forces, gravity, twisting moments), the residual of the
//    rest state (loadScale, solver/newton.hh).
//  - A pose with held vertices prescribed away from their rest positions:
//    the applied loads and the reactions of those vertices at the
//    equilibrium, together (2-norm). The rest state's residual is no force of
//    the equilibrium there: it is the force that moves the held vertices with
//    everything else at rest, i.e. the axial stiffness of their edges times
//    the prescribed displacement, thousands of times the forces of the
//    equilibrium on a sheet whose handle is lifted by a few centimetres. With
//    it the constraints' tolerances, Ipopt's filter and the divergence test
//    would accept residuals of the order of the equilibrium's own forces.
//  - A pose with neither (its equilibrium is the rest state under every rest
//    shape; its residual is round-off): the largest scale of the other poses,
//    or, if no pose has loads, the force that bends a rod of the mean edge
//    length by one radian over its length (E I / l^2). Scaling such a pose by
//    its round-off residual would make every constraint value of the pose
//    about 1e15 times its force.
// States must carry the charts they were solved in; the model's term filter
// is left at All.
std::vector<double> sandLoadScales(const SceneModel& model, const Design& design, const std::vector<PoseState>& states);

class SandNlp {
 public:
  // states: one per pose, at load factor 1; their charts are installed and
  // stay fixed while this problem lives (a change of charts is a change of
  // variables). `base` holds the design values the phase does not free.
  SandNlp(const SceneModel& model, const DesignSpace& space, const TargetObjective& objective, const DesignPhase& phase,
          const ControlValues& base, const std::vector<PoseState>& states, SandScaling scaling, int threads);

  int numVariables() const { return n_; }
  int numConstraints() const { return m_; }
  int numPoses() const { return K_; }
  int poseOffset(int k) const { return offset_[k]; }  // first variable (and constraint) of pose k
  int designOffset() const { return zOffset_; }
  int jacobianNonZeros() const { return static_cast<int>(jacRow_.size()); }
  int hessianNonZeros() const { return static_cast<int>(hessRow_.size()); }

  void bounds(double* xLower, double* xUpper) const;
  Eigen::VectorXd startingPoint() const { return x0_; }
  // Row and column of every Jacobian / lower-triangle Hessian value slot.
  const std::vector<int>& jacobianRows() const { return jacRow_; }
  const std::vector<int>& jacobianCols() const { return jacCol_; }
  const std::vector<int>& hessianRows() const { return hessRow_; }
  const std::vector<int>& hessianCols() const { return hessCol_; }

  // Evaluations; false when a value is not finite or the model throws (no
  // exception leaves these functions).
  bool objective(const double* x, double& f);
  bool gradient(const double* x, double* g);
  bool constraints(const double* x, double* c);
  bool jacobian(const double* x, double* values);
  bool hessian(const double* x, double sigma, const double* lambda, double* values);

  // The design and the pose states at x (charts: the problem's).
  ControlValues controls(const double* x) const;
  Design design(const double* x) const;
  std::vector<PoseState> states(const double* x) const;
  // At x: contract RMS (m) of the positions, and the largest equilibrium
  // residual component in newtons over all poses.
  double rms(const double* x);
  double forceViolation(const double* x);

  double evaluationSeconds() const { return evalSeconds_; }
  int evaluations() const { return evaluations_; }

 private:
  bool prepare(const double* x);    // unpack x into u_k and the design
  bool ensureJoint();               // joint derivatives at the prepared x
  // dE_k/du_k at the prepared x (from the joint derivatives when ready); may throw.
  void poseGradient(int k, Eigen::VectorXd& grad);
  template <class Fn>
  bool guarded(Fn&& fn);            // timing + catch

  const SceneModel& model_;
  const DesignSpace& space_;
  const TargetObjective& objective_;
  DesignPhase phase_;
  ControlValues base_;
  SandScaling scale_;
  int threads_;
  int K_ = 0, n_ = 0, m_ = 0, nz_ = 0, zOffset_ = 0;
  std::vector<int> offset_;
  std::vector<Eigen::VectorXd> rowScale_;         // R_k / L_k per pose
  Eigen::SparseMatrix<double> Jy_;                // dp/dy (5V x nz)
  Eigen::SparseMatrix<double> JyT_;
  Eigen::VectorXd x0_;

  // Jacobian: per pose the Huu values (slot = jacHuuBase_[k] + entry) and
  // the product Hup Jy (slot = jacHupBase_[k] + entry of the product).
  std::vector<int> jacRow_, jacCol_;
  std::vector<int> jacHuuBase_, jacHupBase_;
  std::vector<std::vector<int>> huuRow_;          // row of every Huu entry per pose
  std::vector<Eigen::SparseMatrix<double>> hupJPattern_;

  // Hessian (lower): per pose its Huu lower entries and the diagonal entries
  // of vertex unknowns (objective); the (z, u_k) block from (Hup_dir Jy)^T;
  // the (z, z) block from Jy^T A Jy, A = sum_k Hpp_dir_k + sigma Wp (full).
  std::vector<int> hessRow_, hessCol_;
  std::vector<std::vector<int>> hessHuuSlot_;     // per pose, per Huu entry: slot or -1
  std::vector<std::vector<int>> hessDiagSlot_;    // per pose, per vertex unknown: slot of its diagonal
  std::vector<int> hessHupBase_;                  // per pose
  Eigen::SparseMatrix<double> Apattern_;          // lower, union of Hpp patterns and Wp
  std::vector<std::vector<int>> hppToA_;          // per pose: Hpp entry -> A entry
  Eigen::VectorXd wpValues_;                      // Wp in A's entries (sigma = 1 / f_s already applied: no)
  Eigen::SparseMatrix<double> zzPattern_;         // Jy^T A_full Jy structure
  std::vector<int> zzSlot_;                       // per entry of zzPattern_: slot or -1 (upper)

  // Evaluation cache.
  Eigen::VectorXd x_;
  bool prepared_ = false, jointReady_ = false;
  Design design_;
  // Per pose: the unknowns of x_, the charts the NLP was built with, load
  // factor 1.
  std::vector<PoseState> state_;
  std::vector<JointDerivatives> joint_, dir_;
  double evalSeconds_ = 0.0;
  int evaluations_ = 0;
};

}  // namespace rodmesh
