// PoseSystem: the total potential energy of one pose as a function of its
// unknowns, with exact gradient, sparse Hessian, design derivatives and
// third-order directional derivatives.
//
// Unknowns of a pose (the vector u), in this order:
//   1. for every free vertex (not fixed or clamped), in vertex order, its
//      position: 3 coordinates x, y, z [m], or, for a planar scene, 2
//      coordinates along EffectSet::planeBasis from planeOrigin [m];
//   2. if twist is simulated, one twist angle theta per edge, in edge order [rad]
//      (material frame relative to the reference frame, theta = 0 at rest).
// Held vertices sit at their prescribed positions, interpolated from the rest
// position by the load factor.
//
// Design parameters (the vector p), in this order:
//   1. rest positions, 3 per vertex [m];
//   2. radii [r_t, r_n], 2 per vertex [m].
//
// Energy terms: the blocks registered in model/terms/term_list.hh (stretch
// per edge, bend+twist per interior vertex, clamp coupling per (clamped
// vertex, incident edge), connection coupling per connection (not clamped),
// gravity per edge, point forces per loaded vertex, twisting moments per
// loaded free end, contact penalties per vertex pair). Each is a kernel
// templated on the scalar type and differentiated by forward-mode AD
// (model/ad.hh), so the Hessian and the third derivatives are exact.
#pragma once

