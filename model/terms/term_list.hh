// The list of energy term blocks: the one place that says which terms a pose's
// energy has. Pattern building, simulation (energy, gradient, Hessian), joint
// design derivatives, their third-order directional products and the adjoint
// product all walk it (PoseSystem::forEachStencil), and the names, counts and
// filters of PoseSystem (termKinds, termCount, TermSet) come from it.
//
// A term block is a struct with
//   static constexpr const char* kName;  // unique: reports, TermSet::named
//   static constexpr bool kLinear;       // linear in the unknowns (no Hessian)
//   static constexpr bool kLoad;         // an external load, scaled by the load factor
//   static constexpr bool kDesign;       // depends on design parameters (beyond held vertices)
//   struct Element { ... };              // what one element needs, built once per pose model
//   static void collect(const TermSetup&, std::vector<Element>&);
//   template <int D, bool TW, class Visit>
//   static void visit(const Element&, const BuildCtx&, Visit&& visit);
// where visit builds the element's LocalStencil (model/terms/stencil.hh) and
// kernel and calls visit(kernel, stencil) exactly once. A block whose
// elements carry internal variables in the state (PoseState::internal) also
// declares
//   static constexpr int kInternal;      // per element
//   static void initial(const Element&, double* internal);
//   static bool update(const Element&, const BuildCtx&, double* internal);
// and its visit takes the element's internal values as a third argument
// (const double*); model/terms/tie.hh is the example. A kernel is a
// callable template <class S, class P> S operator()(const S* x, const P* p)
// over its kNx x locals and kNp p locals, written once for every scalar (the
// AD types of model/ad.hh supply exact first, second and third derivatives).
// docs/model.md "Adding an energy term" walks through model/terms/contact.hh.
#pragma once

#include "model/terms/builtin.hh"
#include "model/terms/contact.hh"
#include "model/terms/tie.hh"

#include <cstddef>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

namespace rodmesh::detail {

template <class... Blocks>
struct TermList {
  static constexpr int kCount = static_cast<int>(sizeof...(Blocks));
  using Elements = std::tuple<std::vector<typename Blocks::Element>...>;
  template <int I>
  using Block = std::tuple_element_t<I, std::tuple<Blocks...>>;
  // Calls f(std::integral_constant<int, I>{}) for every block, in order.
  template <class F>
  static void each(F&& f) {
    eachOf(f, std::make_index_sequence<sizeof...(Blocks)>{});
  }

 private:
  template <class F, std::size_t... I>
  static void eachOf(F& f, std::index_sequence<I...>) {
    (f(std::integral_constant<int, static_cast<int>(I)>{}), ...);
  }
};

// The registered blocks, in evaluation order.
using TermBlocks = TermList<StretchTerm, BendTwistTerm, ClampTerm, ConnectionTerm, GravityTerm, PointForceTerm,
                            MomentTerm, ContactTerm, TieTerm>;

// Internal variables per element of a block (0 unless it declares kInternal).
template <class Block, class = void>
struct InternalCount : std::integral_constant<int, 0> {};
template <class Block>
struct InternalCount<Block, std::void_t<decltype(Block::kInternal)>>
    : std::integral_constant<int, Block::kInternal> {};

// One pose model's elements of every block.
struct TermStorage {
  TermBlocks::Elements elements;
};

}  // namespace rodmesh::detail
