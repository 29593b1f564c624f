// Joint derivatives of a pose's energy w.r.t. unknowns and design in fixed
// sparsity patterns, their directional derivatives (third derivatives), and
// the first-order product (dF/dp)^T lambda for adjoint gradients. Kept apart
// from the simulation path so that the two compile in parallel.
#include "model/pose_system.hh"

#include "model/pose_system_detail.hh"

#include <algorithm>
#include <exception>
#include <functional>
#include <stdexcept>
#include <sys/mman.h>
#include <ucontext.h>

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/common_interface_defs.h>
#endif

namespace rodmesh {

using namespace detail;

namespace {
// Joint derivatives of large stencils (a six-valent connection has 56 local
// variables: a Hessian scalar with a direction is 26 kB, and the kernel keeps
// dozens of them; about 2 MB of stack in all) may need more stack than the
// calling thread has. They run on a stack owned by the calling thread: 64 MB
// reserved once per thread (only touched pages are committed, and they stay
// committed for the next call), entered by a context switch on the same
// thread, so no thread is created and the work stays on the caller's CPU.
constexpr std::size_t kLargeStackBytes = std::size_t(64) << 20;

struct LargeStack {
  void* base = nullptr;
  LargeStack() {
    void* p = mmap(nullptr, kLargeStackBytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE,
                   -1, 0);
    if (p == MAP_FAILED) return;
    mprotect(p, 4096, PROT_NONE);  // guard page at the bottom: an overflow faults
    base = p;
  }
  ~LargeStack() {
    if (base) munmap(base, kLargeStackBytes);
  }
  LargeStack(const LargeStack&) = delete;
  LargeStack& operator=(const LargeStack&) = delete;
};

struct LargeStackCall {
  const std::function<void()>* fn = nullptr;
  std::exception_ptr error;
  ucontext_t caller{}, callee{};
#if defined(__SANITIZE_ADDRESS__)
  void* fakeStack = nullptr;
  const void* callerBottom = nullptr;
  std::size_t callerSize = 0;
#endif
};

thread_local LargeStackCall* tCall = nullptr;

void largeStackEntry() {
  LargeStackCall* call = tCall;
#if defined(__SANITIZE_ADDRESS__)
  __sanitizer_finish_switch_fiber(nullptr, &call->callerBottom, &call->callerSize);
#endif
  try {
    (*call->fn)();
  } catch (...) {
    call->error = std::current_exception();
  }
#if defined(__SANITIZE_ADDRESS__)
  __sanitizer_start_switch_fiber(nullptr, call->callerBottom, call->callerSize);
#endif
  // Returning resumes uc_link (the caller).
}

void runWithLargeStack(const std::function<void()>& fn) {
  thread_local LargeStack stack;
  if (tCall || !stack.base) {  // already on it, or no stack could be reserved
    fn();
    return;
  }
  LargeStackCall call;
  call.fn = &fn;
  getcontext(&call.callee);
  call.callee.uc_stack.ss_sp = stack.base;
  call.callee.uc_stack.ss_size = kLargeStackBytes;
  call.callee.uc_link = &call.caller;
  makecontext(&call.callee, largeStackEntry, 0);
  tCall = &call;
#if defined(__SANITIZE_ADDRESS__)
  __sanitizer_start_switch_fiber(&call.fakeStack, stack.base, kLargeStackBytes);
#endif
  swapcontext(&call.caller, &call.callee);
#if defined(__SANITIZE_ADDRESS__)
  __sanitizer_finish_switch_fiber(call.fakeStack, nullptr, nullptr);
#endif
  tCall = nullptr;
  if (call.error) std::rethrow_exception(call.error);
}

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

// Joint value slots are stored as block << kSlotShift | index.
constexpr int kSlotShift = 28;

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
void PoseSystem::buildJointPattern() const {
  if (jointReady_) return;
  // The pattern covers every term, whatever filter is active now.
  const Terms savedFilter = filter_;
  filter_ = Terms::All;
  const Design d0 = Design::fromScene(scene_);
  const int P = d0.numParameters();
  const std::vector<Vec3> x = d0.restPositions;
  const Eigen::VectorXd theta = Eigen::VectorXd::Zero(net_.numEdges());
  const Mat32 B = fx_.planeBasis;
  const std::vector<double> hc = heldCoefficients();
  struct Globals {
    std::vector<bool> isP;
    std::vector<int> index;
  };
  std::vector<Globals> stencils;
  withLayout([&](auto Dc, auto TWc) {
    constexpr int D = decltype(Dc)::value;
    constexpr bool TW = decltype(TWc)::value;
    BuildCtx ctx{&x, &theta, &d0, &vertexDof_, &B, fx_.planeOrigin, D, TW, nVertexDofs_, &hc};
    forEachStencil<D, TW, true>(ctx, [&](const auto&, const LocalStencil& ls, int) {
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
  filter_ = savedFilter;
  jointReady_ = true;
}

const JointDerivatives& PoseSystem::jointPattern() const {
  buildJointPattern();
  return jointPattern_;
}

template <int D, bool TW, class T>
void PoseSystem::runJoint(const Eigen::VectorXd& u, const Design& d, const Eigen::VectorXd* v,
                          JointDerivatives& out) const {
  const std::vector<Vec3> x = positions(u, d);
  const Eigen::VectorXd theta = twists(u);
  const Mat32 B = fx_.planeBasis;
  const std::vector<double> hc = heldCoefficients();
  BuildCtx ctx{&x, &theta, &d, &vertexDof_, &B, fx_.planeOrigin, D, TW, nVertexDofs_, &hc};
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
  forEachStencil<D, TW, true>(ctx, visit);

  // Point forces and twisting moments: linear in the positions and twists.
  if (use(Terms::Forces)) {
    for (std::size_t vi = 0; vi < pointForce_.size(); ++vi) {
      const Vec3 f = loadFactor_ * pointForce_[vi];
      if (f.squaredNorm() == 0) continue;
      const int k = vertexDof_[vi];
      if (derivative) {
        // D_v of the value -f.x; gradients and Hessians of a linear term have
        // zero directional derivative.
        if (k >= 0) {
          const Vec3 dx = D == 3 ? Vec3(v->segment<3>(k)) : Vec3(B * v->segment<2>(k));
          out.energy -= f.dot(dx);
        }
        continue;
      }
      out.energy -= f.dot(x[vi]);
      if (k >= 0) {
        if constexpr (D == 3) out.gu.template segment<3>(k) -= f;
        else out.gu.template segment<2>(k) -= B.transpose() * f;
      } else {
        // A held vertex follows the design's rest position.
        for (int j = 0; j < 3; ++j) out.gp[Design::restIndex(static_cast<int>(vi), j)] -= hc[vi] * f[j];
      }
    }
    if constexpr (TW)
      for (const auto& [e, mom] : edgeMoment_) {
        if (derivative) {
          out.energy -= loadFactor_ * mom * (*v)[thetaDof(e)];
        } else {
          out.energy -= loadFactor_ * mom * theta[e];
          out.gu[thetaDof(e)] -= loadFactor_ * mom;
        }
      }
  }
}

void PoseSystem::evaluateJoint(const Eigen::VectorXd& u, const Design& d, JointDerivatives& out,
                               const Eigen::VectorXd* v) const {
  buildJointPattern();
  const JointDerivatives& jp = jointPattern_;
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
  runWithLargeStack([&] {
    withLayout([&](auto Dc, auto TWc) {
      constexpr int D = decltype(Dc)::value;
      constexpr bool TW = decltype(TWc)::value;
      if (v) runJoint<D, TW, ad::Dual>(u, d, v, out);
      else runJoint<D, TW, double>(u, d, nullptr, out);
    });
  });
  // Huu is symmetric: the stencils fill its lower triangle.
  double* huu = out.Huu.valuePtr();
  for (const auto& [upper, lower] : jointUpperFromLower_) huu[upper] = huu[lower];
}

JointDerivatives PoseSystem::joint(const Eigen::VectorXd& u, const Design& d) const {
  JointDerivatives out;
  evaluateJoint(u, d, out);
  return out;
}

JointDerivatives PoseSystem::jointDirectional(const Eigen::VectorXd& u, const Design& d,
                                              const Eigen::VectorXd& v) const {
  JointDerivatives out;
  evaluateJoint(u, d, out, &v);
  return out;
}

// (dF/dp)^T lambda = D_lambda (dE/dp): the design gradient differentiated
// along lambda in u-space, by first-order AD whose scalars carry a dual part
// seeded with lambda (no Hessians formed).
template <int D, bool TW>
void PoseSystem::runProduct(const Eigen::VectorXd& u, const Design& d, const Eigen::VectorXd& lambda,
                            Eigen::VectorXd& outP, Eigen::VectorXd* outU) const {
  const std::vector<Vec3> x = positions(u, d);
  const Eigen::VectorXd theta = twists(u);
  const Mat32 B = fx_.planeBasis;
  const std::vector<double> hc = heldCoefficients();
  BuildCtx ctx{&x, &theta, &d, &vertexDof_, &B, fx_.planeOrigin, D, TW, nVertexDofs_, &hc};
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
  forEachStencil<D, TW, true>(ctx, visit);
}

Eigen::VectorXd PoseSystem::designForceProduct(const Eigen::VectorXd& u, const Design& d,
                                               const Eigen::VectorXd& lambda,
                                               Eigen::VectorXd* hessianTimesLambda) const {
  Eigen::VectorXd outP = Eigen::VectorXd::Zero(d.numParameters());
  if (hessianTimesLambda) hessianTimesLambda->setZero(nDofs_);
  runWithLargeStack([&] {
    withLayout([&](auto Dc, auto TWc) {
      runProduct<decltype(Dc)::value, decltype(TWc)::value>(u, d, lambda, outP, hessianTimesLambda);
    });
  });
  return outP;
}

}  // namespace rodmesh
