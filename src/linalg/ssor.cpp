#include "linalg/ssor.hpp"

#include "linalg/dispatch.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace weft {

namespace {

// One 32-byte vector of T: four doubles or eight floats, loaded and stored without alignment
// requirements (GCC/Clang vector extension: one AVX register where available, two SSE ones
// otherwise).
template <class T>
struct Simd {
  static constexpr int kLanes = SsorOperatorT<T>::kLanes;
  typedef T V __attribute__((vector_size(32), aligned(alignof(T)), may_alias));
};
template <class T>
using V = typename Simd<T>::V;

template <class T>
inline V<T> load(const T* p) {
  return *reinterpret_cast<const V<T>*>(p);
}
template <class T>
inline void store(T* p, V<T> v) {
  *reinterpret_cast<V<T>*>(p) = v;
}
inline double sum(V<double> v) { return (v[0] + v[1]) + (v[2] + v[3]); }
inline double sum(V<float> v) {
  return (double(v[0]) + double(v[1])) + (double(v[2]) + double(v[3])) + (double(v[4]) + double(v[5])) +
         (double(v[6]) + double(v[7]));
}
template <class T>
inline V<T> splat(double a) {
  return V<T>{} + static_cast<T>(a);
}

// Lane k of the result is lane k - shift of x.
template <int kShift>
inline V<double> rotate_by(V<double> x) {
  return __builtin_shufflevector(x, x, (0 - kShift) & 3, (1 - kShift) & 3, (2 - kShift) & 3, (3 - kShift) & 3);
}
template <int kShift>
inline V<float> rotate_by(V<float> x) {
  return __builtin_shufflevector(x, x, (0 - kShift) & 7, (1 - kShift) & 7, (2 - kShift) & 7, (3 - kShift) & 7,
                                 (4 - kShift) & 7, (5 - kShift) & 7, (6 - kShift) & 7, (7 - kShift) & 7);
}
template <class T>
inline V<T> rotate(V<T> x, int shift) {
  switch (shift) {
    case 1:
      return rotate_by<1>(x);
    case 2:
      return rotate_by<2>(x);
    case 3:
      return rotate_by<3>(x);
    default:
      break;
  }
  if constexpr (Simd<T>::kLanes == 8) {
    switch (shift) {
      case 4:
        return rotate_by<4>(x);
      case 5:
        return rotate_by<5>(x);
      case 6:
        return rotate_by<6>(x);
      case 7:
        return rotate_by<7>(x);
      default:
        break;
    }
  }
  return x;
}

// Three vectors: a component each, a node per lane.
template <class T>
struct V3 {
  V<T> c0, c1, c2;
  V3<T>& operator+=(const V3<T>& o) {
    c0 += o.c0;
    c1 += o.c1;
    c2 += o.c2;
    return *this;
  }
};
template <class T>
inline V3<T> operator-(const V3<T>& a, const V3<T>& b) {
  return {a.c0 - b.c0, a.c1 - b.c1, a.c2 - b.c2};
}
template <class T>
inline V3<T> operator+(const V3<T>& a, const V3<T>& b) {
  return {a.c0 + b.c0, a.c1 + b.c1, a.c2 + b.c2};
}
template <class T>
inline V3<T> operator*(double s, const V3<T>& a) {
  const T t = static_cast<T>(s);
  return {t * a.c0, t * a.c1, t * a.c2};
}
template <class T>
inline V3<T> zero3() {
  const V<T> z = {};
  return {z, z, z};
}
template <class T>
inline V3<T> load3(const T* p) {
  constexpr int L = Simd<T>::kLanes;
  return {load(p), load(p + L), load(p + 2 * L)};
}
template <class T>
inline void store3(T* p, const V3<T>& v) {
  constexpr int L = Simd<T>::kLanes;
  store(p, v.c0);
  store(p + L, v.c1);
  store(p + 2 * L, v.c2);
}
template <class T>
inline V<T> dot3(const V3<T>& a, const V3<T>& b) {
  return a.c0 * b.c0 + a.c1 * b.c1 + a.c2 * b.c2;
}

// The lanes' 3x3 blocks m (9 kLanes numbers, (3 c + r) kLanes + lane) times the lanes' vectors.
template <class T>
inline V3<T> block_times(const T* m, const V3<T>& x) {
  constexpr int L = Simd<T>::kLanes;
  return {load(m) * x.c0 + load(m + 3 * L) * x.c1 + load(m + 6 * L) * x.c2,
          load(m + L) * x.c0 + load(m + 4 * L) * x.c1 + load(m + 7 * L) * x.c2,
          load(m + 2 * L) * x.c0 + load(m + 5 * L) * x.c1 + load(m + 8 * L) * x.c2};
}

// Where entry (r, c) of a symmetric 3x3 block lies among its lower triangle's six entries,
// (0, 0), (1, 0), (2, 0), (1, 1), (2, 1), (2, 2).
constexpr int sym(int r, int c) {
  const int i = r > c ? r : c, j = r > c ? c : r;
  return j == 0 ? i : (j == 1 ? 2 + i : 5);
}

// The lanes' symmetric 3x3 blocks m (6 kLanes numbers, their lower triangles: kLanes sym(r, c)
// + lane) times the lanes' vectors.
template <class T>
inline V3<T> symmetric_block_times(const T* m, const V3<T>& x) {
  constexpr int L = Simd<T>::kLanes;
  const V<T> m00 = load(m), m10 = load(m + L), m20 = load(m + 2 * L), m11 = load(m + 3 * L),
             m21 = load(m + 4 * L), m22 = load(m + 5 * L);
  return {m00 * x.c0 + m10 * x.c1 + m20 * x.c2, m10 * x.c0 + m11 * x.c1 + m21 * x.c2,
          m20 * x.c0 + m21 * x.c1 + m22 * x.c2};
}

// The lanes' transposed blocks times their vectors: sum_r m(r, c) x_r.
template <class T>
inline V3<T> block_transpose_times(const T* m, const V3<T>& x) {
  constexpr int L = Simd<T>::kLanes;
  return {load(m) * x.c0 + load(m + L) * x.c1 + load(m + 2 * L) * x.c2,
          load(m + 3 * L) * x.c0 + load(m + 4 * L) * x.c1 + load(m + 5 * L) * x.c2,
          load(m + 6 * L) * x.c0 + load(m + 7 * L) * x.c1 + load(m + 8 * L) * x.c2};
}

// The raw pointers of one triangular half's rows, taken once per pass (the solves' stores may
// alias anything, which would otherwise make the compiler reload the vectors' pointers).
template <class T>
struct View {
  const int *w_start, *w_src, *s_start, *s_src, *x_start, *x_src, *x_shift, *i_start;
  const T *w_val, *s_val, *x_val;
};

template <class T, class Rows>
View<T> view_of(const Rows& r) {
  return {r.w_start.data(), r.w_src.data(),   r.s_start.data(), r.s_src.data(), r.x_start.data(),
          r.x_src.data(),   r.x_shift.data(), r.i_start.data(), r.w_val.data(),  r.s_val.data(),
          r.x_val.data()};
}

// The group's row of the lower triangle times x, except the couplings inside the group. The
// scalar blocks are summed apart from the whole ones, so the sums' chains are short.
template <class T>
__attribute__((always_inline)) inline V3<T> row_times(const View<T>& r, int g, const T* x) {
  constexpr int L = Simd<T>::kLanes;
  V3<T> a = zero3<T>(), b = zero3<T>();
  for (int e = r.s_start[g], end = r.s_start[g + 1]; e < end; ++e) {
    const V<T> s = load(r.s_val + static_cast<long>(L) * e);
    const V3<T> xj = load3(x + r.s_src[e]);
    b += V3<T>{s * xj.c0, s * xj.c1, s * xj.c2};
  }
  for (int e = r.x_start[g], end = r.x_start[g + 1]; e < end; ++e) {
    const T* xj = x + r.x_src[e];
    const int shift = r.x_shift[e];
    b += block_times(r.x_val + 9L * L * e, V3<T>{rotate<T>(load(xj), shift), rotate<T>(load(xj + L), shift),
                                                 rotate<T>(load(xj + 2 * L), shift)});
  }
  for (int e = r.w_start[g], end = r.w_start[g + 1]; e < end; ++e)
    a += block_times(r.w_val + 9L * L * e, load3(x + r.w_src[e]));
  a += b;
  return a;
}

// The transpose of the group's row of the lower triangle times the group's y, added to the
// source groups' sums: acc_src += M^T y (rotated back to the source's lanes).
template <class T>
__attribute__((always_inline)) inline void add_column_times(const View<T>& r, int g, const V3<T>& y, T* acc) {
  constexpr int L = Simd<T>::kLanes;
  for (int e = r.s_start[g], end = r.s_start[g + 1]; e < end; ++e) {
    const V<T> s = load(r.s_val + static_cast<long>(L) * e);
    T* a = acc + r.s_src[e];
    store3(a, load3(a) + V3<T>{s * y.c0, s * y.c1, s * y.c2});
  }
  for (int e = r.x_start[g], end = r.x_start[g + 1]; e < end; ++e) {
    const V3<T> t = block_transpose_times(r.x_val + 9L * L * e, y);
    const int back = (L - r.x_shift[e]) & (L - 1);
    T* a = acc + r.x_src[e];
    store3(a, load3(a) + V3<T>{rotate<T>(t.c0, back), rotate<T>(t.c1, back), rotate<T>(t.c2, back)});
  }
  for (int e = r.w_start[g], end = r.w_start[g + 1]; e < end; ++e) {
    T* a = acc + r.w_src[e];
    store3(a, load3(a) + block_transpose_times(r.w_val + 9L * L * e, y));
  }
}

// The lanes' blocks of a (9 doubles each at the slots, zeros where a slot is -1) to each
// entry's 9 kLanes numbers: in double precision two 4x4 transposes and the last entries, in
// single precision entry by entry.
template <class T>
WEFT_HOT_KERNEL void copy_lanes(const double* a, const std::vector<int>& slot, AlignedVector<T>& val) {
  constexpr int L = Simd<T>::kLanes;
  static const double kZero[9] = {};
  const long entries = static_cast<long>(slot.size()) / L;
  for (long e = 0; e < entries; ++e) {
    const double* m[L];
    for (int k = 0; k < L; ++k) m[k] = slot[L * e + k] < 0 ? kZero : a + 9L * slot[L * e + k];
    T* d = val.data() + 9L * L * e;
    if constexpr (L == 4) {
      for (int h = 0; h < 8; h += 4) {
        const V<double> r0 = load(m[0] + h), r1 = load(m[1] + h), r2 = load(m[2] + h), r3 = load(m[3] + h);
        const V<double> t0 = __builtin_shufflevector(r0, r1, 0, 4, 2, 6),
                        t1 = __builtin_shufflevector(r0, r1, 1, 5, 3, 7);
        const V<double> t2 = __builtin_shufflevector(r2, r3, 0, 4, 2, 6),
                        t3 = __builtin_shufflevector(r2, r3, 1, 5, 3, 7);
        store(d + 4 * h, __builtin_shufflevector(t0, t2, 0, 1, 4, 5));
        store(d + 4 * h + 4, __builtin_shufflevector(t1, t3, 0, 1, 4, 5));
        store(d + 4 * h + 8, __builtin_shufflevector(t0, t2, 2, 3, 6, 7));
        store(d + 4 * h + 12, __builtin_shufflevector(t1, t3, 2, 3, 6, 7));
      }
      store(d + 32, V<double>{m[0][8], m[1][8], m[2][8], m[3][8]});
    } else {
      for (int q = 0; q < 9; ++q)
        for (int k = 0; k < L; ++k) d[L * q + k] = static_cast<T>(m[k][q]);
    }
  }
}

// The cost of a layout with `stretch` nodes per lane, roughly in multiply-adds per
// triangular solve: per group the diagonal solve and, per entry of the lower triangle (both
// solves use it), 21 for four whole blocks, 7 for four scalars, more for shifted lanes
// and much more for a group solved lane by lane. Only every `every`-th group is counted.
template <int kLanes>
double layout_cost(const BlockPattern& pattern, const std::vector<char>& whole_slot,
                   const std::vector<char>& fixed, const std::vector<int>& base,
                   const std::vector<int>& where, int stretch, int every, std::vector<long>& keys) {
  const int n = pattern.num_nodes();
  const auto& rs = pattern.row_start();
  const auto& col = pattern.column();
  double cost = 0;
  for (int g = 0; g < stretch; g += every) {
    keys.clear();
    int inside = 0;
    for (int k = 0; k < kLanes; ++k) {
      const long m = static_cast<long>(k) * stretch + g;
      if (m >= n) break;
      const int i = base[m];
      if (fixed[i]) continue;
      for (int s = rs[i]; s < rs[i + 1]; ++s) {
        const int j = col[s];
        if (j == i || fixed[j]) continue;
        const int gj = where[j] % stretch, kj = where[j] / stretch;
        if (gj > g || (gj == g && kj > k)) continue;
        if (gj == g) {
          ++inside;
          continue;
        }
        const int shift = (k - kj) & (kLanes - 1);
        keys.push_back((static_cast<long>(gj) * kLanes + shift) * 2 +
                       (shift != 0 || whole_slot[s]));
      }
    }
    std::sort(keys.begin(), keys.end());
    double c = 24;
    for (size_t e = 0; e < keys.size(); ++e) {
      if (e + 1 < keys.size() && keys[e + 1] / 2 == keys[e] / 2)
        continue;  // an entry's last key: whole if any lane is
      const bool shifted = (keys[e] / 2) % kLanes != 0;
      c += shifted ? 30 : (keys[e] % 2 ? 21 : 7);
    }
    if (inside > 0) c += 60 + 20 * inside;
    cost += c;
  }
  return cost;
}

}  // namespace

