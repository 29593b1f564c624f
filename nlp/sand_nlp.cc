#include "nlp/sand_nlp.hh"

#include "model/network.hh"
#include "model/stiffness.hh"
#include "solver/newton.hh"
#include "solver/parallel.hh"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace rodmesh {
namespace {

using Sparse = Eigen::SparseMatrix<double>;

// Index of entry (row, col) in a compressed column-major matrix, -1 if absent.
int entryIndex(const Sparse& A, int row, int col) {
  const int* inner = A.innerIndexPtr();
  const int begin = A.outerIndexPtr()[col], end = A.outerIndexPtr()[col + 1];
  const int* it = std::lower_bound(inner + begin, inner + end, row);
  return it != inner + end && *it == row ? static_cast<int>(it - inner) : -1;
}

// Same structure (dimensions, column starts, row indices).
bool sameStructure(const Sparse& a, const Sparse& b) {
  if (a.rows() != b.rows() || a.cols() != b.cols() || a.nonZeros() != b.nonZeros()) return false;
  return std::memcmp(a.outerIndexPtr(), b.outerIndexPtr(), sizeof(int) * (a.outerSize() + 1)) == 0 &&
         std::memcmp(a.innerIndexPtr(), b.innerIndexPtr(), sizeof(int) * a.nonZeros()) == 0;
}

Sparse compressed(Sparse m) {
  m.makeCompressed();
  return m;
}

// J^T A J with A given by its lower triangle, in a structure that depends
// on the structures of A and J only (Eigen's conservative products keep
// structural zeros).
Sparse congruence(const Sparse& JT, const Sparse& Alower, const Sparse& J) {
  Sparse full = Alower.selfadjointView<Eigen::Lower>();
  Sparse left = JT * full;
  return compressed(left * J);
}

// The applied loads of a pose at u (N, force residual units): the gradient of
// its gravity and load terms alone.
double appliedLoadNorm(const PoseSystem& sys, const PoseState& state, const Design& d) {
  Eigen::VectorXd g;
  sys.evaluate(state, d, &g, nullptr, PoseSystem::Terms::loads());
  return sys.forceResidual(g).stableNorm();
}

// The reactions (N, 2-norm) of pose k's held vertices prescribed away from
// their rest positions, at the equilibrium u of `sys`: the energy gradient
// with respect to their positions, evaluated by a copy of the pose in which
// they are unknowns (same effects, rest frames as charts, so that its twist
// unknowns are the material twists).
double displacedReactions(const Scene& scene, const EffectSet& effects, const PoseSystem& sys, int k,
                          const PoseState& state, const Design& d, const std::vector<int>& displaced) {
  Scene freed = scene;
  std::vector<FixedVertex>& fixed = freed.poses[k].fixed;
  fixed.erase(std::remove_if(fixed.begin(), fixed.end(),
                             [&](const FixedVertex& f) {
                               return std::find(displaced.begin(), displaced.end(), f.vertex) != displaced.end();
                             }),
              fixed.end());
  const RodNetwork network(freed);
  const PoseSystem copy(freed, network, effects, k);
  const PoseState freedState{copy.dofsFrom(sys.positions(state, d), sys.materialTwists(state, d)),
                             copy.restCharts(d), 1.0, {}};
  Eigen::VectorXd g;
  copy.evaluate(freedState, d, &g, nullptr);
  double sum = 0.0;
  for (int vertex : displaced) {
    const int dof = copy.vertexDof()[vertex];
    if (dof >= 0) sum += g.segment(dof, copy.dofsPerVertex()).squaredNorm();
  }
  return std::sqrt(sum);
}

}  // namespace