#include "model/design.hh"
#include "model/effects.hh"
#include "model/network.hh"
#include "model/scene.hh"

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace rodmesh {

namespace detail {
struct BuildCtx;
struct TermStorage;
}

// A set of energy term kinds (the blocks of model/terms/term_list.hh, by
// index in PoseSystem::termKinds()): every evaluation includes the terms of
// one set, All by default (tests and diagnostics evaluate one kind alone).
class TermSet {
 public:
  static const TermSet All;
  static TermSet only(int kind) { return TermSet(1u << kind); }
  // The kind of that name; throws std::invalid_argument listing the names.
  static TermSet named(const std::string& name);
  // The external loads (gravity, point forces, moments: kinds whose `load` is set).
  static TermSet loads();
  bool has(int kind) const { return ((mask_ >> kind) & 1u) != 0; }
  TermSet operator|(TermSet o) const { return TermSet(mask_ | o.mask_); }
  bool operator==(TermSet o) const { return mask_ == o.mask_; }
  bool operator!=(TermSet o) const { return mask_ != o.mask_; }

 private:
  explicit constexpr TermSet(unsigned mask) : mask_(mask) {}
  unsigned mask_;
};
inline const TermSet TermSet::All{~0u};

// One kind of energy term, as registered (model/terms/term_list.hh).
struct TermKind {
  const char* name;
  bool linear;  // linear in the unknowns: no Hessian, no third derivatives
  bool load;    // an external load, scaled by the load factor
  bool design;  // depends on design parameters (beyond the rest positions of held vertices)
  int internal = 0;  // internal variables per element, carried in PoseState::internal
};

// Derivatives of a pose's energy E(u, p) w.r.t. the joint variables (u, p),
// p in the Design::toVector() layout, in fixed sparsity patterns built once
// per PoseSystem (PoseSystem::jointPattern): values change, structure never.
//   energy, gu = dE/du (= F, the equilibrium residual), gp = dE/dp;
//   Huu = d2E/du2 = dF/du, both triangles stored (full rows);
//   Hup = d2E/du dp = dF/dp (n x P);
//   Hpp = d2E/dp2, lower triangle.
// With a direction v (in u-space) the same quantities differentiated along v
// (jointDirectional): D_v energy = gu.v, D_v gu = Huu v, and D_v of the three
// Hessian blocks, i.e. third derivatives of E contracted with v. With v = the
// multipliers lambda of the equilibrium constraints F = 0, the Hessian blocks
// are those of lambda^T F, the constraint part of a Lagrangian's Hessian.
struct JointDerivatives {
  double energy = 0.0;
  Eigen::VectorXd gu, gp;
  Eigen::SparseMatrix<double> Huu, Hup, Hpp;
};

// The state of one pose that a solve starts from and returns: unknowns,
// reference-frame charts (the coordinates the twists are measured in) and
// the load factor they are in equilibrium at.
struct Charts {
  std::vector<Vec3> tangent, director;  // per edge
};
struct PoseState {
  Eigen::VectorXd u;
  Charts charts;
  double loadFactor = 0.0;
  // Internal variables of the term blocks that have them (a plastic tie's
  // rest length, model/terms/tie.hh), block by block in term-list order,
  // element by element (PoseSystem::numInternal). Evaluations read them as
  // constants; minimizers carry them unchanged; PoseSystem::advancedInternal
  // applies the blocks' update rules. Empty: every block's initial values.
  Eigen::VectorXd internal;
};

// A pose model: built once from a scene, its effects and a pose index, and
// never changed afterwards. Every evaluation is const and takes the state it
// evaluates at (unknowns, charts, load factor) and the design explicitly, and
// writes into outputs the caller owns, so that one model serves any number of
// states, solvers and threads at once.
class PoseSystem {
 public:
  PoseSystem(const Scene& scene, const RodNetwork& network, const EffectSet& effects, int poseIndex);

  int numDofs() const { return nDofs_; }
  int numVertexDofs() const { return nVertexDofs_; }
  int dofsPerVertex() const { return D_; }
  bool hasTwist() const { return twist_; }
  int poseIndex() const { return pose_; }
  const EffectSet& effects() const { return fx_; }
  const std::vector<int>& vertexDof() const { return vertexDof_; }  // first unknown of a vertex, -1 if held
  int thetaDof(int edge) const { return twist_ ? nVertexDofs_ + edge : -1; }

  // Which energy terms an evaluation includes (TermSet). Patterns always
  // cover every term.
  using Terms = TermSet;
  // The registered kinds of term, in evaluation order, and how many
  // elements (stencils) of a kind this pose has.
  static const std::vector<TermKind>& termKinds();
  static int termKindIndex(const std::string& name);  // -1 if none has that name
  int termCount(int kind) const;

  // Unknowns of the rest configuration (held vertices are not unknowns).
  Eigen::VectorXd restDofs(const Design& d) const;
  // Reference-frame charts (one per edge): an edge's reference director is the
  // chart director transported from the chart tangent to its current tangent,
  // and its twist unknown is the material frame's angle from it. The energy is
  // smooth except where an edge points against its chart tangent. restCharts:
  // the rest frames of a design (theta = 0 at rest).
  using Charts = rodmesh::Charts;
  Charts restCharts(const Design& d) const;
  // The rest state of a design: rest unknowns, its rest charts, load factor 0
  // (the load factor scales point forces, gravity and the prescribed
  // displacements of held vertices; 1 is the pose as given).
  PoseState restState(const Design& d) const;
  // The state of unknowns u at a load factor, twists measured from the
  // design's rest frames.
  PoseState withRestCharts(const Eigen::VectorXd& u, const Design& d, double loadFactor = 1.0) const {
    return PoseState{u, restCharts(d), loadFactor, {}};
  }

  // Internal variables (PoseState::internal): how many this pose has, their
  // initial values, and the state with every block's update rule applied at
  // the state's positions (e.g. a tie's return mapping to its yield force),
  // or nothing when no value changes. Solvers call it between accepted
  // steps: after a time step, after a static solve (solver/newton.cc).
  int numInternal() const { return static_cast<int>(initialInternal_.size()); }
  const Eigen::VectorXd& initialInternal() const { return initialInternal_; }
  std::optional<PoseState> advancedInternal(const PoseState& s, const Design& d) const;
  // The state with every chart that has turned more than acos(cosLimit) from
  // its edge's current tangent moved to the current frame, or nothing when no
  // chart moves. The material frames, the energy and the equilibria are those
  // of the given state (a change of coordinates of the twist unknowns).
  std::optional<PoseState> reanchored(const PoseState& s, const Design& d, double cosLimit = -0.25) const;

  // Full positions (held vertices at their prescribed positions under design
  // d and the state's load factor) and edge twist angles (zeros when twist is
  // not simulated). twists() reports the unknown itself; materialTwists() the
  // angle of each edge's material frame from d's rest frame transported to the
  // current tangent (chart-independent).
  std::vector<Vec3> positions(const PoseState& s, const Design& d) const;
  Eigen::VectorXd twists(const Eigen::VectorXd& u) const;
  Eigen::VectorXd materialTwists(const PoseState& s, const Design& d) const;
  // Held vertices: whether v is held, and d(position of v)/d(rest position of
  // v): 1 when held at its rest position under the design (clamped, or fixed
  // without a position), 1 - load factor when fixed at an explicit position.
  // For a vertex on a turning handle (positions(), model/pose_system.cc) the
  // latter holds at rest and at the full load, where the design derivatives
  // are taken (the optimizers' equilibria), not in between.
  bool isHeld(int v) const { return held_[v]; }
  double heldDesignCoefficient(int v, double loadFactor) const;
  // Unknowns from full positions and twists (inverse of the above).
  Eigen::VectorXd dofsFrom(const std::vector<Vec3>& x, const Eigen::VectorXd& theta) const;

  // The Hessian's fixed sparsity pattern w.r.t. u (lower triangle and the full
  // diagonal; values zero), built once with the model.
  const Eigen::SparseMatrix<double>& hessianPattern() const { return hessianPattern_; }
  // Total energy at a state; with `gradient`, dE/du (resized to numDofs());
  // with `hessian`, d2E/du2 (lower triangle) in hessianPattern(): a matrix
  // that does not have that pattern yet is given it once, after which only
  // its values are written.
  double evaluate(const PoseState& s, const Design& d, Eigen::VectorXd* gradient,
                  Eigen::SparseMatrix<double>* hessian, Terms terms = Terms::All) const;
  double energy(const PoseState& s, const Design& d, Terms terms = Terms::All) const {
    return evaluate(s, d, nullptr, nullptr, terms);
  }

  // Joint derivatives w.r.t. (u, p); see JointDerivatives. evaluateJoint
  // fills `out` in the fixed patterns (copied into `out` on first use, then
  // only values are written); with a direction v, the directional derivatives.
  void evaluateJoint(const PoseState& s, const Design& d, JointDerivatives& out, const Eigen::VectorXd* v = nullptr,
                     Terms terms = Terms::All) const;
  JointDerivatives joint(const PoseState& s, const Design& d, Terms terms = Terms::All) const;
  JointDerivatives jointDirectional(const PoseState& s, const Design& d, const Eigen::VectorXd& v,
                                    Terms terms = Terms::All) const;
  // The fixed patterns (values zero): Huu full, Hup, Hpp lower. Built on
  // first use (once, thread-safe).
  const JointDerivatives& jointPattern() const;
  // First-order products for adjoint gradients, without second derivatives
  // of the design: (dF/dp)^T lambda (size P) and, if asked, (dF/du) lambda.
  Eigen::VectorXd designForceProduct(const PoseState& s, const Design& d, const Eigen::VectorXd& lambda,
                                     Eigen::VectorXd* hessianTimesLambda = nullptr, Terms terms = Terms::All) const;

  // Length that turns moments into forces in residual norms: mean rest edge length.
  double momentArm() const { return momentArm_; }
  // Force below which residuals are round-off (N): 1e3 eps E A_max times the
  // ratio of the scene's extent to its shortest edge.
  double roundoffForce(const Design& d) const;
  // Residual vector in newtons: position components as they are, twist
  // components divided by momentArm().
  Eigen::VectorXd forceResidual(const Eigen::VectorXd& gradient) const;


 private:
  struct Stencil {
    int offset = 0;  // into stencilDofs_ / slot tables
    int size = 0;
  };

  void buildPattern();
  void buildJointPattern() const;
  std::vector<double> heldCoefficients(double loadFactor) const;
  // The internal variables an evaluation of s reads: s.internal, or the
  // initial values when it is empty; any other size is an error.
  const double* internalOf(const PoseState& s) const;

  // Walks every element of the included blocks (model/terms/term_list.hh)
  // in order and calls visit(kernel, stencil, index of the stencil).
  template <int D, bool TW, class Visit>
  void forEachStencil(const detail::BuildCtx& ctx, Visit&& visit) const;
  // The evaluation context of a state (positions, twists, held-vertex
  // coefficients owned by the caller).
  detail::BuildCtx context(const std::vector<Vec3>& x, const Eigen::VectorXd& theta, const Design& d,
                           const std::vector<double>* heldCoef, const Charts& charts, double loadFactor,
                           Terms terms) const;
  template <class F>
  void withLayout(F&& f) const;
  template <int D, bool TW, class Out>
  void runSim(const PoseState& s, const Design& d, Terms terms, Out& out) const;
  template <int D, bool TW, class T>
  void runJoint(const PoseState& s, const Design& d, Terms terms, const Eigen::VectorXd* v,
                JointDerivatives& out) const;
  template <int D, bool TW>
  void runProduct(const PoseState& s, const Design& d, Terms terms, const Eigen::VectorXd& lambda,
                  Eigen::VectorXd& outP, Eigen::VectorXd* outU) const;

  const Scene& scene_;
  const RodNetwork& net_;
  EffectSet fx_;
  int pose_;
  int D_ = 3;
  bool twist_ = true;
  int nVertexDofs_ = 0, nDofs_ = 0;
  double momentArm_ = 1.0;

  std::vector<int> vertexDof_;
  std::vector<bool> held_;
  std::vector<bool> heldExplicit_;  // held at an explicit position (not at rest)
  std::vector<Vec3> heldTarget_;  // explicit prescribed position at load factor 1
  // Handles: groups of vertices held at explicit positions and joined by
  // edges (buildHandles); each moves along the screw of its least-squares
  // rigid motion from the design's rest positions to the prescribed ones
  // (heldPositions).
  std::vector<std::vector<int>> handles_;
  void buildHandles();
  // Positions of the held vertices at a load factor (x[v] for held v; other
  // entries untouched).
  void heldPositions(const Design& d, double loadFactor, std::vector<Vec3>& x) const;

  // Every block's elements (model/terms/term_list.hh), built once.
  std::shared_ptr<const detail::TermStorage> terms_;
  // Internal variables: first index of each block's, and their initial values.
  std::vector<int> internalOffset_;
  Eigen::VectorXd initialInternal_;

  // Sparsity: per stencil (in the order of forEachStencil) its unknowns and
  // the Hessian value slot of each (i >= j) pair.
  std::vector<int> stencilDofs_;
  std::vector<int> stencilSlots_;
  std::vector<Stencil> stencils_;
  Eigen::SparseMatrix<double> hessianPattern_;

  // Joint patterns (built once, on first use, under jointOnce_): per stencil, for
  // each lower-triangle pair (i >= j) of its JointMap's globals, the value
  // slot it adds to (block << 28 | index into the values of Huu (its lower
  // triangle), Hup or Hpp; -1 for none); Huu's upper triangle is then
  // copied from the lower one: (upper index, lower index) pairs.
  mutable std::once_flag jointOnce_;
  mutable JointDerivatives jointPattern_;
  mutable std::vector<int> jointSlots_;
  mutable std::vector<Stencil> jointStencils_;
  mutable std::vector<std::pair<int, int>> jointUpperFromLower_;
};

}  // namespace rodmesh