template <class T>
long SsorOperatorT<T>::num_whole() const {
  long count = 0;
  for (const Rows* r : {&lower_, &upper_}) {
    for (int s : r->w_slot) count += s >= 0;
    for (int s : r->x_slot) count += s >= 0;
    count += static_cast<long>(r->i_slot.size());
  }
  return count;
}

template <class T>
long SsorOperatorT<T>::num_scalar() const {
  long count = 0;
  for (const Rows* r : {&lower_, &upper_})
    for (int s : r->s_slot) count += s >= 0;
  return count;
}

template <class T>
int SsorOperatorT<T>::num_sequential_groups() const {
  int count = 0;
  for (int g = 0; g < groups_; ++g) count += lower_.i_start[g] != lower_.i_start[g + 1];
  return count;
}

template <class T>
bool SsorOperatorT<T>::Rows::fill(const double* a, bool constants) {
  copy_lanes(a, w_slot, w_val);
  copy_lanes(a, x_slot, x_val);
  // The constant scalar entries (the hinge couplings of a cloth, scattered through A) are
  // read again only when they changed.
  const auto fill_scalars = [&](const std::vector<int>& entries) {
    for (const int e : entries) {
      const double* m = a + 9L * s_slot[e];
      if (!is_multiple_of_identity(m)) return false;
      s_val[e] = static_cast<T>(m[0]);
    }
    return true;
  };
  if (!fill_scalars(s_variable) || (constants && !fill_scalars(s_constant))) return false;
  for (size_t e = 0; e < i_slot.size(); ++e) for (int q = 0; q < 9; ++q) i_val[9 * e + q] = static_cast<T>(a[9L * i_slot[e] + q]);
  return true;
}