std::vector<double> sandLoadScales(const SceneModel& model, const Design& d, const std::vector<PoseState>& states) {
  const Scene& scene = model.scene();
  const int K = model.numPoses();
  std::vector<double> load(K, 0.0);
  std::vector<char> loaded(K, 0);
  for (int k = 0; k < K; ++k) {
    const PoseSystem& sys = model.pose(k);
    std::vector<int> displaced;
    for (const FixedVertex& f : scene.poses[k].fixed)
      if (f.position && (*f.position - d.restPositions[f.vertex]).norm() > 0.0) displaced.push_back(f.vertex);
    double L = 0.0;
    if (displaced.empty()) {
      L = loadScale(sys, d);
    } else {
      try {
        const double applied = appliedLoadNorm(sys, states[k], d);
        const double reactions = displacedReactions(scene, model.effects(), sys, k, states[k], d, displaced);
        L = std::hypot(applied, reactions);
      } catch (...) {
        // The copy of the pose could not be built or evaluated: the rest
        // state's residual, an overestimate but a force.
        L = loadScale(sys, d);
      }
    }
    // Loads at round-off (a few ulps of the stiffest edge's force) are none.
    loaded[k] = std::isfinite(L) && L > sys.roundoffForce(d);
    load[k] = loaded[k] ? L : 0.0;
  }
  const double largest = *std::max_element(load.begin(), load.end());
  double fallback = largest;
  if (!(fallback > 0)) {
    // No pose has loads: E I / l^2 of the mean rod cross-section and the
    // mean rest edge length.
    double rt = 0.0, rn = 0.0;
    for (const Vec2& r : d.radii) {
      rt += r[0];
      rn += r[1];
    }
    rt /= std::max<std::size_t>(1, d.radii.size());
    rn /= std::max<std::size_t>(1, d.radii.size());
    const double l = K > 0 ? model.pose(0).momentArm() : 1.0;
    fallback = stiffness::bendingOut(scene.material.youngModulus, rt, rn) / (l * l);
  }
  for (int k = 0; k < K; ++k)
    if (!loaded[k]) load[k] = fallback;
  return load;
}

