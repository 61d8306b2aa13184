#include "linalg/ssor.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace weft {

namespace {

// Four doubles, loaded and stored without alignment requirements (GCC/Clang vector
// extension: one AVX register where available, two SSE ones otherwise).
typedef double V4 __attribute__((vector_size(32), aligned(8), may_alias));

inline V4 load(const double* p) { return *reinterpret_cast<const V4*>(p); }
inline void store(double* p, V4 v) { *reinterpret_cast<V4*>(p) = v; }

// A column-major 3x3 block times a node's vector: three four-wide loads of the columns at
// offsets 0, 3 and 6 (the fourth lane reads the next entry: its result is not used).
inline V4 block_times(const double* m, const double* x) {
  return load(m) * x[0] + load(m + 3) * x[1] + load(m + 6) * x[2];
}

// The same for a padded block (12 doubles, fourth lane zero): the result's fourth lane is 0.
inline V4 padded_times(const double* m, V4 r) {
  return load(m) * r[0] + load(m + 4) * r[1] + load(m + 8) * r[2];
}

}  // namespace

void SsorOperator::Rows::build(const BlockPattern& pattern, const std::vector<int>& order,
                               const std::vector<int>& position, const std::vector<char>& fixed,
                               const double* sample, bool upper) {
  const int n = pattern.num_nodes();
  const auto& rs = pattern.row_start();
  const auto& col = pattern.column();
  d_start.assign(n + 1, 0);
  s_start.assign(n + 1, 0);
  d_off.clear();
  d_slot.clear();
  s_off.clear();
  s_slot.clear();
  std::vector<std::pair<int, int>> row;  // (position, slot)
  for (int p = 0; p < n; ++p) {
    const int i = order[p];
    if (!fixed[i]) {
      row.clear();
      for (int s = rs[i]; s < rs[i + 1]; ++s) {
        const int q = position[col[s]];
        if ((upper ? q > p : q < p) && !fixed[col[s]]) row.emplace_back(q, s);
      }
      // By distance from the diagonal, farthest first: the lower row ascending, the upper
      // row descending.
      std::sort(row.begin(), row.end());
      if (upper) std::reverse(row.begin(), row.end());
      for (auto [q, s] : row) {
        if (is_multiple_of_identity(sample + 9L * s)) {
          s_off.push_back(4 * q);
          s_slot.push_back(s);
        } else {
          d_off.push_back(4 * q);
          d_slot.push_back(s);
        }
      }
    }
    d_start[p + 1] = static_cast<int>(d_off.size());
    s_start[p + 1] = static_cast<int>(s_off.size());
  }
  d_val.assign(9 * d_off.size() + 1, 0.0);
  s_val.assign(s_off.size(), 0.0);
}

inline bool SsorOperator::Rows::fill_row(int p, const double* a) {
  for (int k = d_start[p]; k < d_start[p + 1]; ++k) copy_block(a + 9L * d_slot[k], d_val.data() + 9L * k);
  for (int k = s_start[p]; k < s_start[p + 1]; ++k) {
    const double* m = a + 9L * s_slot[k];
    if (!is_multiple_of_identity(m)) return false;
    s_val[k] = m[0];
  }
  return true;
}

namespace {
// Sum over row i of A_ij x_j, accumulated by multiply-adds (the scalar and the whole blocks
// in two sums, so the chains are short).
template <class View>
inline V4 row_sum(const View& r, int i, const double* x) {
  V4 acc = {0, 0, 0, 0}, acc_s = {0, 0, 0, 0};
  for (int k = r.s_start[i], end = r.s_start[i + 1]; k < end; ++k) acc_s += r.s_val[k] * load(x + r.s_off[k]);
  for (int k = r.d_start[i], end = r.d_start[i + 1]; k < end; ++k) {
    const double* m = r.d_val + 9L * k;
    const double* xj = x + r.d_off[k];
    acc += load(m) * xj[0];
    acc += load(m + 3) * xj[1];
    acc += load(m + 6) * xj[2];
  }
  return acc + acc_s;
}
}  // namespace