template <class T>
void SsorOperatorT<T>::build_rows(Rows& rows, const std::vector<char>& whole_slot,
                              const std::vector<char>* constant_slots, bool upper) const {
  const auto& rs = pattern_->row_start();
  const auto& col = pattern_->column();
  std::vector<int> slot_node(static_cast<size_t>(kLanes) * groups_, -1);
  for (int i = 0; i < n_; ++i) slot_node[node_slot_[i]] = i;
  for (auto* v : {&rows.w_src, &rows.w_slot, &rows.s_src, &rows.s_slot, &rows.x_src, &rows.x_shift,
                  &rows.x_slot, &rows.i_lane, &rows.i_from, &rows.i_slot})
    v->clear();
  for (auto* v : {&rows.w_start, &rows.s_start, &rows.x_start, &rows.i_start})
    v->assign(groups_ + 1, 0);
  struct Link {
    long key;  // source group * kLanes + lane shift
    int lane, slot;
  };
  std::vector<Link> links;
  for (int g = 0; g < groups_; ++g) {
    links.clear();
    for (int k = 0; k < kLanes; ++k) {
      const int here = kLanes * g + k;
      const int i = slot_node[here];
      if (i < 0 || fixed_[i]) continue;
      for (int s = rs[i]; s < rs[i + 1]; ++s) {
        const int j = col[s];
        if (j == i || fixed_[j]) continue;
        const int sj = node_slot_[j];
        if ((sj > here) != upper) continue;
        const int gj = sj / kLanes, kj = sj % kLanes;
        if (gj == g) {
          rows.i_lane.push_back(k);
          rows.i_from.push_back(kj);
          rows.i_slot.push_back(s);
          continue;
        }
        if (!upper)
          links.push_back({static_cast<long>(gj) * kLanes + ((k - kj) & (kLanes - 1)), k, s});
      }
    }
    // By source group, the farthest from the diagonal first (only the lower rows have any).
    std::sort(links.begin(), links.end(),
              [](const Link& a, const Link& b) { return a.key < b.key; });
    for (size_t e = 0; e < links.size();) {
      size_t end = e;
      bool whole = links[e].key % kLanes != 0;
      for (; end < links.size() && links[end].key == links[e].key; ++end)
        if (whole_slot[links[end].slot]) whole = true;
      const int src = static_cast<int>(3 * kLanes * (links[e].key / kLanes)),
                shift = static_cast<int>(links[e].key % kLanes);
      std::vector<int>& slots = shift ? rows.x_slot : (whole ? rows.w_slot : rows.s_slot);
      if (shift) {
        rows.x_src.push_back(src);
        rows.x_shift.push_back(shift);
      } else {
        (whole ? rows.w_src : rows.s_src).push_back(src);
      }
      const size_t first = slots.size();
      slots.resize(first + kLanes, -1);
      for (; e < end; ++e) slots[first + links[e].lane] = links[e].slot;
    }
    rows.w_start[g + 1] = static_cast<int>(rows.w_src.size());
    rows.s_start[g + 1] = static_cast<int>(rows.s_src.size());
    rows.x_start[g + 1] = static_cast<int>(rows.x_src.size());
    rows.i_start[g + 1] = static_cast<int>(rows.i_slot.size());
  }
  rows.w_val.assign(9 * kLanes * rows.w_src.size(), 0.0);
  rows.x_val.assign(9 * kLanes * rows.x_src.size(), 0.0);
  rows.s_val.assign(kLanes * rows.s_src.size(), 0.0);
  rows.s_constant.clear();
  rows.s_variable.clear();
  for (size_t e = 0; e < rows.s_slot.size(); ++e)
    if (rows.s_slot[e] >= 0)
      (constant_slots && (*constant_slots)[rows.s_slot[e]] ? rows.s_constant : rows.s_variable)
          .push_back(static_cast<int>(e));
  rows.i_val.assign(9 * rows.i_slot.size(), 0.0);
}

