// Internal to model/pose_system*.cc: the definitions of PoseSystem's
// per-layout evaluation templates, the ones that instantiate the AD kernels:
// simulation (runSim), joint derivatives (runJoint, values and directional)
// and the first-order design product (runProduct). Each is explicitly
// instantiated once per unknowns layout and scalar, in translation units of
// one evaluation each (pose_system_sim.cc, pose_system_joint_values.cc,
// pose_system_product.cc; the directional derivatives, the largest, one per
// dimension: pose_system_joint_directional{3,2}.cc), so that the heavy
// instantiations compile once and in parallel; the callers (pose_system.cc,
// pose_system_joint.cc) see only the declarations. Splitting further, one
// translation unit per dimension for all four, cost 1.5 times the compile
// CPU time (docs/testing.md).
#pragma once

#include "model/pose_system_detail.hh"

#include <algorithm>

namespace rodmesh {

using namespace detail;

// Terms linear in the unknowns (loads) add to the gradient only: no Hessian
// is formed for them.
template <int D, bool TW, class Out>
void PoseSystem::runSim(const PoseState& s, const Design& d, Terms terms, Out& out) const {
  const std::vector<Vec3> x = positions(s, d);
  const Eigen::VectorXd theta = twists(s.u);
  BuildCtx ctx = context(x, theta, d, nullptr, s.charts, s.loadFactor, terms);
  ctx.internal = internalOf(s);
  double* hv = out.hessian ? out.hessian->valuePtr() : nullptr;
  auto visit = [&](const auto& kern, const LocalStencil& ls, int sidx) {
    using K = std::decay_t<decltype(kern)>;
    constexpr int NX = KernelSize<K>::nx;
    constexpr bool linear = KernelLinear<K>::value;
    if (!out.gradient && (!hv || linear)) {
      out.energy += kern(ls.xv, ls.pv);
      return;
    }
    if (!hv || linear) {
      // Forces only (or a term without Hessian): first-order AD.
      using G = ad::Grad<NX, double>;
      G x[NX];
      for (int i = 0; i < ls.nx; ++i) x[i] = G::variable(ls.xv[i], i);
      const G r = kern(x, ls.pv);
      out.energy += r.v;
      for (int k = 0; k < ls.nx; ++k)
        for (int a = 0; a < 2; ++a) {
          const int pos = ls.xmap[k].idx[a];
          if (pos < 0) continue;
          const int I = ls.sdofs[pos];
          if (I >= 0) (*out.gradient)[I] += ls.xmap[k].coef[a] * r.g[k];
        }
      return;
    }
    const ad::Hess<NX, double> r = evalLocal<NX, double, false>(kern, ls, nullptr);
    out.energy += r.v;
    scatterSim<NX>(r, ls, stencilSlots_.data() + stencils_[sidx].offset, out.gradient, hv);
  };
  forEachStencil<D, TW>(ctx, visit);
}

template <int D, bool TW, class T>
void PoseSystem::runJoint(const PoseState& s, const Design& d, Terms terms, const Eigen::VectorXd* v,
                          JointDerivatives& out) const {
  const std::vector<Vec3> x = positions(s, d);
  const Eigen::VectorXd theta = twists(s.u);
  const std::vector<double> hc = heldCoefficients(s.loadFactor);
  BuildCtx ctx = context(x, theta, d, &hc, s.charts, s.loadFactor, terms);
  ctx.internal = internalOf(s);
  const bool derivative = v != nullptr;
  double* vals[3] = {out.Huu.valuePtr(), out.Hup.valuePtr(), out.Hpp.valuePtr()};
  constexpr int kSlotMask = (1 << kSlotShift) - 1;
  auto visit = [&](const auto& kern, const LocalStencil& ls, int sidx) {
    using K = std::decay_t<decltype(kern)>;
    constexpr int N = KernelSize<K>::nx + KernelSize<K>::np;
    JointMap m;
    buildJointMap(ls, ctx, m);
    double dir[2 * kMaxLocal] = {};
    if (derivative)
      for (int k = 0; k < ls.nx; ++k)
        for (int t = 0; t < m.nterms[k]; ++t)
          if (!m.isP[m.tg[k][t]]) dir[k] += m.tc[k][t] * (*v)[m.index[m.tg[k][t]]];
    const ad::Hess<N, T> r = evalJoint<N, T>(kern, ls, derivative ? dir : nullptr);
    out.energy += partOf(r.v, derivative);
    GlobalBlock gb;
    toGlobals<N, T>(r, m, ls.nx + ls.np, derivative, gb);
    for (int i = 0; i < m.ng; ++i) {
      if (gb.g[i] != 0.0) (m.isP[i] ? out.gp : out.gu)[m.index[i]] += gb.g[i];
    }
    const Stencil& st = jointStencils_[sidx];
    const int* slots = jointSlots_.data() + st.offset;
    const int nl = m.ng * (m.ng + 1) / 2;
    for (int e = 0; e < nl; ++e) {
      const double h = gb.L[e];
      if (h == 0.0) continue;
      const int sl = slots[e];
      if (sl >= 0) vals[sl >> kSlotShift][sl & kSlotMask] += h;
    }
  };
  forEachStencil<D, TW>(ctx, visit);
}

// (dF/dp)^T lambda = D_lambda (dE/dp): the design gradient differentiated
// along lambda in u-space, by first-order AD whose scalars carry a dual part
// seeded with lambda (no Hessians formed).
template <int D, bool TW>
void PoseSystem::runProduct(const PoseState& s, const Design& d, Terms terms, const Eigen::VectorXd& lambda,
                            Eigen::VectorXd& outP, Eigen::VectorXd* outU) const {
  const std::vector<Vec3> x = positions(s, d);
  const Eigen::VectorXd theta = twists(s.u);
  const std::vector<double> hc = heldCoefficients(s.loadFactor);
  BuildCtx ctx = context(x, theta, d, &hc, s.charts, s.loadFactor, terms);
  ctx.internal = internalOf(s);
  auto visit = [&](const auto& kern, const LocalStencil& ls, int) {
    using K = std::decay_t<decltype(kern)>;
    constexpr int N = KernelSize<K>::nx + KernelSize<K>::np;
    using G = ad::Grad<N, ad::Dual>;
    JointMap m;
    buildJointMap(ls, ctx, m);
    G vars[N];
    for (int k = 0; k < ls.nx; ++k) {
      double dk = 0.0;
      for (int t = 0; t < m.nterms[k]; ++t)
        if (!m.isP[m.tg[k][t]]) dk += m.tc[k][t] * lambda[m.index[m.tg[k][t]]];
      vars[k] = G::variable(ad::Dual(ls.xv[k], dk), k);
    }
    for (int k = 0; k < ls.np; ++k) vars[ls.nx + k] = G::variable(ad::Dual(ls.pv[k]), ls.nx + k);
    const G r = kern(vars, vars + ls.nx);
    for (int k = 0; k < ls.nx + ls.np; ++k) {
      const double gk = r.g[k].d;
      if (gk == 0.0) continue;
      for (int t = 0; t < m.nterms[k]; ++t) {
        const int g = m.tg[k][t];
        if (m.isP[g]) outP[m.index[g]] += m.tc[k][t] * gk;
        else if (outU) (*outU)[m.index[g]] += m.tc[k][t] * gk;
      }
    }
  };
  forEachStencil<D, TW>(ctx, visit);
}

}  // namespace rodmesh

// Explicit instantiations for one unknowns layout (D, TW).
#define RODMESH_INSTANTIATE_SIM(D, TW)                                                                            \
  template void rodmesh::PoseSystem::runSim<D, TW, rodmesh::detail::SimOut>(                                      \
      const rodmesh::PoseState&, const rodmesh::Design&, rodmesh::PoseSystem::Terms, rodmesh::detail::SimOut&) const;
#define RODMESH_INSTANTIATE_JOINT(D, TW, T)                                                                       \
  template void rodmesh::PoseSystem::runJoint<D, TW, T>(const rodmesh::PoseState&, const rodmesh::Design&,        \
                                                        rodmesh::PoseSystem::Terms, const Eigen::VectorXd*,       \
                                                        rodmesh::JointDerivatives&) const;
#define RODMESH_INSTANTIATE_PRODUCT(D, TW)                                                                        \
  template void rodmesh::PoseSystem::runProduct<D, TW>(const rodmesh::PoseState&, const rodmesh::Design&,         \
                                                       rodmesh::PoseSystem::Terms, const Eigen::VectorXd&,          \
                                                       Eigen::VectorXd&, Eigen::VectorXd*) const;
