// Exact second derivatives of the reduced objective (docs/optimization.md,
// "Newton-CG"): products of the reduced Hessian d2f/dz2 and of its
// Gauss-Newton part with a design direction, for the reduced-space Newton
// method (solver/trust_region.hh).
//
// Notation as in solver/design_optimizer.hh: per pose k, F_k(u_k, p) = dE_k/du_k
// = 0, H_k = dF_k/du_k, the objective f = sum_k f_k(u_k, p), p = p0 + J z
// (DesignSpace::jacobian; the map is affine). With the adjoints
// H_k lambda_k = df_k/du_k and the Lagrangian L = f - sum_k lambda_k^T F_k,
// the reduced gradient is g = J^T sum_k (df_k/dp - (dF_k/dp)^T lambda_k) and,
// for a direction v with dp = J v,
//   du_k      = -H_k^-1 (dF_k/dp) dp                 (equilibria follow the design)
//   w_u       = L_uu du_k + L_up dp,   w_p = L_pu du_k + L_pp dp
//   dlambda_k = H_k^-1 w_u                            (adjoints follow too)
//   (d2f/dz2) v = J^T sum_k (w_p - (dF_k/dp)^T dlambda_k).
// The second derivatives of lambda^T F are third derivatives of E contracted
// with lambda (PoseSystem::evaluateJoint with direction lambda); those of f
// are the pose weight on free vertex coordinates and w c^2 P on the rest
// positions of held vertices (c = PoseSystem::heldDesignCoefficient,
// P = the plane projection of a planar scene, else I).
// The Gauss-Newton product drops the terms in lambda (f is a weighted sum of
// squared distances of positions q): J_q^T W J_q v with J_q = dq/dz, always
// positive semidefinite.
//
// prepare() does the per-design work once: one factorization of H_k, one
// adjoint solve, the joint derivatives and their contraction with lambda_k;
// every product afterwards costs two solves with the factorization and sparse
// matrix-vector products per pose.
#pragma once

#include "model/design_space.hh"
#include "solver/design_optimizer.hh"
#include "solver/equilibrium.hh"

#include <Eigen/SparseCholesky>

#include <memory>
#include <vector>

namespace rodmesh {

class ReducedHessian {
 public:
  ReducedHessian(const SceneModel& model, const DesignSpace& space, const TargetObjective& objective,
                 const DesignPhase& phase, int threads);
  // At the design of free variables z over `base` with every pose's
  // equilibrium `states` (load factor 1): objective, gradient and what the
  // products need. False if an equilibrium Hessian cannot be factorized or a
  // value is not finite.
  bool prepare(const Eigen::VectorXd& z, const ControlValues& base, const std::vector<PoseState>& states);
  double value() const { return f_; }
  const Eigen::VectorXd& gradient() const { return g_; }
  // (d2f/dz2) v, exact; and the Gauss-Newton product (positive semidefinite).
  Eigen::VectorXd product(const Eigen::VectorXd& v) const { return apply(v, false); }
  Eigen::VectorXd gaussNewtonProduct(const Eigen::VectorXd& v) const { return apply(v, true); }
  // First-order change of every pose's equilibrium along v:
  // du_k = -H_k^-1 (dF_k/dp) J v (a predictor for the equilibria at z + v).
  std::vector<Eigen::VectorXd> equilibriumChange(const Eigen::VectorXd& v) const;

 private:
  using Ldlt = Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>>;
  struct PoseData {
    int dofs = 0;
    std::unique_ptr<Ldlt> ldlt;
    JointDerivatives joint;      // at (u_k, p): Huu, Hup = dF/dp
    JointDerivatives contracted; // the same blocks of lambda_k^T F_k (third derivatives of E . lambda_k)
    Eigen::VectorXd fuu;         // diagonal of d2f_k/du2
    std::vector<std::pair<int, double>> held;  // (vertex, w c^2) of held vertices
  };
  Eigen::VectorXd apply(const Eigen::VectorXd& v, bool gaussNewton) const;

  const SceneModel& model_;
  const DesignSpace& space_;
  const TargetObjective& objective_;
  DesignPhase phase_;
  int threads_;
  Eigen::SparseMatrix<double> J_;
  Eigen::Matrix3d planeProjection_;
  std::vector<PoseData> poses_;
  double f_ = 0.0;
  Eigen::VectorXd g_;
};

}  // namespace rodmesh
