#include "solver/reduced_hessian.hh"

#include "solver/parallel.hh"

#include <cmath>

namespace rodmesh {

ReducedHessian::ReducedHessian(const SceneModel& model, const DesignSpace& space, const TargetObjective& objective,
                               const DesignPhase& phase, int threads)
    : model_(model),
      space_(space),
      objective_(objective),
      phase_(phase),
      threads_(threads),
      J_(space.jacobian(phase)),
      poses_(model.numPoses()) {
  const EffectSet& fx = model.effects();
  planeProjection_ = fx.planar ? Eigen::Matrix3d(fx.planeBasis * fx.planeBasis.transpose())
                               : Eigen::Matrix3d::Identity();
}

bool ReducedHessian::prepare(const Eigen::VectorXd& z, const ControlValues& base,
                             const std::vector<PoseState>& states) {
  const Design d = space_.toDesign(space_.unpack(phase_, z, base));
  const int n = model_.numPoses();
  std::vector<double> fk(n, 0.0);
  std::vector<Eigen::VectorXd> gk(n);
  std::vector<char> ok(n, 1);
  forEachPose(n, threads_, [&](int k) {
    try {
      const PoseSystem& sys = model_.pose(k);
      PoseData& pd = poses_[k];
      const PoseState& state = states[k];
      pd.dofs = sys.numDofs();
      Eigen::VectorXd dfdu = Eigen::VectorXd::Zero(pd.dofs);
      gk[k] = Eigen::VectorXd::Zero(d.numParameters());
      fk[k] = objective_.pose(sys, state, d, &dfdu, &gk[k]);
      const double w = objective_.weight(k);
      pd.fuu = Eigen::VectorXd::Zero(pd.dofs);
      pd.held.clear();
      const std::vector<int>& vdof = sys.vertexDof();
      for (int v = 0; v < static_cast<int>(vdof.size()); ++v) {
        if (vdof[v] >= 0) {
          pd.fuu.segment(vdof[v], sys.dofsPerVertex()).setConstant(w);
        } else {
          const double c = sys.heldDesignCoefficient(v, state.loadFactor);
          if (c != 0.0) pd.held.emplace_back(v, w * c * c);
        }
      }
      if (pd.dofs == 0) return;
      sys.evaluateJoint(state, d, pd.joint);
      if (!pd.ldlt) pd.ldlt = std::make_unique<Ldlt>();
      pd.ldlt->compute(pd.joint.Huu);
      if (pd.ldlt->info() != Eigen::Success) {
        ok[k] = 0;
        return;
      }
      const Eigen::VectorXd lambda = pd.ldlt->solve(dfdu);
      if (!lambda.allFinite()) {
        ok[k] = 0;
        return;
      }
      gk[k] -= pd.joint.Hup.transpose() * lambda;
      sys.evaluateJoint(state, d, pd.contracted, &lambda);
    } catch (...) {
      ok[k] = 0;
    }
  });
  f_ = 0.0;
  Eigen::VectorXd total = Eigen::VectorXd::Zero(d.numParameters());
  for (int k = 0; k < n; ++k) {
    if (!ok[k]) return false;
    f_ += fk[k];
    total += gk[k];
  }
  g_ = J_.transpose() * total;
  return std::isfinite(f_) && g_.allFinite();
}

Eigen::VectorXd ReducedHessian::apply(const Eigen::VectorXd& v, bool gaussNewton) const {
  const Eigen::VectorXd dp = J_ * v;
  const int n = static_cast<int>(poses_.size());
  std::vector<Eigen::VectorXd> out(n);
  forEachPose(n, threads_, [&](int k) {
    const PoseData& pd = poses_[k];
    // d2f/dp2 dp: held vertices follow their rest positions.
    Eigen::VectorXd wp = Eigen::VectorXd::Zero(dp.size());
    for (const auto& [vtx, wc2] : pd.held) {
      const int i = Design::restIndex(vtx, 0);
      wp.segment<3>(i) = wc2 * (planeProjection_ * dp.segment<3>(i));
    }
    if (pd.dofs > 0) {
      const Eigen::VectorXd du = -pd.ldlt->solve(pd.joint.Hup * dp);
      Eigen::VectorXd wu = pd.fuu.cwiseProduct(du);
      if (!gaussNewton) {
        const JointDerivatives& T = pd.contracted;
        wu -= T.Huu * du + T.Hup * dp;
        wp -= T.Hup.transpose() * du;
        wp -= T.Hpp.selfadjointView<Eigen::Lower>() * dp;
      }
      const Eigen::VectorXd dlambda = pd.ldlt->solve(wu);
      wp -= pd.joint.Hup.transpose() * dlambda;
    }
    out[k] = std::move(wp);
  });
  Eigen::VectorXd total = Eigen::VectorXd::Zero(dp.size());
  for (const Eigen::VectorXd& o : out) total += o;
  return J_.transpose() * total;
}

std::vector<Eigen::VectorXd> ReducedHessian::equilibriumChange(const Eigen::VectorXd& v) const {
  const Eigen::VectorXd dp = J_ * v;
  const int n = static_cast<int>(poses_.size());
  std::vector<Eigen::VectorXd> du(n);
  forEachPose(n, threads_, [&](int k) {
    const PoseData& pd = poses_[k];
    du[k] = pd.dofs > 0 ? Eigen::VectorXd(-pd.ldlt->solve(pd.joint.Hup * dp)) : Eigen::VectorXd();
  });
  return du;
}

}  // namespace rodmesh