SandNlp::SandNlp(const SceneModel& model, const DesignSpace& space, const TargetObjective& objective,
                 const DesignPhase& phase, const ControlValues& base, const std::vector<PoseState>& states,
                 SandScaling scaling, int threads)
    : model_(model),
      space_(space),
      objective_(objective),
      phase_(phase),
      base_(base),
      scale_(std::move(scaling)),
      threads_(std::max(1, threads)) {
  K_ = model.numPoses();
  if (static_cast<int>(states.size()) != K_ || static_cast<int>(scale_.load.size()) != K_)
    throw std::invalid_argument("SandNlp: one state and one load scale per pose are required");
  nz_ = space.numFree(phase);
  if (scale_.variable.size() != nz_) throw std::invalid_argument("SandNlp: one scale per free design value");
  if (!(scale_.objective > 0) || !std::isfinite(scale_.objective))
    throw std::invalid_argument("SandNlp: the objective scale must be positive");
  offset_.resize(K_ + 1, 0);
  for (int k = 0; k < K_; ++k) {
    if (states[k].loadFactor != 1.0) throw std::invalid_argument("SandNlp: pose states must be at full load");
    if (states[k].u.size() != model.pose(k).numDofs()) throw std::invalid_argument("SandNlp: state size");
    offset_[k + 1] = offset_[k] + model.pose(k).numDofs();
  }
  zOffset_ = offset_[K_];
  m_ = zOffset_;
  n_ = zOffset_ + nz_;
  Jy_ = compressed(space.jacobian(phase) * scale_.variable.asDiagonal());
  JyT_ = compressed(Jy_.transpose());

  x0_.resize(n_);
  state_.resize(K_);
  rowScale_.resize(K_);
  joint_.resize(K_);
  dir_.resize(K_);
  for (int k = 0; k < K_; ++k) {
    const PoseSystem& sys = model.pose(k);
    state_[k] = PoseState{states[k].u, states[k].charts, 1.0, {}};
    x0_.segment(offset_[k], sys.numDofs()) = states[k].u;
    const double L = scale_.load[k];
    if (!(L > 0) || !std::isfinite(L)) throw std::invalid_argument("SandNlp: load scales must be positive");
    rowScale_[k] = sys.forceResidual(Eigen::VectorXd::Ones(sys.numDofs())) / L;
  }
  if (nz_ > 0) x0_.tail(nz_) = space.pack(phase, base).cwiseQuotient(scale_.variable);

  // --- Jacobian structure ------------------------------------------------
  huuRow_.resize(K_);
  hupJPattern_.resize(K_);
  for (int k = 0; k < K_; ++k) {
    const JointDerivatives& P = model.pose(k).jointPattern();
    const int off = offset_[k];
    jacHuuBase_.push_back(static_cast<int>(jacRow_.size()));
    huuRow_[k].resize(P.Huu.nonZeros());
    for (int c = 0; c < P.Huu.outerSize(); ++c)
      for (int e = P.Huu.outerIndexPtr()[c]; e < P.Huu.outerIndexPtr()[c + 1]; ++e) {
        const int r = P.Huu.innerIndexPtr()[e];
        huuRow_[k][e] = r;
        jacRow_.push_back(off + r);
        jacCol_.push_back(off + c);
      }
    hupJPattern_[k] = compressed(P.Hup * Jy_);
    jacHupBase_.push_back(static_cast<int>(jacRow_.size()));
    const Sparse& Q = hupJPattern_[k];
    for (int c = 0; c < Q.outerSize(); ++c)
      for (int e = Q.outerIndexPtr()[c]; e < Q.outerIndexPtr()[c + 1]; ++e) {
        jacRow_.push_back(off + Q.innerIndexPtr()[e]);
        jacCol_.push_back(zOffset_ + c);
      }
  }

  // --- Hessian structure (lower triangle) -------------------------------
  hessHuuSlot_.resize(K_);
  hessDiagSlot_.resize(K_);
  for (int k = 0; k < K_; ++k) {
    const PoseSystem& sys = model.pose(k);
    const JointDerivatives& P = sys.jointPattern();
    const int off = offset_[k];
    hessHuuSlot_[k].assign(P.Huu.nonZeros(), -1);
    hessDiagSlot_[k].assign(sys.numVertexDofs(), -1);
    for (int c = 0; c < P.Huu.outerSize(); ++c)
      for (int e = P.Huu.outerIndexPtr()[c]; e < P.Huu.outerIndexPtr()[c + 1]; ++e) {
        const int r = P.Huu.innerIndexPtr()[e];
        if (r < c) continue;
        hessHuuSlot_[k][e] = static_cast<int>(hessRow_.size());
        if (r == c && r < sys.numVertexDofs()) hessDiagSlot_[k][r] = static_cast<int>(hessRow_.size());
        hessRow_.push_back(off + r);
        hessCol_.push_back(off + c);
      }
    for (int i = 0; i < sys.numVertexDofs(); ++i)
      if (hessDiagSlot_[k][i] < 0) throw std::logic_error("SandNlp: a vertex unknown has no diagonal Hessian entry");
    hessHupBase_.push_back(static_cast<int>(hessRow_.size()));
    const Sparse& Q = hupJPattern_[k];
    for (int c = 0; c < Q.outerSize(); ++c)
      for (int e = Q.outerIndexPtr()[c]; e < Q.outerIndexPtr()[c + 1]; ++e) {
        hessRow_.push_back(zOffset_ + c);
        hessCol_.push_back(off + Q.innerIndexPtr()[e]);
      }
  }
  // A = sum_k Hpp_k + Wp (lower), Wp the objective's Hessian in the rest
  // positions of held vertices: w c^2 P, P = I or the plane projector.
  const int P = static_cast<int>(5 * space.numVertices());
  std::vector<Eigen::Triplet<double>> trip;
  std::vector<Eigen::Triplet<double>> wp;
  const EffectSet& fx = model.effects();
  Eigen::Matrix3d proj = Eigen::Matrix3d::Identity();
  if (fx.planar) proj = fx.planeBasis * fx.planeBasis.transpose();
  for (int k = 0; k < K_; ++k) {
    const PoseSystem& sys = model.pose(k);
    const Sparse& H = sys.jointPattern().Hpp;
    for (int c = 0; c < H.outerSize(); ++c)
      for (Sparse::InnerIterator it(H, c); it; ++it) trip.emplace_back(it.row(), it.col(), 0.0);
    for (int v = 0; v < space.numVertices(); ++v) {
      if (!sys.isHeld(v)) continue;
      const double coef = sys.heldDesignCoefficient(v, 1.0);
      if (coef == 0.0) continue;
      const Eigen::Matrix3d block = objective.weight(k) * coef * coef * proj;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b <= a; ++b) {
          trip.emplace_back(Design::restIndex(v, a), Design::restIndex(v, b), 0.0);
          if (block(a, b) != 0.0) wp.emplace_back(Design::restIndex(v, a), Design::restIndex(v, b), block(a, b));
        }
    }
  }
  Apattern_.resize(P, P);
  Apattern_.setFromTriplets(trip.begin(), trip.end());
  Apattern_.makeCompressed();
  Apattern_.coeffs().setZero();
  hppToA_.resize(K_);
  for (int k = 0; k < K_; ++k) {
    const Sparse& H = model.pose(k).jointPattern().Hpp;
    hppToA_[k].resize(H.nonZeros());
    for (int c = 0; c < H.outerSize(); ++c)
      for (int e = H.outerIndexPtr()[c]; e < H.outerIndexPtr()[c + 1]; ++e)
        hppToA_[k][e] = entryIndex(Apattern_, H.innerIndexPtr()[e], c);
  }
  wpValues_ = Eigen::VectorXd::Zero(Apattern_.nonZeros());
  for (const auto& t : wp) wpValues_[entryIndex(Apattern_, t.row(), t.col())] += t.value();
  zzPattern_ = congruence(JyT_, Apattern_, Jy_);
  zzSlot_.assign(zzPattern_.nonZeros(), -1);
  for (int c = 0; c < zzPattern_.outerSize(); ++c)
    for (int e = zzPattern_.outerIndexPtr()[c]; e < zzPattern_.outerIndexPtr()[c + 1]; ++e) {
      const int r = zzPattern_.innerIndexPtr()[e];
      if (r < c) continue;
      zzSlot_[e] = static_cast<int>(hessRow_.size());
      hessRow_.push_back(zOffset_ + r);
      hessCol_.push_back(zOffset_ + c);
    }
}

