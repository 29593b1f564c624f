// DesignSpace: the control-point parameterization of a rod mesh's design
// (Pérez et al. 2015 §4.1 and §4.3; docs/formats.md §4).
//
// Control points. Every rod carries n = scene.design.controlPointsPerRod >= 2
// control points at arc fractions j/(n-1), j = 0..n-1, where the arc fraction
// s of a vertex is its arc length along the rod divided by the rod's length,
// both measured once on the SCENE's rest vertices (so every map below is
// linear and constant). The two end control points sit on the rod's end
// vertices and are shared by every rod ending there (one per rod-end vertex,
// connection or free end); the n-2 interior ones belong to their rod.
// Control point order: first one per distinct rod-end vertex in increasing
// vertex order, then the interior ones rod by rod, j = 1..n-2.
//
// Interpolation. Along rod r, a vertex at arc fraction s gets
//   value(s) = sum_j B_{j,n-1}(s) c_{r,j}      (a Bézier curve in s),
// with Bernstein weights B >= 0 summing to 1 (values stay within the range of
// the control values, so radius bounds on controls bound every vertex). The
// control abscissae j/(n-1) are the Greville abscissae of degree n-1, so
// functions linear in arc length are reproduced exactly, and the end vertices
// take the end control values exactly. W (V x C) holds these weights; a
// rod-end vertex's row is the unit vector of its shared control point.
//
// Levels (multiresolution, §4.3). Level L interpolates with degree d_L per
// rod: the distinct values of {1, min(2, n-1), n-1}, so numLevels() is 1 for
// n = 2, 2 for n = 3 and 3 for n >= 4; the finest level is numLevels()-1 and
// has d = n-1. A level's "nodes" are its free values: the shared end nodes
// (same order as the shared end control points), then per rod d_L-1 interior
// nodes at arc fractions k/d_L, rod by rod. At the finest level the nodes ARE
// the control points. Control values = E_L * nodes, with E_L (C x N_L) the
// exact Bézier degree-elevation matrix from d_L to n-1 (entries >= 0, rows
// summing to 1); levelTransfer(L, L') elevates level-L nodes to level L' >= L
// exactly, so a design at level L is exactly representable at every finer level.
//
// Free-variable vector z of a DesignPhase at level L (N = N_L nodes):
//   1. if phase.radii: radii nodes [r_t, r_n], 2 per node, node-major [m];
//   2. if phase.restShape: rest-displacement nodes, node-major [m]: 3 per node
//      [dx, dy, dz], or for a planar scene (EffectSet::planar) 2 per node, the
//      components along the columns of EffectSet::planeBasis.
// toDesign maps control values to the per-vertex Design (model/design.hh):
//   radii_v = (W * radii controls)_v, set to the bound it passes by rounding
//   only (relative 1e-12), so that controls within the bounds give vertex
//   radii within them to the last digit,
//   restPositions_v = scene.vertices[v] + P (W * displacement controls)_v,
// with P = B B^T (B = planeBasis) for a planar scene and P = I otherwise.
// The composite z -> Design::toVector() is affine (up to that rounding);
// jacobian() is exact.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <string>
#include <vector>

#include "model/design.hh"
#include "model/effects.hh"
#include "model/scene.hh"

namespace rodmesh {

// One control point of the design.
struct ControlPoint {
  int rod = -1;              // owning rod; -1 for a shared end control point
  int vertex = -1;           // scene vertex for a shared end; -1 for an interior one
  double arcFraction = 0.0;  // j/(n-1) along `rod`; 0 for a shared end
};

// Which parameters are free, and at which level (0 = linear along rods, ...,
// numLevels()-1 = all control points).
struct DesignPhase {
  bool radii = false;
  bool restShape = false;
  int level = 0;
};

// The full design state in control form.
struct ControlValues {
  Eigen::MatrixXd radii;         // C x 2: [r_t, r_n] per control point [m]
  Eigen::MatrixXd displacement;  // C x 3: rest-shape displacement per control point [m] (3D even when planar)
};

class DesignSpace {
 public:
  // Uses scene.rods, scene.vertices, scene.radii and scene.design
  // (controlPointsPerRod, radius bounds); effects.planar and planeBasis.
  // Throws std::invalid_argument if controlPointsPerRod < 2.
  DesignSpace(const Scene& scene, const EffectSet& effects);

