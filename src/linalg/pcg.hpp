#pragma once
// Preconditioned conjugate gradient on a BlockMatrix with per-node constraint filters
// (Baraff-Witkin style): a filtered node's unknowns are held at zero, so the system
// restricted to the free nodes stays symmetric positive definite.
#include "linalg/block_sparse.hpp"
#include "linalg/multigrid.hpp"
#include "linalg/ssor.hpp"
#include "weft/settings.hpp"

namespace weft {


struct PcgSettings {
  double relative_tolerance = 1e-6;  ///< stop when |r| <= tol |b| (filtered)
  int max_iterations = 1000;
  Preconditioner preconditioner = Preconditioner::kBlockJacobi;
  MultigridSettings multigrid{};     ///< used by kMultigrid when the hierarchy is (re)built
  /// Relaxation w in (0, 2) of kSsor; 0 chooses it from the number of free nodes N:
  /// w = 2 / (1 + 3.5 N^-1/4) (ssor_relaxation_for).
  double ssor_omega = 0.0;
  /// kSsor: the node order its solves start from (a permutation of the nodes, neighbours
  /// close together: see SsorOperator); the nodes' numbering when null.
  const std::vector<int>* node_order = nullptr;
  /// kSsor: run the iterations in single precision (SsorOperatorT<float>, eight lanes), with
  /// the solution and the true residual in double precision: CG restarts from the true
  /// residual whenever a check finds it above the tolerance, and finishes in double precision
  /// should a restart not halve it. The stopping rule is the same.
  bool ssor_single_precision = false;
  /// kSsor: store every block whole (SsorOperatorT::assign's all_whole), for systems with
  /// contact constraints.
  bool ssor_whole_blocks = false;
};

struct PcgResult {
  int iterations = 0;
  double relative_residual = 0.0;
  bool converged = false;
};

/// Scratch vectors kept between solves so a step does not allocate.
struct PcgWorkspace {
  VecX r, z, p, q, b;
  std::vector<Mat3> inverse_diagonal;  ///< zero on fixed nodes
  std::vector<int> fixed_nodes;        ///< indices of the fixed nodes
  /// Multigrid hierarchy; rebuilt when the pattern, node count or fixed set changes, its
  /// operators updated every solve.
  AggregationMultigrid multigrid;
  /// kSsor: the SSOR operators on a copy of A, and vectors with 4 doubles per node.
  SsorOperator ssor;
  VecX t, w, x4, b4;
  /// kSsor: |r| / |r^| (true over transformed residual, r^ = (B + L)^-1 r) of the last solve's
  /// final true residual (single precision: measured with one lower solve; double precision: at
  /// its last check), from which the next solve predicts when to check; 0: none yet.
  double ssor_residual_ratio = 0;
  /// kSsor in single precision: the operator, its vectors, and node-ordered residual and
  /// correction in double precision.
  SsorOperatorT<float> ssor_single;
  Eigen::VectorXf fr, fz, fp, fq, ft, fw, fdx;
  VecX residual, correction;
  /// Single-precision solves that finished in double precision (a restart did not halve the
  /// true residual, or the curvature broke down).
  long ssor_single_fallbacks = 0;
};

/// The automatic SSOR relaxation for N free nodes, 2 / (1 + 3.5 N^-1/4): 1.24 at 33x33, 1.39
/// at 65x65, 1.53 at 129x129. The relaxation that needs the fewest CG iterations on the cloth
/// grows with the mesh (like the optimal SOR relaxation 2 / (1 + O(h))); this fit follows the
/// best measured values, about 1.2, 1.4 and 1.55 at those sizes (docs/performance.md).
double ssor_relaxation_for(int free_nodes);

/// Solves A x = b for the nodes with fixed[i] == 0; x_i = 0 on fixed nodes.
/// `x` holds the initial guess on entry. Preconditioner: settings.preconditioner.
PcgResult solve_pcg(const BlockMatrix& A, const VecX& b, const std::vector<char>& fixed,
                    const PcgSettings& settings, VecX& x, PcgWorkspace& ws);

}  // namespace weft