void SandNlp::bounds(double* xl, double* xu) const {
  for (int i = 0; i < zOffset_; ++i) {
    xl[i] = -std::numeric_limits<double>::infinity();
    xu[i] = std::numeric_limits<double>::infinity();
  }
  Eigen::VectorXd lo, hi;
  space_.bounds(phase_, lo, hi);
  for (int j = 0; j < nz_; ++j) {
    xl[zOffset_ + j] = lo[j] / scale_.variable[j];
    xu[zOffset_ + j] = hi[j] / scale_.variable[j];
  }
}

ControlValues SandNlp::controls(const double* x) const {
  const Eigen::Map<const Eigen::VectorXd> y(x + zOffset_, nz_);
  return space_.unpack(phase_, y.cwiseProduct(scale_.variable), base_);
}

Design SandNlp::design(const double* x) const { return space_.toDesign(controls(x)); }

std::vector<PoseState> SandNlp::states(const double* x) const {
  std::vector<PoseState> s = state_;
  for (int k = 0; k < K_; ++k) s[k].u = Eigen::Map<const Eigen::VectorXd>(x + offset_[k], offset_[k + 1] - offset_[k]);
  return s;
}

bool SandNlp::prepare(const double* x) {
  if (prepared_ && std::memcmp(x, x_.data(), sizeof(double) * n_) == 0) return true;
  prepared_ = false;
  jointReady_ = false;
  x_ = Eigen::Map<const Eigen::VectorXd>(x, n_);
  if (!x_.allFinite()) return false;
  design_ = design(x);
  for (int k = 0; k < K_; ++k) state_[k].u = x_.segment(offset_[k], offset_[k + 1] - offset_[k]);
  prepared_ = true;
  return true;
}