template <class T>
void SsorOperatorT<T>::build(const BlockMatrix& A, const std::vector<char>& fixed,
                         const std::vector<int>* base) {
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
      throw std::invalid_argument("SSOR node order is not a permutation of the " +
                                  std::to_string(n_) + " nodes");
  }
  std::vector<int> b = base_;
  if (b.empty()) {
    b.resize(n_);
    std::iota(b.begin(), b.end(), 0);
  }
  std::vector<int> where(n_);
  for (int m = 0; m < n_; ++m) where[b[m]] = m;
  const double* a = A.block.front().data();
  std::vector<char> whole_slot(blocks_);
  for (int s = 0; s < blocks_; ++s) whole_slot[s] = all_whole_ || !is_multiple_of_identity(a + 9L * s);
  // The stretch: at least n / kLanes; a little more when that lines the lanes' patterns up
  // (on a grid, within two rows).
  const int shortest = std::max(1, (n_ + kLanes - 1) / kLanes);
  const int window = std::min(shortest, 2 * static_cast<int>(std::ceil(std::sqrt(n_))) + 8);
  std::vector<long> keys;
  double best_cost = 0;
  groups_ = shortest;
  // Sampling a few hundred groups (prime spacing, so that on a grid they fall at every
  // column) ranks the candidates as well as counting them all.
  int every = 1;
  for (int p : {3, 7, 13, 29, 61, 127})
    if (shortest / p >= 150) every = p;
  for (int s = shortest; s <= shortest + window; ++s) {
    const double cost = layout_cost<kLanes>(*pattern_, whole_slot, fixed, b, where, s, every, keys);
    if (s == shortest || cost < best_cost) {
      best_cost = cost;
      groups_ = s;
    }
  }
  order_.clear();
  slot_.clear();
  node_slot_.assign(n_, -1);
  for (int g = 0; g < groups_; ++g)
    for (int k = 0; k < kLanes; ++k) {
      const long m = static_cast<long>(k) * groups_ + g;
      if (m >= n_) continue;
      order_.push_back(b[m]);
      slot_.push_back(kLanes * g + k);
      node_slot_[b[m]] = kLanes * g + k;
    }
  constant_slots_ = A.constant_slots && static_cast<int>(A.constant_slots->size()) == blocks_
                        ? A.constant_slots
                        : nullptr;
  constant_version_ = 0;
  build_rows(lower_, whole_slot, constant_slots_, false);
  build_rows(upper_, whole_slot, constant_slots_, true);
  // Fixed and absent nodes keep zero diagonal blocks; assign writes the rest.
  diag_.assign(6L * kLanes * groups_, 0.0);
  binv_.assign(6L * kLanes * groups_, 0.0);
  acc_.assign(3L * kLanes * groups_, 0.0);
  diag_slot_.assign(static_cast<size_t>(kLanes) * groups_, -1);
  present_.assign(static_cast<size_t>(kLanes) * groups_, 0.0);
  for (int p = 0; p < n_; ++p)
    if (!fixed_[order_[p]]) {
      diag_slot_[slot_[p]] = pattern_->diagonal_slot(order_[p]);
      present_[slot_[p]] = 1.0;
    }
}

