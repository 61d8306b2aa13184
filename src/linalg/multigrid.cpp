#include "linalg/multigrid.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "linalg/lower_blocks.hpp"

namespace weft {

struct AggregationMultigrid::Level {
  int n = 0;
  const BlockPattern* pattern = nullptr;      ///< level 0: the caller's pattern
  std::unique_ptr<BlockPattern> own_pattern;  ///< coarse levels (stable address)
  const BlockMatrix* A = nullptr;             ///< level 0: the caller's matrix
  BlockMatrix own_A;                          ///< coarse levels
  std::vector<char> fixed;                    ///< n entries; only level 0 has fixed nodes

  // The smoother's copy of the matrix (the lower blocks between free nodes and the
  // diagonal; on level 0 also CG's product) and its inverse diagonal blocks, symmetrized,
  // 9 per node, zero on fixed nodes.
  LowerBlocks lower;
  std::vector<double> dinv_val;

  // Prolongator to the next level, stored by rows of this level: row i holds next-level
  // nodes p_col[k] with weights p_w[k] (times I3), k in [p_start[i], p_start[i+1]).
  std::vector<int> p_start, p_col;
  std::vector<double> p_w;
  // Galerkin product, gathered per next-level block: next-level slot c (a block (I, J) with
  // I <= J; the others are mirrored) is sum_k g_w[k] A_{g_fine[k]}, k in [g_start[c],
  // g_start[c+1]). Each coarse block is summed in registers and written once.
  std::vector<int> g_start, g_fine;
  std::vector<double> g_w;

  // On coarse levels: slots (I, J) with I > J and the slot of (J, I).
  std::vector<std::pair<int, int>> lower_mirror;

  VecX r, x, t;  ///< right-hand side, solution and residual scratch