void SsorOperator::build(const BlockMatrix& A, const std::vector<char>& fixed, const std::vector<int>* base) {
  pattern_ = A.pattern;
  blocks_ = A.pattern->num_blocks();
  n_ = A.pattern->num_nodes();
  fixed_ = fixed;
  base_ = base ? *base : std::vector<int>();
  if (!base_.empty()) {
    std::vector<char> seen(n_, 0);
    bool permutation = static_cast<int>(base_.size()) == n_;
    for (int i : base_) {
      if (!permutation) break;
      permutation = i >= 0 && i < n_ && !seen[i];
      if (permutation) seen[i] = 1;
    }
    if (!permutation)
      throw std::invalid_argument("SSOR node order is not a permutation of the " + std::to_string(n_) + " nodes");
  }
  // Interleave kChains stretches of the base order (on a mesh, bands of rows): consecutive
  // positions then belong to different stretches and are rarely coupled, so the triangular
  // solves run kChains independent chains of dependent nodes side by side.
  order_.clear();
  const int stretch = (n_ + kChains - 1) / kChains;
  for (int k = 0; k < stretch; ++k)
    for (int c = 0; c < kChains; ++c)
      if (c * stretch + k < n_) order_.push_back(base_.empty() ? c * stretch + k : base_[c * stretch + k]);
  position_.assign(n_, 0);
  for (int p = 0; p < n_; ++p) position_[order_[p]] = p;
  fixed_at_.assign(n_, 0);
  for (int p = 0; p < n_; ++p) fixed_at_[p] = fixed[order_[p]];
  const double* a = A.block.front().data();
  lower_.build(*pattern_, order_, position_, fixed, a, false);
  upper_.build(*pattern_, order_, position_, fixed, a, true);
  // Padding lanes and fixed nodes stay zero; assign writes the rest.
  diag_.assign(12L * n_, 0.0);
  binv_.assign(12L * n_, 0.0);
}

void SsorOperator::assign(const BlockMatrix& A, const std::vector<char>& fixed, double omega,
                          const std::vector<int>* base) {
  const bool same = pattern_ == A.pattern && blocks_ == A.pattern->num_blocks() &&
                    n_ == A.pattern->num_nodes() && fixed_ == fixed &&
                    (base ? *base == base_ : base_.empty());
  if (!same) build(A, fixed, base);
  omega_ = omega;
  // One pass by position: a node's lower and upper blocks and its diagonal block all lie in
  // its row of A, read once.
  const double* a = A.block.front().data();
  for (int pass = 0; pass < 2; ++pass) {
    bool fits = true;
    for (int p = 0; p < n_ && fits; ++p) {
      if (fixed_at_[p]) continue;
      fits = lower_.fill_row(p, a) && upper_.fill_row(p, a);
      const Mat3& d = A.block[pattern_->diagonal_slot(order_[p])];
      const Mat3 inv = invert_spd_block(d);
      for (int c = 0; c < 3; ++c) {
        store(diag_.data() + 12L * p + 4 * c, V4{d(0, c), d(1, c), d(2, c), 0.0});
        store(binv_.data() + 12L * p + 4 * c, omega * V4{inv(0, c), inv(1, c), inv(2, c), 0.0});
      }
    }
    if (fits) return;
    build(A, fixed, base);  // a block stored as a scalar stopped being one: lay out again
  }
}

void SsorOperator::solve_lower(const double* v, double* y) const {
  lower_solve<false>(v, y, nullptr, nullptr);
}

double SsorOperator::solve_lower_dot(const double* v, double* y, const double* p, const double* t) const {
  return lower_solve<true>(v, y, p, t);
}

template <bool kDot>
double SsorOperator::lower_solve(const double* v, double* y, const double* p, const double* t) const {
  const Rows::View rows = lower_.view();
  const char* fixed = fixed_at_.data();
  const double* binv = binv_.data();
  V4 dot = {0, 0, 0, 0};
  for (int i = 0; i < n_; ++i) {
    if (fixed[i]) {
      store(y + 4 * i, V4{0, 0, 0, 0});
      continue;
    }
    const V4 sum = row_sum(rows, i, y);
    const V4 yi = padded_times(binv + 12L * i, load(v + 4 * i) - sum);
    store(y + 4 * i, yi);
    if constexpr (kDot) dot += load(p + 4 * i) * (yi + load(t + 4 * i));
  }
  return (dot[0] + dot[1]) + (dot[2] + dot[3]);
}

