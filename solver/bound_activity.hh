// How much the radius bounds hold a design back (docs/optimization.md,
// "Radius bounds that hold the design").
//
// An optimizer that ends with radii pressed against their bounds has met
// the design space's limit, not the targets' one: a designer who can print
// thinner or thicker rods would do better. This reports which control radii
// are held there and, to first order, what widening the bounds would gain.
//
// A control radius value z_i (one of r_t, r_n of one control point) is held
// at the lower bound when it lies within kAtBoundFraction of the bound range
// from it and the objective's gradient df/dz_i > 0 (the objective falls as
// z_i falls); at the upper bound likewise with df/dz_i < 0. Moving a bound
// moves the values it holds with it, so to first order
//   d ln f / d ln r_min = r_min * sum_{i held at r_min} df/dz_i / f   (> 0),
//   d ln f / d ln r_max = r_max * sum_{i held at r_max} df/dz_i / f   (< 0):
// a minimum radius 1% lower changes f by about -(d ln f / d ln r_min) %.
// The gradient is the reduced (adjoint) one at the design's equilibria, as
// the reduced method computes it (solver/design_optimizer.hh).
#pragma once

#include <string>
#include <vector>

#include "model/design_space.hh"
#include "model/scene_model.hh"
#include "solver/newton.hh"

namespace rodmesh {

class TargetObjective;

// Within this fraction of the bound range from a bound, a value is at it
// (an interior-point optimizer stops a little inside its bounds).
constexpr double kAtBoundFraction = 0.01;

struct RadiusBoundActivity {
  bool computed = false;  // false: radii not free, no equilibria, or the gradient failed
  int total = 0;          // control radius values (2 per control point)
  int atLower = 0, atUpper = 0;
  double lowerBound = 0.0, upperBound = 0.0;  // m
  // d ln f / d ln r_min and d ln f / d ln r_max (first order; 0 when no
  // value is held at that bound or f = 0).
  double lowerElasticity = 0.0, upperElasticity = 0.0;
  // Per control radius value, in the order of the finest level's free
  // variables (DesignSpace, radii node-major [r_t, r_n]): -1 held at the
  // lower bound, +1 at the upper, 0 neither.
  std::vector<signed char> held;
};

// The activity at `controls`, whose equilibria `states` (one per pose, at
// full load) warm-start the gradient's solves. Never throws.
RadiusBoundActivity radiusBoundActivity(const SceneModel& model, const DesignSpace& space,
                                        const TargetObjective& objective, const ControlValues& controls,
                                        const std::vector<PoseState>& states, const NewtonOptions& newton);

// One clause for a run's message, e.g. "47 of 196 control radii are held at
// a radius bound (29 at 1 mm, 18 at 5 mm): to first order the objective falls
// by 0.31% per 1% lower minimum radius and by 0.52% per 1% higher maximum";
// empty when nothing is held or the activity was not computed.
std::string describeBoundActivity(const RadiusBoundActivity& a);

}  // namespace rodmesh
