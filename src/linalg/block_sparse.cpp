#include "linalg/block_sparse.hpp"

#include "linalg/dispatch.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>

namespace weft {

BlockPattern::BlockPattern(int n, const std::vector<std::pair<int, int>>& pairs) : n_(n) {
  std::vector<std::vector<int>> rows(n);
  for (int i = 0; i < n; ++i) rows[i].push_back(i);
  for (auto [i, j] : pairs) {
    rows[i].push_back(j);
    rows[j].push_back(i);
  }
  row_start_.assign(n + 1, 0);
  diag_.assign(n, -1);
  for (int i = 0; i < n; ++i) {
    auto& r = rows[i];
    std::sort(r.begin(), r.end());
    r.erase(std::unique(r.begin(), r.end()), r.end());
    row_start_[i + 1] = row_start_[i] + static_cast<int>(r.size());
  }
  col_.reserve(row_start_[n]);
  for (int i = 0; i < n; ++i) {
    for (int j : rows[i]) {
      if (j == i) diag_[i] = static_cast<int>(col_.size());
      col_.push_back(j);
    }
  }
}

int BlockPattern::slot(int i, int j) const {
  auto begin = col_.begin() + row_start_[i], end = col_.begin() + row_start_[i + 1];
  auto it = std::lower_bound(begin, end, j);
  return (it != end && *it == j) ? static_cast<int>(it - col_.begin()) : -1;
}

long next_constant_version() {
  static std::atomic<long> next{0};
  return ++next;
}

WEFT_HOT_KERNEL void BlockMatrix::multiply(const VecX& x, VecX& y) const {
  const auto& rs = pattern->row_start();
  const auto& col = pattern->column();
  const int n = pattern->num_nodes();
  y.resize(3 * n);
  static_assert(sizeof(Mat3) == 9 * sizeof(double), "blocks are stored as 9 contiguous doubles");
  const double* a = block.empty() ? nullptr : block.front().data();  // column-major 3x3 blocks
  const double* xp = x.data();
  double* yp = y.data();
  // Four-wide: a block's columns as three loads of four (the fourth number is the next
  // column's first, or the next block's, multiplied into the unused fourth lane), except for
  // the matrix's last block, whose third column ends the array.
  typedef double V4 __attribute__((vector_size(32), aligned(8), may_alias));
  const long last = static_cast<long>(block.size()) - 1;
  for (int i = 0; i < n; ++i) {
    V4 acc = {0, 0, 0, 0};
    double y0 = 0, y1 = 0, y2 = 0;
    for (int s = rs[i]; s < rs[i + 1]; ++s) {
      const double* m = a + 9L * s;
      const double* v = xp + 3 * col[s];
      if (s == last) {
        add_block_times(m, v, y0, y1, y2);
        continue;
      }
      acc += *reinterpret_cast<const V4*>(m) * v[0] + *reinterpret_cast<const V4*>(m + 3) * v[1] +
             *reinterpret_cast<const V4*>(m + 6) * v[2];
    }
    yp[3 * i] = acc[0] + y0;
    yp[3 * i + 1] = acc[1] + y1;
    yp[3 * i + 2] = acc[2] + y2;
  }
}

MatX BlockMatrix::to_dense() const {
  const int n = pattern->num_nodes();
  MatX d = MatX::Zero(3 * n, 3 * n);
  for (int i = 0; i < n; ++i)
    for (int s = pattern->row_start()[i]; s < pattern->row_start()[i + 1]; ++s)
      d.block<3, 3>(3 * i, 3 * pattern->column()[s]) = block[s];
  return d;
}

Mat3 inverse_of_diagonal(const Mat3& d) {
  return d.diagonal().cwiseAbs().cwiseMax(1e-300).cwiseInverse().asDiagonal();
}

}  // namespace weft