template <class Fn>
bool SandNlp::guarded(Fn&& fn) {
  const auto t0 = std::chrono::steady_clock::now();
  bool ok = false;
  try {
    ok = fn();
  } catch (...) {
    ok = false;
  }
  evalSeconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  evaluations_++;
  return ok;
}

bool SandNlp::ensureJoint() {
  if (jointReady_) return true;
  std::vector<char> ok(K_, 1);
  forEachPose(K_, threads_, [&](int k) {
    try {
      model_.pose(k).evaluateJoint(state_[k], design_, joint_[k]);
      ok[k] = joint_[k].gu.allFinite();
    } catch (...) {
      ok[k] = 0;
    }
  });
  jointReady_ = std::all_of(ok.begin(), ok.end(), [](char c) { return c != 0; });
  return jointReady_;
}

void SandNlp::poseGradient(int k, Eigen::VectorXd& grad) {
  if (jointReady_) {
    grad = joint_[k].gu;
    return;
  }
  model_.pose(k).evaluate(state_[k], design_, &grad, nullptr);
}

bool SandNlp::objective(const double* x, double& f) {
  return guarded([&] {
    if (!prepare(x)) return false;
    double sum = 0.0;
    for (int k = 0; k < K_; ++k) sum += objective_.pose(model_.pose(k), state_[k], design_, nullptr, nullptr);
    f = sum / scale_.objective;
    return std::isfinite(f);
  });
}

bool SandNlp::gradient(const double* x, double* g) {
  return guarded([&] {
    if (!prepare(x)) return false;
    Eigen::Map<Eigen::VectorXd> out(g, n_);
    out.setZero();
    Eigen::VectorXd dfdp = Eigen::VectorXd::Zero(5 * space_.numVertices());
    for (int k = 0; k < K_; ++k) {
      Eigen::VectorXd dfdu = Eigen::VectorXd::Zero(state_[k].u.size());
      objective_.pose(model_.pose(k), state_[k], design_, &dfdu, &dfdp);
      out.segment(offset_[k], dfdu.size()) = dfdu;
    }
    if (nz_ > 0) out.tail(nz_) = JyT_ * dfdp;
    out /= scale_.objective;
    return out.allFinite();
  });
}

bool SandNlp::constraints(const double* x, double* c) {
  return guarded([&] {
    if (!prepare(x)) return false;
    Eigen::Map<Eigen::VectorXd> out(c, m_);
    std::vector<char> ok(K_, 1);
    forEachPose(K_, threads_, [&](int k) {
      try {
        const int n = offset_[k + 1] - offset_[k];
        Eigen::VectorXd grad;
        poseGradient(k, grad);
        out.segment(offset_[k], n) = rowScale_[k].cwiseProduct(grad);
      } catch (...) {
        ok[k] = 0;
      }
    });
    return std::all_of(ok.begin(), ok.end(), [](char v) { return v != 0; }) && out.allFinite();
  });
}

bool SandNlp::jacobian(const double* x, double* values) {
  return guarded([&] {
    if (!prepare(x) || !ensureJoint()) return false;
    for (int k = 0; k < K_; ++k) {
      const JointDerivatives& J = joint_[k];
      const Eigen::VectorXd& rs = rowScale_[k];
      const double* hv = J.Huu.valuePtr();
      double* out = values + jacHuuBase_[k];
      for (std::size_t e = 0; e < huuRow_[k].size(); ++e) out[e] = rs[huuRow_[k][e]] * hv[e];
      const Sparse Q = compressed(J.Hup * Jy_);
      if (!sameStructure(Q, hupJPattern_[k])) return false;
      out = values + jacHupBase_[k];
      for (int e = 0; e < Q.nonZeros(); ++e) out[e] = rs[Q.innerIndexPtr()[e]] * Q.valuePtr()[e];
    }
    return std::all_of(values, values + jacRow_.size(), [](double v) { return std::isfinite(v); });
  });
}