template <class T>
WEFT_HOT_KERNEL void SsorOperatorT<T>::assign(const BlockMatrix& A, const std::vector<char>& fixed, double omega,
                          const std::vector<int>* base, bool all_whole) {
  const bool same = all_whole == all_whole_ && pattern_ == A.pattern && blocks_ == A.pattern->num_blocks() &&
                    n_ == A.pattern->num_nodes() && fixed_ == fixed &&
                    (base ? *base == base_ : base_.empty()) &&
                    (constant_slots_ == A.constant_slots || !constant_slots_);
  all_whole_ = all_whole;
  if (!same) build(A, fixed, base);
  omega_ = omega;
  const double* a = A.block.front().data();
  for (int pass = 0; pass < 2; ++pass) {
    const bool constants = !constant_slots_ || A.constant_version != constant_version_;
    if (lower_.fill(a, constants) && upper_.fill(a, constants)) break;
    build(A, fixed, base);  // a block stored as a scalar stopped being one: lay out again
  }
  constant_version_ = constant_slots_ ? A.constant_version : 0;
  // D by lanes, and B^-1 = omega D^-1 four lanes at a time from the symmetric cofactors of
  // D's lower triangle (a lane whose D is numerically singular takes invert_spd_block's
  // fallback; fixed and absent lanes stay zero).
  for (int g = 0; g < groups_; ++g) {
    T* d = diag_.data() + 6L * kLanes * g;
    for (int k = 0; k < kLanes; ++k) {
      const int slot = diag_slot_[kLanes * g + k];
      if (slot < 0) continue;  // stays zero
      const double* m = a + 9L * slot;  // column-major: (r, c) at 3 c + r
      for (int c = 0; c < 3; ++c)
        for (int r = c; r < 3; ++r) d[kLanes * sym(r, c) + k] = m[3 * c + r];
    }
    const V<T> a00 = load(d), a10 = load(d + kLanes), a20 = load(d + 2 * kLanes), a11 = load(d + 3 * kLanes),
             a21 = load(d + 4 * kLanes), a22 = load(d + 5 * kLanes);
    const V<T> c00 = a11 * a22 - a21 * a21, c10 = a20 * a21 - a10 * a22, c20 = a10 * a21 - a20 * a11;
    const V<T> c11 = a00 * a22 - a20 * a20, c21 = a10 * a20 - a00 * a21, c22 = a00 * a11 - a10 * a10;
    const V<T> det = a00 * c00 + a10 * c10 + a20 * c20;
    const V<T> present = load(present_.data() + static_cast<long>(kLanes) * g);
    const V<T> s = present * (static_cast<T>(omega) / (det + (T(1) - present)));  // 0 on fixed and absent lanes
    T* bi = binv_.data() + 6L * kLanes * g;
    store(bi, s * c00);
    store(bi + kLanes, s * c10);
    store(bi + 2 * kLanes, s * c20);
    store(bi + 3 * kLanes, s * c11);
    store(bi + 4 * kLanes, s * c21);
    store(bi + 5 * kLanes, s * c22);
    for (int k = 0; k < kLanes; ++k) {
      if (present[k] == 0.0 || (det[k] > 0 && std::isfinite(det[k]))) continue;
      const Mat3 inv = omega * invert_spd_block(A.block[diag_slot_[kLanes * g + k]]);
      for (int c = 0; c < 3; ++c)
        for (int r = c; r < 3; ++r) bi[kLanes * sym(r, c) + k] = inv(r, c);
    }
  }
}

