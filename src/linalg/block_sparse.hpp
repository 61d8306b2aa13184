#pragma once
// Block-sparse matrix with 3x3 blocks (one block per pair of coupled nodes), stored as
// compressed rows of blocks. The pattern is built once from the topology; assembly writes
// into precomputed slots, so a step never allocates.
#include <cmath>
#include <cstring>
#include <utility>
#include <vector>

#include "weft/types.hpp"

namespace weft {

/// Which node pairs (i, j) hold a block. Symmetric: both (i, j) and (j, i) are stored.
class BlockPattern {
 public:
  BlockPattern() = default;
  /// `n` nodes; `pairs` lists coupled nodes (either order, duplicates allowed). Every
  /// diagonal block (i, i) is always present.
  BlockPattern(int n, const std::vector<std::pair<int, int>>& pairs);

  int num_nodes() const { return n_; }
  int num_blocks() const { return static_cast<int>(col_.size()); }
  /// Index of block (i, j) in the value array; -1 when absent.
  int slot(int i, int j) const;
  int diagonal_slot(int i) const { return diag_[i]; }
  const std::vector<int>& row_start() const { return row_start_; }
  const std::vector<int>& column() const { return col_; }

 private:
  int n_ = 0;
  std::vector<int> row_start_, col_, diag_;
};

/// A number no other call returns (for BlockMatrix::constant_version).
long next_constant_version();

/// Values of a matrix on a BlockPattern.
struct BlockMatrix {
  const BlockPattern* pattern = nullptr;
  std::vector<Mat3> block;
  /// Optional, for the copies solvers make (SsorOperator): per slot, 1 where the block
  /// changes only together with constant_version. The code that fills the matrix sets it
  /// and must call constants_changed whenever it changes such a block; null: any block may
  /// change at any time.
  const std::vector<char>* constant_slots = nullptr;
  long constant_version = next_constant_version();

  void reset(const BlockPattern& p) {
    pattern = &p;
    block.assign(p.num_blocks(), Mat3::Zero());
    constants_changed();
  }
  void set_zero() {
    std::fill(block.begin(), block.end(), Mat3::Zero());
    constants_changed();
  }
  /// Marks the blocks of constant_slots as changed (a version no matrix had before).
  void constants_changed() { constant_version = next_constant_version(); }
  /// y = A x
  void multiply(const VecX& x, VecX& y) const;
  /// Dense copy (tests and small systems only).
  MatX to_dense() const;
};

/// Copies the 9 doubles of a block (a fixed-size copy the compiler turns into two four-wide
/// moves and one single).
inline void copy_block(const double* from, double* to) { std::memcpy(to, from, 9 * sizeof(double)); }

/// (y0, y1, y2) += m v for a column-major 3x3 block m.
inline void add_block_times(const double* m, const double* v, double& y0, double& y1, double& y2) {
  const double v0 = v[0], v1 = v[1], v2 = v[2];
  y0 += m[0] * v0 + m[3] * v1 + m[6] * v2;
  y1 += m[1] * v0 + m[4] * v1 + m[7] * v2;
  y2 += m[2] * v0 + m[5] * v1 + m[8] * v2;
}

/// x_i = D_i^-1 (s0, s1, s2) for a column-major 3x3 inverse (a Gauss-Seidel node update).
inline void solve_node(const double* inv, double s0, double s1, double s2, double* xi) {
  xi[0] = inv[0] * s0 + inv[3] * s1 + inv[6] * s2;
  xi[1] = inv[1] * s0 + inv[4] * s1 + inv[7] * s2;
  xi[2] = inv[2] * s0 + inv[5] * s1 + inv[8] * s2;
}

/// Whether a column-major 3x3 block is a multiple of the identity (then stored as one number).
inline bool is_multiple_of_identity(const double* m) {
  // Bitwise & rather than &&: all eight comparisons and one branch, not eight branches.
  return (m[1] == 0) & (m[2] == 0) & (m[3] == 0) & (m[5] == 0) & (m[6] == 0) & (m[7] == 0) & (m[0] == m[4]) &
         (m[0] == m[8]);
}

/// The inverse of a block's diagonal magnitudes (each at least 1e-300): invert_spd_block's
/// fallback for a numerically singular block.
Mat3 inverse_of_diagonal(const Mat3& d);

/// Inverse of a diagonal block of an SPD matrix (itself SPD, read from its lower triangle); the
/// inverse of its diagonal when it is numerically singular. Symmetric: the cofactors of the
/// lower triangle, one determinant and one division.
inline Mat3 invert_spd_block(const Mat3& d) {
  const double a = d(0, 0), b = d(1, 0), c = d(2, 0), e = d(1, 1), f = d(2, 1), g = d(2, 2);
  const double c00 = e * g - f * f, c10 = c * f - b * g, c20 = b * f - c * e;
  const double det = a * c00 + b * c10 + c * c20;
  if (!(det > 0 && std::isfinite(det))) return inverse_of_diagonal(d);
  const double s = 1.0 / det;
  const double c11 = a * g - c * c, c21 = b * c - a * f, c22 = a * e - b * b;
  Mat3 inv;
  inv << s * c00, s * c10, s * c20, s * c10, s * c11, s * c21, s * c20, s * c21, s * c22;
  return inv;
}

}  // namespace weft