  // Coarsest level: dense Cholesky factor.
  bool coarsest = false;
  bool dense_ok = false;
  MatX dense;
  Eigen::LLT<MatX> llt;
};

AggregationMultigrid::AggregationMultigrid() = default;
AggregationMultigrid::~AggregationMultigrid() = default;
AggregationMultigrid::AggregationMultigrid(AggregationMultigrid&&) noexcept = default;
AggregationMultigrid& AggregationMultigrid::operator=(AggregationMultigrid&&) noexcept = default;

namespace {

// Sum over the slots [begin, end) of row blocks times x's nodes.
inline void row_accumulate(const double* a, const int* col, int begin, int end, const double* x,
                           double& y0, double& y1, double& y2) {
  for (int s = begin; s < end; ++s) {
    add_block_times(a + 9 * s, x + 3 * col[s], y0, y1, y2);
  }
}

// The same over the slots in descending order: a backward sweep then streams the blocks
// from high to low addresses, which the hardware prefetchers follow (mixing ascending rows
// with descending row order defeats them and leaves the sweep waiting on memory).
inline void row_accumulate_descending(const double* a, const int* col, int begin, int end,
                                      const double* x, double& y0, double& y1, double& y2) {
  for (int s = end - 1; s >= begin; --s) {
    add_block_times(a + 9 * s, x + 3 * col[s], y0, y1, y2);
  }
}

// Gauss-Seidel rows depend on the previous row's result, so few matrix loads are in flight
// at once and a sweep over a matrix larger than the caches waits on memory; fetching the
// blocks `distance` bytes ahead of (or behind) the current row's hides that latency.
constexpr long kPrefetchBytes = 6144;
inline void prefetch_range(const double* a, int num_blocks, int begin, int end, long distance) {
  const long bytes = 72L * num_blocks;
  const long lo = std::max(0L, 72L * begin + distance), hi = std::min(bytes, 72L * end + distance);
  const char* base = reinterpret_cast<const char*>(a);
  for (long p = lo; p < hi; p += 64) __builtin_prefetch(base + p);
}

}  // namespace

bool AggregationMultigrid::matches(const BlockPattern& pattern, const std::vector<char>& fixed,
                                   const MultigridSettings& settings) const {
  return is_setup() && settings_ == settings && pattern_ == &pattern && pattern_blocks_ == pattern.num_blocks() &&
         levels_[0]->n == pattern.num_nodes() && fixed_ == fixed;
}

int AggregationMultigrid::level_nodes(int level) const { return levels_.at(level)->n; }

const BlockMatrix& AggregationMultigrid::coarse_matrix(int level) const {
  if (level < 1 || level >= num_levels()) throw std::out_of_range("coarse_matrix: bad level");
  return levels_[level]->own_A;
}

MatX AggregationMultigrid::prolongator_dense(int level) const {
  const Level& f = *levels_.at(level);
  const Level& c = *levels_.at(level + 1);
  MatX P = MatX::Zero(3 * f.n, 3 * c.n);
  for (int i = 0; i < f.n; ++i)
    for (int k = f.p_start[i]; k < f.p_start[i + 1]; ++k)
      P.block<3, 3>(3 * i, 3 * f.p_col[k]) = f.p_w[k] * Mat3::Identity();
  return P;
}

void AggregationMultigrid::setup(const BlockPattern& pattern, const std::vector<char>& fixed,
                                 const MultigridSettings& settings) {
  build(pattern, fixed, settings, nullptr);
}

void AggregationMultigrid::setup(const BlockMatrix& A, const std::vector<char>& fixed,
                                 const MultigridSettings& settings) {
  build(*A.pattern, fixed, settings, &A);
}

void AggregationMultigrid::build(const BlockPattern& pattern, const std::vector<char>& fixed,
                                 const MultigridSettings& settings, const BlockMatrix* A) {
  const int n = pattern.num_nodes();
  if (static_cast<int>(fixed.size()) != n)
    throw std::invalid_argument("AggregationMultigrid::setup: fixed has the wrong size");
  settings_ = settings;
  pattern_ = &pattern;
  pattern_blocks_ = pattern.num_blocks();
  fixed_ = fixed;
  levels_.clear();
  auto fine = std::make_unique<Level>();
  fine->n = n;
  fine->pattern = &pattern;
  fine->fixed = fixed;
  fine->A = A;
  levels_.push_back(std::move(fine));
  while (true) {
    const int l = num_levels() - 1;
    const Level& cur = *levels_[l];
    int free_nodes = 0;
    for (char f : cur.fixed) free_nodes += f ? 0 : 1;
    if (free_nodes <= settings_.coarsest_nodes || num_levels() >= settings_.max_levels) break;
    const int before = num_levels();
    build_coarse(l, A != nullptr);
    // Stop when aggregation no longer reduces the problem (e.g. no couplings at all).
    if (num_levels() == before) break;
    // The coarse operator's values decide the next level's strong couplings.
    if (A != nullptr) galerkin(l);
  }
  for (auto& lev : levels_) {
    // The compact lower copy for the smoother (all levels but the coarsest) and, on level 0,
    // for CG's products; scalar blocks are recognised in the setup's matrix, if any.
    lev->lower.build(*lev->pattern, lev->fixed, A ? lev->A : nullptr);
    lev->dinv_val.assign(9 * lev->n, 0.0);
    lev->r.setZero(3 * lev->n);
    lev->x.setZero(3 * lev->n);
    lev->t.setZero(3 * lev->n);
  }
  levels_[0]->A = nullptr;  // set by update
  Level& last = *levels_.back();
  last.coarsest = true;
  last.dense.setZero(3 * last.n, 3 * last.n);
  // The factor is sized by its first compute(). (Not by assigning a sized LLT: Eigen leaves a
  // constructed but uncomputed LLT's info member uninitialised, and copying it reads it.)
}

namespace {

// Coupling weights of the free nodes, per block slot of `pattern`: with a matrix, the
// Frobenius norm of the strong off-diagonal blocks (|A_ij| >= theta sqrt(max_k |A_ik|
// max_k |A_jk|)), else 1 for every coupling. 0 marks no (or a weak) coupling.
std::vector<double> coupling_weights(const BlockPattern& pattern, const std::vector<char>& fixed,
                                     const BlockMatrix* A, double theta) {
  const int n = pattern.num_nodes();
  const auto& rs = pattern.row_start();
  const auto& col = pattern.column();
  std::vector<double> weight(pattern.num_blocks(), 0.0);
  std::vector<double> row_max(n, 0.0);
  if (A != nullptr)
    for (int i = 0; i < n; ++i)
      for (int s = rs[i]; s < rs[i + 1]; ++s)
        if (col[s] != i && !fixed[col[s]]) row_max[i] = std::max(row_max[i], A->block[s].norm());
  for (int i = 0; i < n; ++i) {
    if (fixed[i]) continue;
    for (int s = rs[i]; s < rs[i + 1]; ++s) {
      const int j = col[s];
      if (j == i || fixed[j]) continue;
      if (A == nullptr) {
        weight[s] = 1.0;
        continue;
      }
      const double a = A->block[s].norm();
      if (a > 0 && a >= theta * std::sqrt(row_max[i] * row_max[j])) weight[s] = a;
    }
  }
  return weight;
}

// Aggregates of the free nodes along the weighted couplings; agg[i] = -1 on fixed nodes.
// Returns the number of aggregates. Three passes:
//  1. a free node whose free neighbours are all unassigned becomes the root of an aggregate
//     with them;
//  2. leftovers join the first pass's aggregate they are most strongly coupled to;
//  3. nodes with no aggregated neighbour start aggregates of their own.
int aggregate(const BlockPattern& pattern, const std::vector<char>& fixed,
              const std::vector<double>& weight, std::vector<int>& agg) {
  const int n = pattern.num_nodes();
  const auto& rs = pattern.row_start();
  const auto& col = pattern.column();
  agg.assign(n, -1);
  int nc = 0;
  for (int i = 0; i < n; ++i) {
    if (fixed[i] || agg[i] >= 0) continue;
    bool clear = true;
    for (int s = rs[i]; s < rs[i + 1] && clear; ++s) {
      if (weight[s] > 0 && agg[col[s]] >= 0) clear = false;
    }
    if (!clear) continue;
    agg[i] = nc;
    for (int s = rs[i]; s < rs[i + 1]; ++s)
      if (weight[s] > 0) agg[col[s]] = nc;
    ++nc;
  }
  const std::vector<int> roots = agg;
  std::vector<std::pair<int, double>> sums;  // (aggregate, coupling weight)
  for (int i = 0; i < n; ++i) {
    if (fixed[i] || roots[i] >= 0) continue;
    sums.clear();
    for (int s = rs[i]; s < rs[i + 1]; ++s) {
      const int a = roots[col[s]];
      if (a < 0 || weight[s] == 0) continue;
      auto it = std::find_if(sums.begin(), sums.end(), [&](auto& c) { return c.first == a; });
      if (it == sums.end()) sums.emplace_back(a, weight[s]); else it->second += weight[s];
    }
    int best = -1;
    double best_sum = 0;
    for (auto [a, w] : sums)
      if (w > best_sum) best = a, best_sum = w;
    agg[i] = best;
  }
  for (int i = 0; i < n; ++i) {
    if (fixed[i] || agg[i] >= 0) continue;
    agg[i] = nc;
    for (int s = rs[i]; s < rs[i + 1]; ++s)
      if (weight[s] > 0 && agg[col[s]] < 0) agg[col[s]] = nc;
    ++nc;
  }
  return nc;
}

// One row of the smoothed prolongator, P_iJ = (1 - omega) [agg(i) = J] + omega sum_{j in J}
// w_ij / sum_j w_ij, for the free node i: merged by aggregate, exact zeros (omega = 1 and no
// neighbour in the own aggregate) and weights below `drop` other than the own aggregate's
// dropped (they widen the coarse stencil for little benefit), then normalised so that the
// row sums to one exactly (translations are kept).
void prolongator_row(const BlockPattern& pattern, const std::vector<double>& weight,
                     const std::vector<int>& agg, int i, double omega, double drop,
                     std::vector<std::pair<int, double>>& row) {
  const auto& rs = pattern.row_start();
  const auto& col = pattern.column();
  row.clear();
  double deg = 0;
  for (int s = rs[i]; s < rs[i + 1]; ++s) deg += weight[s];
  if (deg == 0 || omega == 0.0) {
    row.emplace_back(agg[i], 1.0);
    return;
  }
  row.emplace_back(agg[i], 1.0 - omega);
  for (int s = rs[i]; s < rs[i + 1]; ++s)
    if (weight[s] > 0) row.emplace_back(agg[col[s]], omega * weight[s] / deg);
  std::sort(row.begin(), row.end());
  size_t m = 0;
  for (size_t k = 1; k < row.size(); ++k) {
    if (row[k].first == row[m].first) row[m].second += row[k].second;
    else row[++m] = row[k];
  }
  row.resize(m + 1);
  row.erase(std::remove_if(row.begin(), row.end(), [](auto& e) { return e.second == 0.0; }), row.end());
  row.erase(std::remove_if(row.begin(), row.end(), [&](auto& e) { return e.first != agg[i] && e.second < drop; }),
            row.end());
  double sum = 0;
  for (auto& e : row) sum += e.second;
  for (auto& e : row) e.second /= sum;
}

// The coarse pattern's couplings (I, J), I < J, for nc aggregates: coupled when some
// P_iI A_ij P_jJ is structurally nonzero. P by rows of the fine level (p_start, p_col).
std::vector<std::pair<int, int>> coarse_couplings(const BlockPattern& pattern, const std::vector<int>& p_start,
                                                  const std::vector<int>& p_col, int nc) {
  const int n = pattern.num_nodes();
  const auto& rs = pattern.row_start();
  const auto& col = pattern.column();
  // The columns of P.
  std::vector<int> pt_start(nc + 1, 0), pt_row(p_col.size());
  for (int J : p_col) ++pt_start[J + 1];
  for (int J = 0; J < nc; ++J) pt_start[J + 1] += pt_start[J];
  std::vector<int> fill(pt_start.begin(), pt_start.end() - 1);
  for (int i = 0; i < n; ++i)
    for (int k = p_start[i]; k < p_start[i + 1]; ++k) pt_row[fill[p_col[k]]++] = i;
  std::vector<std::pair<int, int>> pairs;
  std::vector<int> mark(nc, -1);
  for (int I = 0; I < nc; ++I) {
    for (int q = pt_start[I]; q < pt_start[I + 1]; ++q) {
      const int i = pt_row[q];
      for (int s = rs[i]; s < rs[i + 1]; ++s) {
        const int j = col[s];
        for (int k = p_start[j]; k < p_start[j + 1]; ++k) {
          const int J = p_col[k];
          if (J > I && mark[J] != I) {
            mark[J] = I;
            pairs.emplace_back(I, J);
          }
        }
      }
    }
  }
  return pairs;
}

}  // namespace

void AggregationMultigrid::build_coarse(int l, bool with_values) {
  Level& f = *levels_[l];
  const int n = f.n;
  const auto& fixed = f.fixed;
  const std::vector<double> weight = coupling_weights(
      *f.pattern, fixed, with_values ? f.A : nullptr, settings_.strength_threshold);
  std::vector<int> agg;
  const int nc = aggregate(*f.pattern, fixed, weight, agg);
  int free_nodes = 0;
  for (char c : fixed) free_nodes += c ? 0 : 1;
  if (nc == 0 || nc >= free_nodes) return;

  // Smoothed prolongator P = (I - omega D_L^-1 L) P_tent with L the weighted graph Laplacian
  // of the free nodes' couplings, by rows (fixed nodes' rows are empty).
  f.p_start.assign(n + 1, 0);
  f.p_col.clear();
  f.p_w.clear();
  std::vector<std::pair<int, double>> row;
  for (int i = 0; i < n; ++i) {
    row.clear();
    if (!fixed[i])
      prolongator_row(*f.pattern, weight, agg, i, settings_.prolongator_damping, settings_.prolongator_drop, row);
    for (auto [J, w] : row) {
      f.p_col.push_back(J);
      f.p_w.push_back(w);
    }
    f.p_start[i + 1] = static_cast<int>(f.p_col.size());
  }

  auto c = std::make_unique<Level>();
  c->n = nc;
  c->own_pattern = std::make_unique<BlockPattern>(nc, coarse_couplings(*f.pattern, f.p_start, f.p_col, nc));
  c->pattern = c->own_pattern.get();
  c->A = &c->own_A;
  c->own_A.reset(*c->pattern);
  c->fixed.assign(nc, 0);
  const BlockPattern& cp = *c->pattern;
  for (int I = 0; I < nc; ++I)
    for (int s = cp.row_start()[I]; s < cp.row_start()[I + 1]; ++s) {
      const int J = cp.column()[s];
      if (J < I) c->lower_mirror.emplace_back(s, cp.slot(J, I));
    }
  gather_galerkin_terms(f, cp);
  levels_.push_back(std::move(c));
}

// The Galerkin product's terms, generated by fine slot and sorted by coarse slot.
void AggregationMultigrid::gather_galerkin_terms(Level& f, const BlockPattern& cp) {
  const auto& rs = f.pattern->row_start();
  const auto& col = f.pattern->column();
  std::vector<int> by_slot;
  std::vector<std::pair<int, double>> entries;  // (fine slot, weight), in generation order
  for (int i = 0; i < f.n; ++i) {
    for (int s = rs[i]; s < rs[i + 1]; ++s) {
      const int j = col[s];
      for (int a = f.p_start[i]; a < f.p_start[i + 1]; ++a) {
        const int I = f.p_col[a];
        for (int b = f.p_start[j]; b < f.p_start[j + 1]; ++b) {
          const int J = f.p_col[b];
          if (J < I) continue;
          by_slot.push_back(cp.slot(I, J));
          entries.emplace_back(s, f.p_w[a] * f.p_w[b]);
        }
      }
    }
  }
  f.g_start.assign(cp.num_blocks() + 1, 0);
  for (int c : by_slot) ++f.g_start[c + 1];
  for (int c = 0; c < cp.num_blocks(); ++c) f.g_start[c + 1] += f.g_start[c];
  f.g_fine.resize(entries.size());
  f.g_w.resize(entries.size());
  std::vector<int> fill(f.g_start.begin(), f.g_start.end() - 1);
  for (size_t k = 0; k < entries.size(); ++k) {
    const int q = fill[by_slot[k]]++;
    f.g_fine[q] = entries[k].first;
    f.g_w[q] = entries[k].second;
  }
}

void AggregationMultigrid::galerkin(int l) {
  const Level& f = *levels_[l];
  Level& c = *levels_[l + 1];
  const BlockMatrix& M = *f.A;
  const double* a = M.block.front().data();
  double* ac = c.own_A.block.front().data();
  const int nc = c.pattern->num_blocks();
  const int* gs = f.g_start.data();
  const int* gf = f.g_fine.data();
  const double* gw = f.g_w.data();
  for (int q = 0; q < nc; ++q) {
    double acc[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    for (int k = gs[q]; k < gs[q + 1]; ++k) {
      const double* m = a + 9L * gf[k];
      const double w = gw[k];
      for (int e = 0; e < 9; ++e) acc[e] += w * m[e];
    }
    copy_block(acc, ac + 9L * q);  // lower blocks (no contributions) are mirrored below
  }
  for (auto [s, m] : c.lower_mirror) c.own_A.block[s] = c.own_A.block[m].transpose();
  for (int I = 0; I < c.n; ++I) {
    Mat3& d = c.own_A.block[c.pattern->diagonal_slot(I)];
    d = 0.5 * (d + d.transpose()).eval();
  }
}

// The smoother's inverse diagonal blocks, symmetrized so that the forward and backward
// sweeps stay exact adjoints of each other; zero on fixed nodes.
void AggregationMultigrid::set_inverse_diagonal(Level& f) {
  const BlockMatrix& M = *f.A;
  for (int i = 0; i < f.n; ++i) {
    Mat3 d = Mat3::Zero();
    if (!f.fixed[i]) {
      d = invert_spd_block(M.block[f.pattern->diagonal_slot(i)]);
      d = (0.5 * (d + d.transpose())).eval();
    }
    copy_block(d.data(), f.dinv_val.data() + 9L * i);
  }
}

void AggregationMultigrid::update(const BlockMatrix& A) {
  if (!is_setup() || A.pattern != pattern_)
    throw std::logic_error("AggregationMultigrid::update: matrix is not on the setup's pattern");
  levels_[0]->A = &A;
  for (int l = 0; l < num_levels(); ++l) {
    Level& f = *levels_[l];
    const BlockMatrix& M = *f.A;
    if (l + 1 < num_levels()) galerkin(l);
    // The compact lower copy (the smoother's, and level 0's product for CG); laid out again
    // if a block kept as a scalar stopped being one.
    if (l == 0 || !f.coarsest) f.lower.assign(M, f.fixed);
    if (!f.coarsest) {
      set_inverse_diagonal(f);
    } else {
      // Dense Cholesky of the coarsest operator; fixed rows and columns become identity.
      f.dense.setZero();
      const auto& rs = f.pattern->row_start();
      const auto& col = f.pattern->column();
      for (int i = 0; i < f.n; ++i) {
        if (f.fixed[i]) {
          f.dense.block<3, 3>(3 * i, 3 * i).setIdentity();
          continue;
        }
        for (int s = rs[i]; s < rs[i + 1]; ++s)
          if (!f.fixed[col[s]]) f.dense.block<3, 3>(3 * i, 3 * col[s]) = M.block[s];
      }
      f.llt.compute(f.dense);
      f.dense_ok = f.llt.info() == Eigen::Success;
      // Without a factor (matrix not SPD to working precision) the coarsest level is
      // smoothed like the others instead.
      if (!f.dense_ok) set_inverse_diagonal(f);
    }
  }
}

void AggregationMultigrid::multiply_free(const VecX& x, VecX& y) const {
  levels_[0]->lower.multiply(x, y);
}

void AggregationMultigrid::apply(const VecX& r, VecX& z) {
  Level& f = *levels_[0];
  f.r = r;
  vcycle(0);
  z = f.x;
}

void AggregationMultigrid::vcycle(int l) {
  Level& f = *levels_[l];
  const int n = f.n;
  const auto& rs = f.pattern->row_start();
  const int* col = f.pattern->column().data();
  const double* a = f.A->block.front().data();
  const int nb = f.pattern->num_blocks();
  const double* r = f.r.data();
  double* x = f.x.data();
  const char* fixed = f.fixed.data();
  const double* inv = f.dinv_val.data();

  if (f.coarsest && f.dense_ok) {
    f.x = f.r;
    for (int i = 0; i < n; ++i)
      if (fixed[i]) f.x.segment<3>(3 * i).setZero();
    f.llt.solveInPlace(f.x);
    for (int i = 0; i < n; ++i)
      if (fixed[i]) f.x.segment<3>(3 * i).setZero();
    return;
  }

  auto forward_sweep = [&]() {
    for (int i = 0; i < n; ++i) {
      if (fixed[i]) continue;
      double y0 = 0, y1 = 0, y2 = 0;
      row_accumulate(a, col, rs[i], rs[i + 1], x, y0, y1, y2);
      const double* xi = x + 3 * i;
      // Remove the diagonal block's own contribution.
      const double* d = a + 9 * f.pattern->diagonal_slot(i);
      y0 -= d[0] * xi[0] + d[3] * xi[1] + d[6] * xi[2];
      y1 -= d[1] * xi[0] + d[4] * xi[1] + d[7] * xi[2];
      y2 -= d[2] * xi[0] + d[5] * xi[1] + d[8] * xi[2];
      solve_node(inv + 9 * i, r[3 * i] - y0, r[3 * i + 1] - y1, r[3 * i + 2] - y2, x + 3 * i);
    }
  };
  auto backward_sweep = [&]() {
    for (int i = n - 1; i >= 0; --i) {
      if (fixed[i]) continue;
      double y0 = 0, y1 = 0, y2 = 0;
      const int dslot = f.pattern->diagonal_slot(i);
      prefetch_range(a, nb, rs[i], rs[i + 1], -kPrefetchBytes);
      row_accumulate_descending(a, col, dslot + 1, rs[i + 1], x, y0, y1, y2);
      row_accumulate_descending(a, col, rs[i], dslot, x, y0, y1, y2);
      solve_node(inv + 9 * i, r[3 * i] - y0, r[3 * i + 1] - y1, r[3 * i + 2] - y2, x + 3 * i);
    }
  };

  // Pre-smoothing: forward Gauss-Seidel from x = 0. The first sweep needs only the strictly
  // lower blocks (later nodes are still zero), and afterwards the residual of row j is
  // -sum_{i > j} A_ji x_i = -sum_{i > j} A_ij^T x_i (A is symmetric), which is scattered
  // from row i's lower blocks while they are in cache: one pass over half of A. With one
  // sweep this runs on the compact lower copy.
  double* t = f.t.data();
  const int sweeps = std::max(1, settings_.smoothing_sweeps);
  const bool fused = sweeps == 1 && !f.coarsest;
  if (fused) {
    f.t.setZero();
    f.lower.forward_sweep(f.dinv_val.data(), r, x, t);
  } else {
    for (int i = 0; i < n; ++i) {
      if (fixed[i]) {
        x[3 * i] = x[3 * i + 1] = x[3 * i + 2] = 0.0;
        continue;
      }
      double y0 = 0, y1 = 0, y2 = 0;
      const int dslot = f.pattern->diagonal_slot(i);
      prefetch_range(a, nb, rs[i], rs[i + 1], kPrefetchBytes);
      row_accumulate(a, col, rs[i], dslot, x, y0, y1, y2);
      solve_node(inv + 9 * i, r[3 * i] - y0, r[3 * i + 1] - y1, r[3 * i + 2] - y2, x + 3 * i);
    }
  }
  if (f.coarsest) {  // no factor: symmetric Gauss-Seidel only
    for (int k = 1; k < sweeps; ++k) forward_sweep();
    for (int k = 0; k < sweeps; ++k) backward_sweep();
    return;
  }
  if (!fused) {
    for (int k = 1; k < sweeps; ++k) forward_sweep();
    for (int i = 0; i < n; ++i) {
      double y0 = 0, y1 = 0, y2 = 0;
      if (!fixed[i]) row_accumulate(a, col, rs[i], rs[i + 1], x, y0, y1, y2);
      t[3 * i] = r[3 * i] - y0;
      t[3 * i + 1] = r[3 * i + 1] - y1;
      t[3 * i + 2] = r[3 * i + 2] - y2;
    }
  }

  // Restriction r_c = P^T t (P has no rows for fixed nodes).
  Level& c = *levels_[l + 1];
  c.r.setZero();
  double* rc = c.r.data();
  const int* ps = f.p_start.data();
  const int* pc = f.p_col.data();
  const double* pw = f.p_w.data();
  for (int i = 0; i < n; ++i) {
    const double t0 = t[3 * i], t1 = t[3 * i + 1], t2 = t[3 * i + 2];
    for (int k = ps[i]; k < ps[i + 1]; ++k) {
      double* o = rc + 3 * pc[k];
      o[0] += pw[k] * t0;
      o[1] += pw[k] * t1;
      o[2] += pw[k] * t2;
    }
  }
  vcycle(l + 1);
  // Prolongation x += P x_c.
  const double* xc = c.x.data();
  for (int i = 0; i < n; ++i) {
    double y0 = 0, y1 = 0, y2 = 0;
    for (int k = ps[i]; k < ps[i + 1]; ++k) {
      const double* v = xc + 3 * pc[k];
      y0 += pw[k] * v[0];
      y1 += pw[k] * v[1];
      y2 += pw[k] * v[2];
    }
    x[3 * i] += y0;
    x[3 * i + 1] += y1;
    x[3 * i + 2] += y2;
  }
  // Post-smoothing: backward Gauss-Seidel, the adjoint of the pre-smoother. On the lower
  // copy, row i's upper part sum_{j > i} A_ij x_j = sum_{j > i} A_ji^T x_j is scattered into
  // t from the rows j already swept (descending), and its lower part gathered from the
  // nodes not swept yet.
  if (!fused) {
    for (int k = 0; k < sweeps; ++k) backward_sweep();
    return;
  }
  f.t.setZero();
  f.lower.backward_sweep(f.dinv_val.data(), r, x, t);
}

}  // namespace weft