void SsorOperator::solve_upper(const double* v, double* y, double* u, double cp, double cu) const {
  upper_solve<false>(nullptr, 0.0, const_cast<double*>(v), y, u, cp, cu, nullptr, 0.0);
}

void SsorOperator::step_and_solve_upper(const double* z, double beta, double* p, double* y, double* u, double cp,
                                        double cu, double* x, double a) const {
  upper_solve<true>(z, beta, p, y, u, cp, cu, x, a);
}

template <bool kStep>
void SsorOperator::upper_solve(const double* z, double beta, double* v, double* y, double* u, double cp, double cu,
                               double* x, double a) const {
  const Rows::View rows = upper_.view();
  const char* fixed = fixed_at_.data();
  const double* binv = binv_.data();
  for (int i = n_ - 1; i >= 0; --i) {
    if (fixed[i]) {
      store(y + 4 * i, V4{0, 0, 0, 0});
      if (u) store(u + 4 * i, V4{0, 0, 0, 0});
      continue;
    }
    V4 vi = load(v + 4 * i);
    if constexpr (kStep) {
      vi = load(z + 4 * i) + beta * vi;
      store(v + 4 * i, vi);
      if (a != 0.0) store(x + 4 * i, load(x + 4 * i) + a * load(y + 4 * i));  // y_i still the old value
    }
    const V4 s = row_sum(rows, i, y);
    store(y + 4 * i, padded_times(binv + 12L * i, vi - s));
    if (u) {
      V4 ui = cp * vi + cu * s;
      ui[3] = 0.0;
      store(u + 4 * i, ui);
    }
  }
}

double SsorOperator::update(double a, const double* t, const double* q, double* r, double s, double* z,
                            double& rz) const {
  V4 rr4 = {0, 0, 0, 0}, rz4 = {0, 0, 0, 0};
  const double* diag = diag_.data();
  for (int i = 0; i < n_; ++i) {
    const long k = 4L * i;
    const V4 ri = load(r + k) - a * (load(q + k) + load(t + k));
    store(r + k, ri);
    const V4 zi = s * padded_times(diag + 12L * i, ri);
    store(z + k, zi);
    rr4 += ri * ri;
    rz4 += ri * zi;
  }
  rz = (rz4[0] + rz4[1]) + (rz4[2] + rz4[3]);
  return (rr4[0] + rr4[1]) + (rr4[2] + rr4[3]);
}

void SsorOperator::axpy(double a, const double* t, double* x) const {
  for (long k = 0; k < 4L * n_; k += 4) store(x + k, load(x + k) + a * load(t + k));
}

void SsorOperator::multiply(const double* x, double* y) const {
  const Rows::View lower = lower_.view(), upper = upper_.view();
  const char* fixed = fixed_at_.data();
  const double* diag = diag_.data();
  for (int i = 0; i < n_; ++i) {
    if (fixed[i]) {
      store(y + 4 * i, V4{0, 0, 0, 0});
      continue;
    }
    V4 yi = padded_times(diag + 12L * i, load(x + 4 * i)) + row_sum(lower, i, x) + row_sum(upper, i, x);
    yi[3] = 0.0;
    store(y + 4 * i, yi);
  }
}

void SsorOperator::diagonal_times(double s, const double* x, double* y) const {
  const double* diag = diag_.data();
  for (int i = 0; i < n_; ++i) store(y + 4 * i, s * padded_times(diag + 12L * i, load(x + 4 * i)));
}

void SsorOperator::pad(const VecX& v, VecX& v4) const {
  v4.setZero(4L * n_);
  for (int p = 0; p < n_; ++p)
    if (!fixed_at_[p]) v4.segment<3>(4 * p) = v.segment<3>(3 * order_[p]);
}

void SsorOperator::unpad(const VecX& v4, VecX& v) const {
  v.resize(3L * n_);
  for (int p = 0; p < n_; ++p) v.segment<3>(3 * order_[p]) = v4.segment<3>(4 * p);
}

}  // namespace weft