bool SandNlp::hessian(const double* x, double sigma, const double* lambda, double* values) {
  return guarded([&] {
    if (!prepare(x)) return false;
    std::fill(values, values + hessRow_.size(), 0.0);
    std::vector<char> ok(K_, 1);
    forEachPose(K_, threads_, [&](int k) {
      try {
        const PoseSystem& sys = model_.pose(k);
        const int n = offset_[k + 1] - offset_[k];
        const Eigen::VectorXd v = rowScale_[k].cwiseProduct(Eigen::Map<const Eigen::VectorXd>(lambda + offset_[k], n));
        sys.evaluateJoint(state_[k], design_, dir_[k], &v);
      } catch (...) {
        ok[k] = 0;
      }
    });
    if (!std::all_of(ok.begin(), ok.end(), [](char v) { return v != 0; })) return false;
    const double objScale = sigma / scale_.objective;
    Sparse A = Apattern_;
    Eigen::Map<Eigen::VectorXd>(A.valuePtr(), A.nonZeros()) = objScale * wpValues_;
    for (int k = 0; k < K_; ++k) {
      const JointDerivatives& D = dir_[k];
      const double* hv = D.Huu.valuePtr();
      for (std::size_t e = 0; e < hessHuuSlot_[k].size(); ++e)
        if (hessHuuSlot_[k][e] >= 0) values[hessHuuSlot_[k][e]] += hv[e];
      const double w = objScale * objective_.weight(model_.pose(k).poseIndex());
      for (int slot : hessDiagSlot_[k]) values[slot] += w;
      const Sparse Q = compressed(D.Hup * Jy_);
      if (!sameStructure(Q, hupJPattern_[k])) return false;
      double* out = values + hessHupBase_[k];
      for (int e = 0; e < Q.nonZeros(); ++e) out[e] += Q.valuePtr()[e];
      if (D.Hpp.nonZeros() != static_cast<int>(hppToA_[k].size())) return false;
      const double* pv = D.Hpp.valuePtr();
      for (std::size_t e = 0; e < hppToA_[k].size(); ++e) A.valuePtr()[hppToA_[k][e]] += pv[e];
    }
    const Sparse Z = congruence(JyT_, A, Jy_);
    if (!sameStructure(Z, zzPattern_)) return false;
    for (int e = 0; e < Z.nonZeros(); ++e)
      if (zzSlot_[e] >= 0) values[zzSlot_[e]] += Z.valuePtr()[e];
    return std::all_of(values, values + hessRow_.size(), [](double v) { return std::isfinite(v); });
  });
}

double SandNlp::rms(const double* x) {
  if (!prepare(x)) return std::numeric_limits<double>::quiet_NaN();
  double ss = 0.0;
  for (int k = 0; k < K_; ++k) {
    double s = 0.0;
    objective_.pose(model_.pose(k), state_[k], design_, nullptr, nullptr, &s);
    ss += s;
  }
  return objective_.rms(ss);
}

double SandNlp::forceViolation(const double* x) {
  if (!prepare(x)) return std::numeric_limits<double>::quiet_NaN();
  double worst = 0.0;
  try {
    for (int k = 0; k < K_; ++k) {
      Eigen::VectorXd grad;
      poseGradient(k, grad);
      if (grad.size() > 0) worst = std::max(worst, model_.pose(k).forceResidual(grad).lpNorm<Eigen::Infinity>());
    }
  } catch (...) {  // called from Ipopt's iteration callback: nothing may throw through it
    return std::numeric_limits<double>::infinity();
  }
  return worst;
}

}  // namespace rodmesh
