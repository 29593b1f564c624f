// Joint derivatives of a pose's energy w.r.t. unknowns and design in fixed
// sparsity patterns, their directional derivatives (third derivatives), and
// the first-order product (dF/dp)^T lambda for adjoint gradients: patterns
// and entry points. The evaluations themselves (runJoint, runProduct) are
// instantiated in pose_system_joint_values.cc, pose_system_joint_directional*.cc
// and pose_system_product.cc (model/pose_system_impl.hh).
#include "model/pose_system.hh"

#include "model/pose_system_detail.hh"

#include <algorithm>
#include <stdexcept>

namespace rodmesh {

using namespace detail;

namespace {
// Builds a CSC matrix pattern from per-column row lists.
Eigen::SparseMatrix<double> patternFrom(std::vector<std::vector<int>>& cols, int rows) {
  const int n = static_cast<int>(cols.size());
  std::vector<int> outer(n + 1, 0);
  for (int c = 0; c < n; ++c) {
    auto& r = cols[c];
    std::sort(r.begin(), r.end());
    r.erase(std::unique(r.begin(), r.end()), r.end());
    outer[c + 1] = outer[c] + static_cast<int>(r.size());
  }
  Eigen::SparseMatrix<double> m(rows, n);
  m.resizeNonZeros(outer[n]);
  for (int c = 0; c <= n; ++c) m.outerIndexPtr()[c] = outer[c];
  for (int c = 0; c < n; ++c) std::copy(cols[c].begin(), cols[c].end(), m.innerIndexPtr() + outer[c]);
  std::fill(m.valuePtr(), m.valuePtr() + outer[n], 0.0);
  return m;
}

int slotOf(const Eigen::SparseMatrix<double>& m, int r, int c) {
  const int* b = m.innerIndexPtr() + m.outerIndexPtr()[c];
  const int* e = m.innerIndexPtr() + m.outerIndexPtr()[c + 1];
  const int* it = std::lower_bound(b, e, r);
  return (it != e && *it == r) ? static_cast<int>(it - m.innerIndexPtr()) : -1;
}
}  // namespace

// Walks the stencil list once at the scene's rest state (structure only),
// collects every (global, global) pair of every stencil into the three block
// patterns, then records each pair's value slot.
// Called once, under jointOnce_.
void PoseSystem::buildJointPattern() const {
  const Design d0 = Design::fromScene(scene_);
  const int P = d0.numParameters();
  const std::vector<Vec3> x = d0.restPositions;
  const Eigen::VectorXd theta = Eigen::VectorXd::Zero(net_.numEdges());
  const std::vector<double> hc = heldCoefficients(1.0);
  const Charts charts = restCharts(d0);
  struct Globals {
    std::vector<bool> isP;
    std::vector<int> index;
  };
  std::vector<Globals> stencils;
  withLayout([&](auto Dc, auto TWc) {
    constexpr int D = decltype(Dc)::value;
    constexpr bool TW = decltype(TWc)::value;
    const BuildCtx ctx = context(x, theta, d0, &hc, charts, 1.0, Terms::All);
    forEachStencil<D, TW>(ctx, [&](const auto&, const LocalStencil& ls, int) {
      JointMap m;
      buildJointMap(ls, ctx, m);
      stencils.push_back({std::vector<bool>(m.isP, m.isP + m.ng), std::vector<int>(m.index, m.index + m.ng)});
    });
  });
  std::vector<std::vector<int>> uu(nDofs_), up(P), pp(P);
  for (int i = 0; i < nDofs_; ++i) uu[i].push_back(i);
  for (const Globals& s : stencils)
    for (std::size_t i = 0; i < s.index.size(); ++i)
      for (std::size_t j = 0; j < s.index.size(); ++j) {
        const int a = s.index[i], b = s.index[j];
        if (!s.isP[i] && !s.isP[j]) uu[b].push_back(a);
        else if (!s.isP[i] && s.isP[j]) up[b].push_back(a);
        else if (s.isP[i] && s.isP[j] && a >= b) pp[b].push_back(a);
      }
  JointDerivatives& jp = jointPattern_;
  jp.energy = 0.0;
  jp.gu.setZero(nDofs_);
  jp.gp.setZero(P);
  jp.Huu = patternFrom(uu, nDofs_);
  jp.Hup = patternFrom(up, nDofs_);
  jp.Hpp = patternFrom(pp, P);
  if (std::max({jp.Huu.nonZeros(), jp.Hup.nonZeros(), jp.Hpp.nonZeros()}) >= (Eigen::Index(1) << kSlotShift))
    throw std::length_error("joint derivative patterns too large for their slot encoding");
  jointSlots_.clear();
  jointStencils_.clear();
  // Per stencil, per lower-triangle pair (i >= j) of its globals, the value
  // slot it adds to, encoded as block << kSlotShift | index, block 0: Huu
  // (lower triangle), 1: Hup, 2: Hpp.
  auto enc = [](int block, int index) { return index < 0 ? -1 : (block << kSlotShift) | index; };
  for (const Globals& s : stencils) {
    const int ng = static_cast<int>(s.index.size());
    jointStencils_.push_back({static_cast<int>(jointSlots_.size()), ng});
    for (int i = 0; i < ng; ++i)
      for (int j = 0; j <= i; ++j) {
        const int a = s.index[i], b = s.index[j];
        int slot = -1;
        if (!s.isP[i] && !s.isP[j]) slot = enc(0, slotOf(jp.Huu, std::max(a, b), std::min(a, b)));
        else if (!s.isP[i] && s.isP[j]) slot = enc(1, slotOf(jp.Hup, a, b));
        else if (s.isP[i] && !s.isP[j]) slot = enc(1, slotOf(jp.Hup, b, a));
        else slot = enc(2, slotOf(jp.Hpp, std::max(a, b), std::min(a, b)));
        jointSlots_.push_back(slot);
      }
  }
  // Huu's strictly upper entries, each with its lower transpose.
  jointUpperFromLower_.clear();
  for (int c = 0; c < jp.Huu.outerSize(); ++c)
    for (int k = jp.Huu.outerIndexPtr()[c]; k < jp.Huu.outerIndexPtr()[c + 1]; ++k) {
      const int r = jp.Huu.innerIndexPtr()[k];
      if (r < c) jointUpperFromLower_.emplace_back(k, slotOf(jp.Huu, c, r));
    }
}

const JointDerivatives& PoseSystem::jointPattern() const {
  std::call_once(jointOnce_, [this] { buildJointPattern(); });
  return jointPattern_;
}

void PoseSystem::evaluateJoint(const PoseState& s, const Design& d, JointDerivatives& out, const Eigen::VectorXd* v,
                               Terms terms) const {
  const JointDerivatives& jp = jointPattern();
  auto samePattern = [](const Eigen::SparseMatrix<double>& a, const Eigen::SparseMatrix<double>& b) {
    return a.rows() == b.rows() && a.cols() == b.cols() && a.nonZeros() == b.nonZeros();
  };
  if (!samePattern(out.Huu, jp.Huu) || !samePattern(out.Hup, jp.Hup) || !samePattern(out.Hpp, jp.Hpp)) {
    out = jp;
  } else {
    std::fill(out.Huu.valuePtr(), out.Huu.valuePtr() + out.Huu.nonZeros(), 0.0);
    std::fill(out.Hup.valuePtr(), out.Hup.valuePtr() + out.Hup.nonZeros(), 0.0);
    std::fill(out.Hpp.valuePtr(), out.Hpp.valuePtr() + out.Hpp.nonZeros(), 0.0);
  }
  out.energy = 0.0;
  out.gu.setZero(nDofs_);
  out.gp.setZero(d.numParameters());
  withLayout([&](auto Dc, auto TWc) {
    constexpr int D = decltype(Dc)::value;
    constexpr bool TW = decltype(TWc)::value;
    if (v) runJoint<D, TW, ad::Dual>(s, d, terms, v, out);
    else runJoint<D, TW, double>(s, d, terms, nullptr, out);
  });
  // Huu is symmetric: the stencils fill its lower triangle.
  double* huu = out.Huu.valuePtr();
  for (const auto& [upper, lower] : jointUpperFromLower_) huu[upper] = huu[lower];
}

JointDerivatives PoseSystem::joint(const PoseState& s, const Design& d, Terms terms) const {
  JointDerivatives out;
  evaluateJoint(s, d, out, nullptr, terms);
  return out;
}

JointDerivatives PoseSystem::jointDirectional(const PoseState& s, const Design& d, const Eigen::VectorXd& v,
                                              Terms terms) const {
  JointDerivatives out;
  evaluateJoint(s, d, out, &v, terms);
  return out;
}

Eigen::VectorXd PoseSystem::designForceProduct(const PoseState& s, const Design& d,
                                               const Eigen::VectorXd& lambda, Eigen::VectorXd* hessianTimesLambda,
                                               Terms terms) const {
  Eigen::VectorXd outP = Eigen::VectorXd::Zero(d.numParameters());
  if (hessianTimesLambda) hessianTimesLambda->setZero(nDofs_);
  withLayout([&](auto Dc, auto TWc) {
    runProduct<decltype(Dc)::value, decltype(TWc)::value>(s, d, terms, lambda, outP, hessianTimesLambda);
  });
  return outP;
}

}  // namespace rodmesh