// Solves group g lane by lane when its nodes are coupled: acc (3 kLanes numbers, laid out as a
// group's vector) holds the row sums from the other groups; each lane adds its couplings to
// the lanes solved before it in this solve's direction, then solves. v is the group's
// right-hand side.
template <class T>
template <bool kUpper>
void SsorOperatorT<T>::lane_by_lane(const Rows& rows, int g, const T* v, T* y,
                                T* acc) const {
  const T* bi = binv_.data() + 6L * kLanes * g;
  T* yg = y + 3L * kLanes * g;
  for (int kk = 0; kk < kLanes; ++kk) {
    const int k = kUpper ? kLanes - 1 - kk : kk;
    for (int e = rows.i_start[g]; e < rows.i_start[g + 1]; ++e) {
      if (rows.i_lane[e] != k) continue;
      const T* m = rows.i_val.data() + 9L * e;
      for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) acc[kLanes * r + k] += m[3 * c + r] * yg[kLanes * c + rows.i_from[e]];
    }
    double w[3];
    for (int r = 0; r < 3; ++r) w[r] = v[kLanes * r + k] - acc[kLanes * r + k];
    for (int r = 0; r < 3; ++r) {
      double s = 0;
      for (int c = 0; c < 3; ++c) s += bi[kLanes * sym(r, c) + k] * w[c];
      yg[kLanes * r + k] = s;
    }
  }
}

