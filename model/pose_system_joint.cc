// Joint derivatives of a pose's energy w.r.t. unknowns and design, and their
// directional derivatives (third derivatives), kept apart from the simulation
// path so that the two compile in parallel.
#include "model/pose_system.hh"

#include "model/pose_system_detail.hh"

#include <exception>
#include <functional>
#include <pthread.h>

namespace rodmesh {

using namespace detail;

template <int D, bool TW, class T>
void PoseSystem::runJoint(const Eigen::VectorXd& u, const Design& d, const Eigen::VectorXd* v,
                          JointDerivatives& out) const {
  const std::vector<Vec3> x = positions(u);
  const Eigen::VectorXd theta = twists(u);
  const Mat32 B = fx_.planeBasis;
  BuildCtx ctx{&x, &theta, &d, &vertexDof_, &B, fx_.planeOrigin, D, TW, nVertexDofs_};
  const bool derivative = v != nullptr;
  auto localDir = [&](const LocalStencil& ls, double* dir) {
    for (int k = 0; k < ls.nx; ++k) {
      dir[k] = 0.0;
      for (int a = 0; a < 2; ++a) {
        const int pos = ls.xmap[k].idx[a];
        if (pos >= 0 && ls.sdofs[pos] >= 0) dir[k] += ls.xmap[k].coef[a] * (*v)[ls.sdofs[pos]];
      }
    }
  };
  auto visit = [&](const auto& kern, const LocalStencil& ls, int) {
    using K = std::decay_t<decltype(kern)>;
    constexpr int N = KernelSize<K>::nx + KernelSize<K>::np;
    double dir[kMaxLocal];
    if (derivative) localDir(ls, dir);
    const ad::Hess<N, T> r = evalLocal<N, T, true>(kern, ls, derivative ? dir : nullptr);
    scatterJoint<N, T>(r, ls, derivative, out);
  };
  RODMESH_FOR_EACH_STENCIL(D, TW, ctx, visit);

  if (fx_.has(Effect::Gravity) && use(Terms::Gravity)) {
    GravityK<D, TW> kern;
    kern.k.g = loadFactor_ * *scene_.gravity;
    kern.k.density = scene_.material.density;
    kern.B = &B;
    for (const Edge& e : net_.edges()) {
      LocalStencil ls;
      const int pa = addVertex(ls, ctx, e.a), pb = addVertex(ls, ctx, e.b);
      kern.offA = addPointVars(ls, ctx, e.a, pa);
      kern.offB = addPointVars(ls, ctx, e.b, pb);
      addRestEdge(ls, ctx, e.a, e.b);
      addRadii(ls, ctx, e.a);
      addRadii(ls, ctx, e.b);
      visit(kern, ls, -1);
    }
  }
  if (use(Terms::Forces))
    for (std::size_t vi = 0; vi < pointForce_.size(); ++vi) {
      const Vec3 f = loadFactor_ * pointForce_[vi];
      if (f.squaredNorm() == 0) continue;
      const int k = vertexDof_[vi];
      if (derivative) {
        // D_v of the value -f.x; gradient and Hessian of a linear term have
        // zero directional derivative.
        if (k >= 0) {
          Eigen::Vector3d dx = D == 3 ? Eigen::Vector3d(v->segment<3>(k)) : Eigen::Vector3d(B * v->segment<2>(k));
          out.energy -= f.dot(dx);
        }
        continue;
      }
      out.energy -= f.dot(x[vi]);
      if (k < 0) continue;
      if constexpr (D == 3) out.gu.template segment<3>(k) -= f;
      else out.gu.template segment<2>(k) -= B.transpose() * f;
    }
  if (use(Terms::Forces) && TW)
    for (const auto& [e, m] : edgeMoment_) {
      if (derivative) {
        out.energy -= loadFactor_ * m * (*v)[thetaDof(e)];
      } else {
        out.energy -= loadFactor_ * m * theta[e];
        out.gu[thetaDof(e)] -= loadFactor_ * m;
      }
    }
}

namespace {
// Joint derivatives of large stencils (a six-valent connection has 56 local
// variables: a Hessian scalar of 26 kB, and the kernel keeps hundreds of
// them) need more stack than a default thread has: run on a thread with a
// 1 GiB stack reservation (virtual; only what is touched is committed).
void runWithLargeStack(const std::function<void()>& fn) {
  pthread_attr_t attr;
  pthread_attr_init(&attr);
  pthread_attr_setstacksize(&attr, std::size_t(1) << 30);
  struct Payload {
    const std::function<void()>* fn;
    std::exception_ptr error;
  } payload{&fn, nullptr};
  auto trampoline = [](void* arg) -> void* {
    auto* p = static_cast<Payload*>(arg);
    try {
      (*p->fn)();
    } catch (...) {
      p->error = std::current_exception();
    }
    return nullptr;
  };
  pthread_t thread;
  if (pthread_create(&thread, &attr, trampoline, &payload) != 0) {
    pthread_attr_destroy(&attr);
    fn();  // fall back to the current thread
    return;
  }
  pthread_join(thread, nullptr);
  pthread_attr_destroy(&attr);
  if (payload.error) std::rethrow_exception(payload.error);
}
}  // namespace

JointDerivatives PoseSystem::joint(const Eigen::VectorXd& u, const Design& d) const {
  JointDerivatives out;
  out.gu.setZero(nDofs_);
  out.gp.setZero(d.numParameters());
  runWithLargeStack([&] { jointImpl(u, d, nullptr, out); });
  return out;
}

void PoseSystem::jointImpl(const Eigen::VectorXd& u, const Design& d, const Eigen::VectorXd* v,
                           JointDerivatives& out) const {
  if (v) {
    if (D_ == 3 && twist_) runJoint<3, true, ad::Dual>(u, d, v, out);
    else if (D_ == 3) runJoint<3, false, ad::Dual>(u, d, v, out);
    else if (twist_) runJoint<2, true, ad::Dual>(u, d, v, out);
    else runJoint<2, false, ad::Dual>(u, d, v, out);
    return;
  }
  if (D_ == 3 && twist_) runJoint<3, true, double>(u, d, nullptr, out);
  else if (D_ == 3) runJoint<3, false, double>(u, d, nullptr, out);
  else if (twist_) runJoint<2, true, double>(u, d, nullptr, out);
  else runJoint<2, false, double>(u, d, nullptr, out);
}

JointDerivatives PoseSystem::jointDirectional(const Eigen::VectorXd& u, const Design& d,
                                              const Eigen::VectorXd& v) const {
  JointDerivatives out;
  out.gu.setZero(nDofs_);
  out.gp.setZero(d.numParameters());
  runWithLargeStack([&] { jointImpl(u, d, &v, out); });
  return out;
}
}  // namespace rodmesh
