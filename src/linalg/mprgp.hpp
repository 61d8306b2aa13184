#pragma once
// A bound-constrained solve: minimises 1/2 x^T A x - b^T x (A symmetric positive definite, in
// 3x3 blocks) subject to per-node lower bounds along unit directions, n . x_i >= l, at most two
// per node with orthogonal directions, and nodes held at given values. It is Dostal's modified
// proportioning with reduced gradient projections (MPRGP), preconditioned in the face by the
// nodes' diagonal blocks: conjugate gradient steps on the bounds that are active, a step to
// the first bound met where a step would leave the feasible set, then (expansion) the whole
// step with every bound it crosses met, or where that does not lower the energy a projected
// gradient step, and a step that frees bounds (proportioning) where the part of the
// gradient that would leave them outweighs the free part. Its answer satisfies the
// conditions of the problem's minimum (docs/collisions.md, "Contacts as bounds"): the residual
// b - A x vanishes along every free direction and points into every active bound (a force
// pushing the node off its surface, never pulling).
#include <vector>

#include "linalg/block_sparse.hpp"

namespace weft {

/// n . x_node >= lower, n a unit vector. A node with two bounds has orthogonal directions.
struct NodeBound {
  int node = 0;
  Vec3 normal = Vec3::UnitY();
  double lower = 0;
};

struct BoundedSolveSettings {
  double relative_tolerance = 1e-6;  ///< stop when the projected residual <= tol |b| (free nodes)
  int max_iterations = 1000;         ///< products with A, all steps together
  /// Gamma of the proportioning test: bounds are freed when |chopped residual| > Gamma times
  /// the (preconditioned) free residual's size.
  double proportioning = 1.0;
  /// Where a CG step would cross bounds, try the whole step with every bound it crosses met
  /// (the step projected onto the feasible set) before the projected gradient step, and keep
  /// it where it lowers the energy below the first bound's point.
  bool projected_cg_step = true;
};

struct BoundedSolveResult {
  int iterations = 0;      ///< products with A
  int expansions = 0;      ///< steps that met a bound and projected
  int proportionings = 0;  ///< steps that freed bounds
  double relative_residual = 0;
  bool converged = false;
};

/// Scratch kept between solves.
struct BoundedSolveWorkspace {
  VecX r, z, p, q, d;
  std::vector<int> slot;            ///< per node: its first bound's index in the list, or -1
  std::vector<int> second;          ///< per bound: the node's other bound's index, or -1
  std::vector<char> active;         ///< per bound
  std::vector<Mat3> inverse_free;   ///< per node: the diagonal block's inverse (unbounded nodes)
  std::vector<double> scale;        ///< per node: the diagonal block's mean diagonal
  VecX x_save, r_save;              ///< x and r at the first bound, while a projected CG step is tried
  std::vector<char> active_save;
};

/// Solves the bounded problem. `x` holds the initial guess on entry (projected onto the
/// bounds); nodes with held[i] != 0 keep x_i as given. On return `active` (one entry per
/// bound) says which bounds hold the answer (n . x_i = lower).
BoundedSolveResult solve_bounded(const BlockMatrix& A, const VecX& b, const std::vector<char>& held,
                                 const std::vector<NodeBound>& bounds, const BoundedSolveSettings& settings, VecX& x,
                                 BoundedSolveWorkspace& ws, std::vector<char>& active);

}  // namespace weft