template <class T>
void SsorOperatorT<T>::solve_lower(const T* v, T* y) const {
  lower_solve<false>(v, y, nullptr, nullptr);
}

template <class T>
double SsorOperatorT<T>::solve_lower_dot(const T* v, T* y, const T* p,
                                     const T* t) const {
  return lower_solve<true>(v, y, p, t);
}

// Group by group: y_g = B_g^-1 (v_g - sum of the row's blocks times the y's solved before).
template <class T>
template <bool kDot>
WEFT_HOT_KERNEL double SsorOperatorT<T>::lower_solve(const T* v, T* y, const T* p,
                                 const T* t) const {
  const View<T> rows = view_of<T>(lower_);
  const T* binv = binv_.data();
  V<T> dot = {};
  for (int g = 0; g < groups_; ++g) {
    const long o = 3L * kLanes * g;
    const V3<T> rest = row_times(rows, g, y);
    V3<T> yg;
    if (rows.i_start[g] == rows.i_start[g + 1]) {
      yg = symmetric_block_times(binv + 6L * kLanes * g, load3(v + o) - rest);
      store3(y + o, yg);
    } else {
      T acc[3 * kLanes];
      store3(acc, rest);
      lane_by_lane<false>(lower_, g, v + o, y, acc);
      yg = load3(y + o);
    }
    if constexpr (kDot) {
      const V3<T> tg = load3(t + o);
      dot += dot3(load3(p + o), V3<T>{yg.c0 + tg.c0, yg.c1 + tg.c1, yg.c2 + tg.c2});
    }
  }
  return sum(dot);
}

template <class T>
void SsorOperatorT<T>::solve_upper(const T* v, T* y, T* u, double cp, double cu) const {
  upper_solve<false>(nullptr, 0.0, const_cast<T*>(v), y, u, cp, cu, nullptr, 0.0);
}

template <class T>
void SsorOperatorT<T>::step_and_solve_upper(const T* z, double beta, T* p, T* y,
                                        T* u, double cp, double cu, T* x,
                                        double a) const {
  upper_solve<true>(z, beta, p, y, u, cp, cu, x, a);
}

// From the last group down: y_g = B_g^-1 (v_g - s_g), where s_g, the sum of L^T's row
// times the y's solved before, has been gathered in acc_ by columns: once y_g is known, the
// transposes of its lower row's blocks times y_g go to the groups they couple to (all
// solved later). Only the lower triangle is kept. s_g is also u's L^T y; acc_ is left zero.
template <class T>
template <bool kStep>
WEFT_HOT_KERNEL void SsorOperatorT<T>::upper_solve(const T* z, double beta, T* v, T* y, T* u,
                               double cp, double cu, T* x, double a) const {
  const View<T> rows = view_of<T>(lower_);
  const T* binv = binv_.data();
  T* acc = acc_.data();
  const V3<T> zero = zero3<T>();
  const T tb = static_cast<T>(beta), ta = static_cast<T>(a), tcp = static_cast<T>(cp), tcu = static_cast<T>(cu);
  for (int g = groups_ - 1; g >= 0; --g) {
    const long o = 3L * kLanes * g;
    V3<T> vg = load3(v + o);
    if constexpr (kStep) {
      const V3<T> zg = load3(z + o);
      vg = V3<T>{zg.c0 + tb * vg.c0, zg.c1 + tb * vg.c1, zg.c2 + tb * vg.c2};
      store3(v + o, vg);
      if (a != 0.0)  // y still holds the previous step's values here
        for (int c = 0; c < 3 * kLanes; c += kLanes) store(x + o + c, load(x + o + c) + ta * load(y + o + c));
    }
    V3<T> sum = load3(acc + o);
    store3(acc + o, zero);
    V3<T> yg;
    if (upper_.i_start[g] == upper_.i_start[g + 1]) {  // no couplings inside the group
      yg = symmetric_block_times(binv + 6L * kLanes * g, vg - sum);
      store3(y + o, yg);
    } else {
      T s[3 * kLanes];
      store3(s, sum);
      lane_by_lane<true>(upper_, g, v + o, y, s);
      sum = load3(s);
      yg = load3(y + o);
    }
    if (u)
      store3(u + o,
             V3<T>{tcp * vg.c0 + tcu * sum.c0, tcp * vg.c1 + tcu * sum.c1, tcp * vg.c2 + tcu * sum.c2});
    add_column_times(rows, g, yg, acc);
  }
}

