#pragma once
// Aggregation-based algebraic multigrid preconditioner for the block-sparse step matrix
// A = M - cd D - ck K (3x3 blocks, SPD on the free nodes).
//
// Setup (once per pattern and fixed set): the free nodes are grouped into aggregates (a
// root and its neighbours; leftovers join the neighbouring aggregate they are most strongly
// coupled to) along the strong couplings of the first matrix (|A_ij| against the rows'
// largest couplings, so the weak bending couplings across hinges do not merge aggregates),
// or along every coupling of the pattern when set up from the topology alone. The tentative
// prolongator maps each aggregate's coarse node to its members with identity 3x3 blocks
// (the three translations, which dominate the coarse scales where mass outweighs
// stiffness). It is smoothed once with the weighted graph Laplacian L of those couplings,
// P = (I - omega D_L^-1 L) P_tent, so every entry of P is a scalar times I3 and each row of
// P sums to one (translations are kept exactly). The coarse pattern and, per coarse block,
// the list of (fine slot, scalar weight) contributions are precomputed, so the per-step
// Galerkin product A_c = P^T A P is a weighted sum of fine blocks gathered into each coarse
// block and written once (upper coarse blocks only; the lower ones are their transposes).
// Fixed nodes have zero rows in P and are held at zero by the smoothers.
//
// Update (every matrix): coarse operators, inverted diagonal blocks for the smoothers, a
// compact copy of each level's strictly lower blocks between free nodes (LowerBlocks: the
// sweeps read only that half of the symmetric matrix, contiguously, and scatter its
// transposes) and a dense Cholesky factor of the coarsest operator.
//
// Apply: one V-cycle with forward block Gauss-Seidel pre-smoothing and backward block
// Gauss-Seidel post-smoothing (the adjoint of the pre-smoother) and an exact coarsest
// solve, so the preconditioner is a fixed symmetric positive definite operator and can be
// used inside CG.
#include <memory>
#include <vector>

#include "linalg/block_sparse.hpp"

namespace weft {

struct MultigridSettings {
  int max_levels = 8;
  /// Coarsening stops once a level has at most this many nodes; that level is solved with
  /// a dense Cholesky factorization.
  int coarsest_nodes = 48;
  /// omega in P = (I - omega D_L^-1 L) P_tent; 0 gives unsmoothed (piecewise-constant)
  /// aggregation.
  double prolongator_damping = 2.0 / 3.0;
  /// Prolongator weights below this (other than a node's own aggregate) are dropped and
  /// the row renormalized, which keeps the coarse operators sparser.
  double prolongator_drop = 0.0;
  /// Couplings with |A_ij|_F < theta sqrt(max_k |A_ik|_F max_k |A_jk|_F) are weak: they
  /// neither join aggregates nor smooth the prolongator (bending couplings across hinges
  /// are orders of magnitude weaker than membrane ones). Only used by setup from a matrix.
  double strength_threshold = 0.25;
  /// Gauss-Seidel sweeps before and after the coarse correction on each level.
  int smoothing_sweeps = 1;
  bool operator==(const MultigridSettings&) const = default;
};

class AggregationMultigrid {
 public:
  AggregationMultigrid();
  ~AggregationMultigrid();
  AggregationMultigrid(AggregationMultigrid&&) noexcept;
  AggregationMultigrid& operator=(AggregationMultigrid&&) noexcept;

  /// Builds the hierarchy for matrices on `pattern` with the nodes `fixed[i] != 0` held at
  /// zero. `pattern` must outlive this object (or the next setup).
  void setup(const BlockPattern& pattern, const std::vector<char>& fixed,
             const MultigridSettings& settings = {});
  /// As above, but aggregates and smooths the prolongator along the strong couplings of A
  /// (and of the coarse operators derived from it). The hierarchy stays valid for any later
  /// matrix on the same pattern; only its quality depends on A.
  void setup(const BlockMatrix& A, const std::vector<char>& fixed,
             const MultigridSettings& settings = {});
  /// Recomputes the coarse operators and smoother data for a matrix on the setup's pattern.
  void update(const BlockMatrix& A);
  /// z = B r, one V-cycle; z is zero on fixed nodes. Uses only r's free entries.
  void apply(const VecX& r, VecX& z);

  /// y = A x on the free nodes (zero on fixed nodes) for the last updated A, from the
  /// smoother's compact lower copy: half the matrix's bytes of A.multiply.
  void multiply_free(const VecX& x, VecX& y) const;

  bool is_setup() const { return !levels_.empty(); }
  /// Whether setup was done for this pattern (by address and size), fixed set and settings.
  bool matches(const BlockPattern& pattern, const std::vector<char>& fixed,
               const MultigridSettings& settings) const;
  int num_levels() const { return static_cast<int>(levels_.size()); }
  int level_nodes(int level) const;
  /// Operator on `level` >= 1 after update (level 0 is the matrix given to update).
  const BlockMatrix& coarse_matrix(int level) const;
  /// Prolongator from `level` + 1 to `level` as a dense 3n_l x 3n_{l+1} matrix (tests).
  MatX prolongator_dense(int level) const;

 private:
  struct Level;
  void build(const BlockPattern& pattern, const std::vector<char>& fixed,
             const MultigridSettings& settings, const BlockMatrix* A);
  /// Adds the level below `level`: coupling weights, aggregates, the smoothed prolongator,
  /// the coarse pattern and the Galerkin product's terms.
  void build_coarse(int level, bool with_values);
  static void gather_galerkin_terms(Level& fine, const BlockPattern& coarse);
  void galerkin(int level);
  static void set_inverse_diagonal(Level& level);
  void vcycle(int level);
  std::vector<std::unique_ptr<Level>> levels_;
  MultigridSettings settings_;
  const BlockPattern* pattern_ = nullptr;
  int pattern_blocks_ = 0;
  std::vector<char> fixed_;
};

}  // namespace weft
