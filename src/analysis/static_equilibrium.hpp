#pragma once
// Static equilibrium of a cloth system (quasi-static experiments): Newton's method on the
// total potential energy (elastic + load_factor * gravitational) over the free coordinates,
// with the system's own forces and (semi-definite) stiffness, and a backtracking line search.
// Constraints act per coordinate, so a clamp can hold a vertex along one axis and let it
// slide along the others.
#include <vector>

#include "system/cloth.hpp"

namespace weft {

struct StaticSolveOptions {
  int max_iterations = 200;
  /// Converged when the largest out-of-balance force on a free coordinate is below this (N).
  double force_tolerance_N = 1e-9;
  /// Multiplies gravity (load stepping from a flat start).
  double load_factor = 1.0;
};

struct StaticSolveResult {
  bool converged = false;
  int iterations = 0;
  double residual_N = 0;  ///< largest out-of-balance force on a free coordinate
};

/// Moves the free coordinates of `x` (3n) to a static equilibrium of `system` (velocities
/// zero). `fixed_coordinate` (3n entries, 1 = held at its value in `x`) marks the constraints.
/// `force` receives the system's force at the result (internal + gravity; on held
/// coordinates minus the reaction of the constraint).
StaticSolveResult solve_static_equilibrium(ClothSystem& system, VecX& x,
                                           const std::vector<char>& fixed_coordinate,
                                           const StaticSolveOptions& options, VecX* force = nullptr);

}  // namespace weft