template <class T>
WEFT_HOT_KERNEL double SsorOperatorT<T>::update(double a, const T* t, const T* q, T* r, double s,
                            T* z, double& rz) const {
  V<T> rr4 = {}, rz4 = {};
  const T* diag = diag_.data();
  for (int g = 0; g < groups_; ++g) {
    const long o = 3L * kLanes * g;
    const V3<T> qg = load3(q + o), tg = load3(t + o);
    const V3<T> rg = load3(r + o) - a * V3<T>{qg.c0 + tg.c0, qg.c1 + tg.c1, qg.c2 + tg.c2};
    store3(r + o, rg);
    const V3<T> zg = s * symmetric_block_times(diag + 6L * kLanes * g, rg);
    store3(z + o, zg);
    rr4 += dot3(rg, rg);
    rz4 += dot3(rg, zg);
  }
  rz = sum(rz4);
  return sum(rr4);
}

template <class T>
WEFT_HOT_KERNEL void SsorOperatorT<T>::axpy(double a, const T* t, T* x) const {
  const T ta = static_cast<T>(a);
  for (long k = 0; k < vector_size(); k += kLanes) store(x + k, load(x + k) + ta * load(t + k));
}

// A x = D x + L x + L^T x: by groups, the diagonal and lower row (gathered), then the
// transposes of the lower row's blocks times x_g added to the earlier groups they couple to.
template <class T>
WEFT_HOT_KERNEL void SsorOperatorT<T>::multiply(const T* x, T* y) const {
  const View<T> lower = view_of<T>(lower_);
  const T* diag = diag_.data();
  for (int g = 0; g < groups_; ++g) {
    const long o = 3L * kLanes * g;
    const V3<T> xg = load3(x + o);
    store3(y + o, symmetric_block_times(diag + 6L * kLanes * g, xg) + row_times(lower, g, x));
    for (const Rows* rows : {&lower_, &upper_})
      for (int e = rows->i_start[g]; e < rows->i_start[g + 1]; ++e) {
        const T* m = rows->i_val.data() + 9L * e;
        const int k = rows->i_lane[e], from = rows->i_from[e];
        for (int c = 0; c < 3; ++c)
          for (int r = 0; r < 3; ++r) y[o + kLanes * r + k] += m[3 * c + r] * x[o + kLanes * c + from];
      }
    add_column_times(lower, g, xg, y);
  }
}

template <class T>
void SsorOperatorT<T>::diagonal_times(double s, const T* x, T* y) const {
  const T* diag = diag_.data();
  for (int g = 0; g < groups_; ++g)
    store3(y + 3L * kLanes * g, s * symmetric_block_times(diag + 6L * kLanes * g, load3(x + 3L * kLanes * g)));
}

template <class T>
void SsorOperatorT<T>::pad(const VecX& v, Vector& g) const {
  g.setZero(vector_size());
  for (int p = 0; p < n_; ++p)
    if (!fixed_[order_[p]])
      for (int c = 0; c < 3; ++c) g(index(p, c)) = static_cast<T>(v(3 * order_[p] + c));
}

template <class T>
void SsorOperatorT<T>::unpad(const Vector& g, VecX& v) const {
  v.resize(3L * n_);
  for (int p = 0; p < n_; ++p)
    for (int c = 0; c < 3; ++c) v(3 * order_[p] + c) = g(index(p, c));
}

template class SsorOperatorT<double>;
template class SsorOperatorT<float>;

}  // namespace weft
