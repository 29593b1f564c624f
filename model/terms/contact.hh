// Example term block, the one walked through in docs/model.md "Adding an
// energy term": a soft contact penalty that keeps two vertices at least a
// distance d apart (scene: poses[i].contacts, docs/formats.md §1),
//   E = k d / 3 (1 - r / d)^3  for r = |x_b - x_a| < d,   0 otherwise,
// a force of k (1 - r / d)^2 [N] pushing them apart, k at coincidence. C2
// across r = d (energy, force and stiffness vanish there), so Newton and the
// exact Hessians see a smooth energy; its third derivative jumps at r = d.
// This header and one line in model/terms/term_list.hh are the whole energy
// term; its data come from the scene (Pose::contacts, read and written by
// io/scene_reader.cc and io/scene_writer.cc).
#pragma once

#include "model/terms/stencil.hh"

#include <vector>

namespace rodmesh::detail {

// The kernel: one local vector, e = x_b - x_a (D locals, model/terms/stencil.hh
// addEdgeVars), no design locals.
template <int D, bool TW>
struct ContactK {
  static constexpr int kNx = D, kNp = 0;
  Vec3 off;
  const Mat32* B;
  double distance, stiffness;
  template <class S, class P>
  S operator()(const S* x, const P*) const {
    const S r = norm(embed<D>(x, off, *B));
    if (!(ad::value(r) < distance)) return S(0.0);
    const S gap = (r - distance) * (-1.0 / distance);  // 1 - r / d, in (0, 1]
    return gap * gap * gap * (stiffness * distance / 3.0);
  }
};

struct ContactTerm {
  static constexpr const char* kName = "contact";
  static constexpr bool kLinear = false, kLoad = false, kDesign = false;
  struct Element {
    int a, b;
    double distance, stiffness;
  };
  static void collect(const TermSetup& s, std::vector<Element>& out) {
    for (const VertexContact& c : s.pose.contacts) out.push_back({c.a, c.b, c.distance, c.stiffness});
  }
  template <int D, bool TW, class Visit>
  static void visit(const Element& el, const BuildCtx& c, Visit&& visit) {
    LocalStencil ls;
    const int pa = addVertex(ls, c, el.a), pb = addVertex(ls, c, el.b);
    ContactK<D, TW> kern{addEdgeVars(ls, c, el.a, el.b, pa, pb), c.B, el.distance, el.stiffness};
    visit(kern, ls);
  }
};

}  // namespace rodmesh::detail
