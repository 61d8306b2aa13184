#include "linalg/lower_blocks.hpp"

#include "linalg/dispatch.hpp"

#include <algorithm>

namespace weft {

namespace {

// o += s m^T (v0, v1, v2).
inline void add_transpose_times(const double* m, double s, double v0, double v1, double v2, double* o) {
  o[0] += s * (m[0] * v0 + m[1] * v1 + m[2] * v2);
  o[1] += s * (m[3] * v0 + m[4] * v1 + m[5] * v2);
  o[2] += s * (m[6] * v0 + m[7] * v1 + m[8] * v2);
}

}  // namespace

void LowerBlocks::build(const BlockPattern& pattern, const std::vector<char>& fixed, const BlockMatrix* sample) {
  pattern_ = &pattern;
  blocks_ = pattern.num_blocks();
  n_ = pattern.num_nodes();
  fixed_ = fixed;
  const auto& rs = pattern.row_start();
  const auto& col = pattern.column();
  const double* a = sample && !sample->block.empty() ? sample->block.front().data() : nullptr;
  d_start_.assign(n_ + 1, 0);
  s_start_.assign(n_ + 1, 0);
  d_col_.clear();
  d_slot_.clear();
  s_col_.clear();
  s_slot_.clear();
  for (int i = 0; i < n_; ++i) {
    if (!fixed[i])
      for (int s = rs[i]; s < rs[i + 1] && col[s] < i; ++s) {
        if (fixed[col[s]]) continue;
        if (a && is_multiple_of_identity(a + 9L * s)) {
          s_col_.push_back(col[s]);
          s_slot_.push_back(s);
        } else {
          d_col_.push_back(col[s]);
          d_slot_.push_back(s);
        }
      }
    d_start_[i + 1] = static_cast<int>(d_col_.size());
    s_start_[i + 1] = static_cast<int>(s_col_.size());
  }
  d_val_.assign(9 * d_col_.size(), 0.0);
  s_val_.assign(s_col_.size(), 0.0);
  diag_.assign(9L * n_, 0.0);
}

bool LowerBlocks::matches(const BlockPattern& pattern, const std::vector<char>& fixed) const {
  return pattern_ == &pattern && blocks_ == pattern.num_blocks() && n_ == pattern.num_nodes() && fixed_ == fixed;
}

bool LowerBlocks::fill(const BlockMatrix& A) {
  const double* a = A.block.front().data();
  for (size_t k = 0; k < d_slot_.size(); ++k) copy_block(a + 9L * d_slot_[k], d_val_.data() + 9 * k);
  for (size_t k = 0; k < s_slot_.size(); ++k) {
    const double* m = a + 9L * s_slot_[k];
    if (!is_multiple_of_identity(m)) return false;
    s_val_[k] = m[0];
  }
  for (int i = 0; i < n_; ++i)
    if (!fixed_[i]) copy_block(a + 9L * pattern_->diagonal_slot(i), diag_.data() + 9L * i);
  return true;
}

void LowerBlocks::assign(const BlockMatrix& A, const std::vector<char>& fixed) {
  if (!matches(*A.pattern, fixed)) build(*A.pattern, fixed, &A);
  if (!fill(A)) {
    build(*A.pattern, fixed, &A);
    fill(A);
  }
}

WEFT_HOT_KERNEL void LowerBlocks::multiply(const VecX& x, VecX& y) const {
  y.setZero(3 * n_);
  const double* xp = x.data();
  double* yp = y.data();
  for (int i = 0; i < n_; ++i) {
    if (fixed_[i]) continue;
    const double* xi = xp + 3 * i;
    const double v0 = xi[0], v1 = xi[1], v2 = xi[2];
    double* yi = yp + 3 * i;
    double y0 = yi[0], y1 = yi[1], y2 = yi[2];
    add_block_times(diag_.data() + 9L * i, xi, y0, y1, y2);
    for (int k = d_start_[i]; k < d_start_[i + 1]; ++k) {
      const double* m = d_val_.data() + 9L * k;
      const int j = d_col_[k];
      add_block_times(m, xp + 3 * j, y0, y1, y2);
      add_transpose_times(m, 1.0, v0, v1, v2, yp + 3 * j);
    }
    for (int k = s_start_[i]; k < s_start_[i + 1]; ++k) {
      const double s = s_val_[k];
      const int j = s_col_[k];
      const double* xj = xp + 3 * j;
      y0 += s * xj[0];
      y1 += s * xj[1];
      y2 += s * xj[2];
      double* yj = yp + 3 * j;
      yj[0] += s * v0;
      yj[1] += s * v1;
      yj[2] += s * v2;
    }
    yi[0] = y0;
    yi[1] = y1;
    yi[2] = y2;
  }
}

template <bool kDescending>
[[gnu::always_inline]] inline void LowerBlocks::gather_row(int i, const double* x, double& y0, double& y1, double& y2) const {
  // Ascending (forward sweeps and lower solves): x_j of the last column, i - 1 on a grid, was
  // computed just before; the scalar blocks go first and that block last, so little of the
  // sum waits for it.
  const int db = d_start_[i], de = d_start_[i + 1], sb = s_start_[i], se = s_start_[i + 1];
  for (int q = 0; q < se - sb; ++q) {
    const int k = kDescending ? se - 1 - q : sb + q;
    const double sv = s_val_[k];
    const double* xj = x + 3 * s_col_[k];
    y0 += sv * xj[0];
    y1 += sv * xj[1];
    y2 += sv * xj[2];
  }
  for (int q = 0; q < de - db; ++q) {
    const int k = kDescending ? de - 1 - q : db + q;
    add_block_times(d_val_.data() + 9L * k, x + 3 * d_col_[k], y0, y1, y2);
  }
}

template <bool kDescending>
[[gnu::always_inline]] inline void LowerBlocks::scatter_row(int i, double sign, double v0, double v1, double v2, double* out) const {
  const int db = d_start_[i], de = d_start_[i + 1], sb = s_start_[i], se = s_start_[i + 1];
  for (int q = 0; q < de - db; ++q) {
    const int k = kDescending ? de - 1 - q : db + q;
    add_transpose_times(d_val_.data() + 9L * k, sign, v0, v1, v2, out + 3 * d_col_[k]);
  }
  for (int q = 0; q < se - sb; ++q) {
    const int k = kDescending ? se - 1 - q : sb + q;
    const double sv = sign * s_val_[k];
    double* o = out + 3 * s_col_[k];
    o[0] += sv * v0;
    o[1] += sv * v1;
    o[2] += sv * v2;
  }
}

template <bool kForward>
void LowerBlocks::sweep(const double* dinv, const double* r, double* x, double* scattered) const {
  // Forward (x = 0 on entry): x_i = D_i^-1 (r_i - sum_{j<i} A_ij x_j), then row i's lower
  // blocks scatter -A_ij^T x_i into t, which ends as -(strictly upper part of A) x = r - A x.
  // Backward: row i's upper part sum_{j > i} A_ij x_j = sum_{j > i} A_ji^T x_j is scattered
  // into acc from the rows already swept (descending) and its lower part gathered from the
  // nodes not swept yet; blocks are visited in descending order so that the loads run
  // downwards with the rows.
  const double sign = kForward ? -1.0 : 1.0;
  for (int step = 0; step < n_; ++step) {
    const int i = kForward ? step : n_ - 1 - step;
    double* xi = x + 3 * i;
    if (fixed_[i]) {
      if (kForward) xi[0] = xi[1] = xi[2] = 0.0;
      continue;
    }
    double y0 = 0, y1 = 0, y2 = 0;
    if (!kForward) y0 = scattered[3 * i], y1 = scattered[3 * i + 1], y2 = scattered[3 * i + 2];
    gather_row<!kForward>(i, x, y0, y1, y2);
    solve_node(dinv + 9L * i, r[3 * i] - y0, r[3 * i + 1] - y1, r[3 * i + 2] - y2, xi);
    scatter_row<!kForward>(i, sign, xi[0], xi[1], xi[2], scattered);
  }
}

void LowerBlocks::forward_sweep(const double* dinv, const double* r, double* x, double* t) const {
  sweep<true>(dinv, r, x, t);
}

void LowerBlocks::backward_sweep(const double* dinv, const double* r, double* x, double* acc) const {
  sweep<false>(dinv, r, x, acc);
}

}  // namespace weft
