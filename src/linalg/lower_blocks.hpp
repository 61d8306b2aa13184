#pragma once
// The solver's working copy of a symmetric block matrix restricted to its free nodes: the
// diagonal blocks and, by rows, the strictly lower blocks between free nodes, contiguous.
// Products and Gauss-Seidel sweeps read this half of the matrix and apply the upper half as
// transposes. A lower block that is a multiple of the identity (on a cloth, the bending
// couplings across hinges that no membrane shares: about half of the off-diagonal slots) is
// stored as one number and applied with 3 multiplications instead of 9.
#include <vector>

#include "linalg/block_sparse.hpp"

namespace weft {

class LowerBlocks {
 public:
  /// Chooses the layout for matrices on `pattern` without the nodes `fixed[i] != 0`. A lower
  /// slot is stored as a scalar when `sample`'s block there is an exact multiple of I3 (with
  /// no sample, every block is stored whole). `pattern` must outlive this object.
  void build(const BlockPattern& pattern, const std::vector<char>& fixed, const BlockMatrix* sample);
  /// Whether build was called for this pattern (address and size) and fixed set.
  bool matches(const BlockPattern& pattern, const std::vector<char>& fixed) const;
  /// Copies A's values (A on the built pattern). Returns false, leaving the copy unusable, when
  /// a slot stored as a scalar holds a block that is not a multiple of I3; build from A then.
  bool fill(const BlockMatrix& A);
  /// build (when the pattern or fixed set changed, or the layout no longer fits A) and fill.
  void assign(const BlockMatrix& A, const std::vector<char>& fixed);

  int num_nodes() const { return n_; }
  /// Diagonal block i, 9 column-major doubles (zero for a fixed node).
  const double* diagonal(int i) const { return diag_.data() + 9L * i; }
  long num_dense() const { return static_cast<long>(d_col_.size()); }
  long num_scalar() const { return static_cast<long>(s_col_.size()); }

  /// y = A x on the free nodes, zero on fixed nodes; x's fixed entries are not read.
  void multiply(const VecX& x, VecX& y) const;
  /// Forward block Gauss-Seidel sweep from x = 0 with the inverse diagonal blocks `dinv` (9
  /// column-major doubles per node, zero on fixed nodes): x_i = D_i^-1 (r_i - sum_{j<i} A_ij x_j).
  /// `t` (3n, zero on entry) receives r - A x = -(strictly upper part of A) x.
  void forward_sweep(const double* dinv, const double* r, double* x, double* t) const;
  /// Backward block Gauss-Seidel sweep from the current x; `acc` (3n, zero on entry) is
  /// scratch. Fixed nodes keep their x.
  void backward_sweep(const double* dinv, const double* r, double* x, double* acc) const;

 private:
  /// forward_sweep (kForward) or backward_sweep; `scattered` is t or acc.
  template <bool kForward>
  void sweep(const double* dinv, const double* r, double* x, double* scattered) const;

  /// (y0, y1, y2) += sum_{j<i} A_ij x_j over row i's lower blocks.
  template <bool kDescending>
  void gather_row(int i, const double* x, double& y0, double& y1, double& y2) const;
  /// out_j += sign A_ij^T v for row i's lower blocks.
  template <bool kDescending>
  void scatter_row(int i, double sign, double v0, double v1, double v2, double* out) const;

  const BlockPattern* pattern_ = nullptr;
  int blocks_ = 0;
  int n_ = 0;
  std::vector<char> fixed_;
  // Whole blocks of row i: columns d_col_[k], k in [d_start_[i], d_start_[i+1]), from slots
  // d_slot_[k]; values 9 per block, column-major. Scalar blocks likewise (s_*), one value each.
  std::vector<int> d_start_, d_col_, d_slot_;
  std::vector<double> d_val_;
  std::vector<int> s_start_, s_col_, s_slot_;
  std::vector<double> s_val_;
  std::vector<double> diag_;
};

}  // namespace weft