  // --- Control points and interpolation --------------------------------
  int numControlPoints() const { return static_cast<int>(controlPoints_.size()); }
  int numSharedEnds() const { return numEnds_; }
  int numRods() const { return static_cast<int>(rodVertices_.size()); }
  int numVertices() const { return static_cast<int>(sceneVertices_.size()); }
  int controlPointsPerRod() const { return n_; }
  bool planar() const { return planar_; }
  const std::vector<ControlPoint>& controlPoints() const { return controlPoints_; }
  // Control point index of rod r's j-th control point, j = 0..n-1.
  int controlIndex(int rod, int j) const { return nodeIndex(numLevels() - 1, rod, j); }
  // Arc fraction s in [0, 1] of every vertex of rod r, in the rod's vertex order.
  const std::vector<double>& rodArcFractions(int rod) const { return rodArcFractions_[rod]; }
  // W: V x C interpolation weights, vertex values = W * control values.
  const Eigen::SparseMatrix<double, Eigen::RowMajor>& interpolation() const { return W_; }
  // Control values (C x k) whose interpolation best fits a per-vertex field
  // (V x k), in the least-squares sense (the normal equations of W, the
  // fit of least norm where controls reach no vertex); false when the fit
  // fails or is not finite.
  bool fitControls(const Eigen::MatrixXd& vertexField, Eigen::MatrixXd& controls) const;

  // --- Levels ------------------------------------------------------------
  int numLevels() const { return static_cast<int>(degrees_.size()); }
  int degree(int level) const;    // d_L
  int numNodes(int level) const;  // N_L = numSharedEnds() + numRods() * (d_L - 1)
  // Node index of rod r's k-th Bézier coefficient at `level`, k = 0..d_L
  // (k = 0 and k = d_L are the shared end nodes of the rod's first/last vertex).
  int nodeIndex(int level, int rod, int k) const;
  // E_L: C x N_L, control values = E_L * level-L nodes.
  Eigen::SparseMatrix<double> levelMatrix(int level) const { return levelTransfer(level, numLevels() - 1); }
  // N_to x N_from exact degree elevation, level-`to` nodes = T * level-`from`
  // nodes (from <= to). Non-negative, rows sum to 1.
  Eigen::SparseMatrix<double> levelTransfer(int from, int to) const;

  // --- Phases and free variables ----------------------------------------
  int numFree(const DesignPhase& phase) const;
  // Radii controls reproducing the scene's radii: shared ends take the radius
  // at their vertex; a rod's interior controls are the linear-in-arc-length
  // interpolation of its end values plus the minimum-norm least-squares
  // correction fitting the rod's interior vertex radii, clipped to the range
  // of the rod's vertex radii. For radii uniform (or linear in arc length)
  // along each rod the control values are exact, so the vertex radii are the
  // scene's to round-off (Bernstein weights sum to 1 only to round-off).
  // Zero displacement. scene.radii must have one pair per vertex.
  ControlValues initialControls(const Scene& scene) const;
  // z for these controls: exact when they are representable at the phase's
  // level; otherwise the least-squares fit of the control values
  // (min |E_L nodes - controls|), not clipped to bounds. For a planar scene
  // the displacement is projected onto the plane.
  Eigen::VectorXd pack(const DesignPhase& phase, const ControlValues& controls) const;
  // Controls with the phase's free parts from z (all control points of that
  // part replaced by E_L * nodes) and the other parts copied from `base`.
  ControlValues unpack(const DesignPhase& phase, const Eigen::VectorXd& z, const ControlValues& base) const;
  Design toDesign(const ControlValues& controls) const;
  // Exact constant Jacobian d Design::toVector() / dz: 5V x numFree(phase).
  // Independent of z and of the base controls; build once per phase.
  Eigen::SparseMatrix<double> jacobian(const DesignPhase& phase) const;
  // Bounds on z: radius entries in [radiusLower(), radiusUpper()],
  // displacement entries unbounded (+-infinity).
  void bounds(const DesignPhase& phase, Eigen::VectorXd& lower, Eigen::VectorXd& upper) const;
  // Radius bounds in use: scene.design's when hasRadiusBounds, else
  // [0.1 * smallest, 10 * largest] scene radius component.
  double radiusLower() const { return radiusMin_; }
  double radiusUpper() const { return radiusMax_; }

  // One line for progress output: control points and nodes per level.
  std::string describe() const;

 private:
  int displacementDim() const { return planar_ ? 2 : 3; }
  void checkLevel(int level) const;
  // V x N_L: vertex values = M_L * level-L nodes (W * E_L).
  Eigen::SparseMatrix<double> vertexMatrix(int level) const;

  int n_ = 2;                                  // control points per rod
  int numEnds_ = 0;                            // distinct rod-end vertices
  std::vector<int> degrees_;                   // d_L per distinct level, increasing
  std::vector<int> endNode_;                   // per vertex: shared end index, or -1
  std::vector<std::vector<int>> rodVertices_;  // scene rods
  std::vector<std::vector<double>> rodArcFractions_;
  std::vector<ControlPoint> controlPoints_;
  Eigen::SparseMatrix<double, Eigen::RowMajor> W_;  // V x C
  std::vector<Vec3> sceneVertices_;
  bool planar_ = false;
  Eigen::Matrix<double, 3, 2> planeBasis_ = Eigen::Matrix<double, 3, 2>::Zero();
  double radiusMin_ = 0.0, radiusMax_ = 0.0;
};

}  // namespace rodmesh
