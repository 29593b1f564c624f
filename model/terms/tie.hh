// A term block with an internal variable per element: an elastic-perfectly-
// plastic tie between two vertices (scene: poses[i].ties, docs/formats.md §1).
// Its rest length L is part of the pose's state (PoseState::internal), not of
// the model, because it records what the tie went through (initially the
// vertices' distance in the scene). The tension k (r - L) [N], r = |x_b - x_a|,
// never exceeds the yield force f in magnitude; where it would, the tie
// yields and its rest length follows. The energy of a tie is the incremental
// potential of one plastic step from the state's L (a variational update):
//   E(r) = min over L' of  k/2 (r - L')^2 + f |L' - L|
//        = k/2 s^2                 for |s| <= f/k,   s = r - L,
//          f |s| - f^2 / (2k)      beyond (plastic flow),
// smooth up to the gradient; its second derivative along the tie jumps from
// k to 0 where the tie starts to yield. A solve from a state therefore finds
// the equilibrium after one plastic step from that state's rest lengths
// (exact when each tie stretches monotonically on the way), and update()
// (PoseSystem::advancedInternal) then records the minimizing L' = the return
// mapping L' = r - sign(s) f/k for |s| > f/k: dynamics after every accepted
// time step, or a caller after a static solve.
#pragma once

#include "model/terms/stencil.hh"

#include <cmath>
#include <vector>

namespace rodmesh::detail {

// The kernel: one local vector, e = x_b - x_a; the rest length a constant.
template <int D, bool TW>
struct TieK {
  static constexpr int kNx = D, kNp = 0;
  Vec3 off;
  const Mat32* B;
  double restLength, stiffness, yieldForce;
  template <class S, class P>
  S operator()(const S* x, const P*) const {
    const S stretch = norm(embed<D>(x, off, *B)) - restLength;
    const double s = ad::value(stretch), yieldStretch = yieldForce / stiffness;
    if (std::abs(s) <= yieldStretch) return stretch * stretch * (0.5 * stiffness);
    const S flow = s > 0.0 ? stretch : stretch * -1.0;  // |s|
    return flow * yieldForce - 0.5 * yieldForce * yieldStretch;
  }
};

struct TieTerm {
  static constexpr const char* kName = "tie";
  static constexpr bool kLinear = false, kLoad = false, kDesign = false;
  static constexpr int kInternal = 1;  // the rest length L [m]
  struct Element {
    int a, b;
    double stiffness, yieldForce, initialLength;
  };
  static void collect(const TermSetup& s, std::vector<Element>& out) {
    for (const VertexTie& t : s.pose.ties)
      out.push_back({t.a, t.b, t.stiffness, t.yieldForce, (s.scene.vertices[t.b] - s.scene.vertices[t.a]).norm()});
  }
  static void initial(const Element& el, double* internal) { internal[0] = el.initialLength; }
  template <int D, bool TW, class Visit>
  static void visit(const Element& el, const BuildCtx& c, const double* internal, Visit&& visit) {
    LocalStencil ls;
    const int pa = addVertex(ls, c, el.a), pb = addVertex(ls, c, el.b);
    TieK<D, TW> kern{addEdgeVars(ls, c, el.a, el.b, pa, pb), c.B, internal[0], el.stiffness, el.yieldForce};
    visit(kern, ls);
  }
  // The minimizing L' of the energy above at the current positions (the
  // return mapping); true if L changed.
  static bool update(const Element& el, const BuildCtx& c, double* internal) {
    const double r = ((*c.x)[el.b] - (*c.x)[el.a]).norm();
    const double tension = el.stiffness * (r - internal[0]);
    if (std::abs(tension) <= el.yieldForce) return false;
    internal[0] = r - std::copysign(el.yieldForce / el.stiffness, tension);
    return true;
  }
};

}  // namespace rodmesh::detail
