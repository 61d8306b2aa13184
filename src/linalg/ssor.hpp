#pragma once
// The symmetric block SOR operators of the SSOR-preconditioned conjugate gradient
// (linalg/pcg.hpp, Preconditioner::kSsor), on a copy of the symmetric step matrix laid out for
// SIMD.
//
// The nodes are taken in an order that interleaves kChains stretches of a base order (the
// cloth's rows across its pattern, mesh/mesh.hpp banded_order; else the node numbering), so
// consecutive nodes of a solve are rarely coupled and the processor works on kChains
// independent chains at once. (Gauss-Seidel-type solves need neighbours close together in
// the order: on a scrambled numbering SSOR needs about twice the iterations.) With A = L + D + L^T on the free
// nodes in that order (L strictly lower, D block diagonal) and B = D/omega, it provides the two block-triangular solves (B + L) y = v and (B + L^T) y = v, y = A x and
// y = s D x. Both triangles are kept by rows, so each solve gathers its row's known values and
// writes its own node once. Vectors have four doubles per node (the fourth is zero), so a
// 3x3 block times a node's vector is three four-wide multiply-adds, and a block that is a
// multiple of the identity (the hinge couplings of the bending elements, about half of the
// off-diagonal blocks of a cloth) is stored as one number and applied with one. Each row lists
// its scalar blocks first and its whole blocks by distance, the neighbour solved just before
// last, so little of the row sum waits for it. Fixed nodes are left out and come out zero.
#include <vector>

#include "linalg/block_sparse.hpp"

namespace weft {

class SsorOperator {
 public:
  /// Stretches of the node numbering interleaved in the solves' order.
  static constexpr int kChains = 2;
  /// Copies A's free-node values with relaxation omega in (0, 2), laying the copy out again
  /// when the pattern, fixed set or base order changed or a block stored as a scalar stopped
  /// being one. `base` (a permutation of the nodes, neighbours close together, e.g. rows of a
  /// mesh) is the order whose stretches are interleaved; the nodes' numbering when null.
  void assign(const BlockMatrix& A, const std::vector<char>& fixed, double omega,
              const std::vector<int>* base = nullptr);

  int num_nodes() const { return n_; }
  /// The node at each position of the solves' order; vectors are by position.
  const std::vector<int>& order() const { return order_; }
  double omega() const { return omega_; }
  long num_whole() const { return static_cast<long>(lower_.d_off.size() + upper_.d_off.size()); }
  long num_scalar() const { return static_cast<long>(lower_.s_off.size() + upper_.s_off.size()); }

  /// (B + L) y = v. Vectors are 4 doubles per node; y is zero on fixed nodes.
  void solve_lower(const double* v, double* y) const;
  /// The same solve, returning p . (y + t) (a CG step's curvature, in the same pass).
  double solve_lower_dot(const double* v, double* y, const double* p, const double* t) const;
  /// (B + L^T) y = v; also writes u = cp v + cu (L^T y) when u is not null.
  void solve_upper(const double* v, double* y, double* u = nullptr, double cp = 0, double cu = 0) const;
  /// p = z + beta p, then the upper solve with v = p (one pass: a CG step's new direction);
  /// first, at each node, x += a y with y's old value (the previous step's update of x,
  /// applied while y streams by).
  void step_and_solve_upper(const double* z, double beta, double* p, double* y, double* u, double cp, double cu,
                            double* x, double a) const;
  /// A CG update in one pass: r -= a (q + t), z = s D r; returns r.r and sets rz = r.z.
  /// (x += a t is left to the next step_and_solve_upper or axpy.)
  double update(double a, const double* t, const double* q, double* r, double s, double* z, double& rz) const;
  /// x += a t.
  void axpy(double a, const double* t, double* x) const;
  /// y = A x on the free nodes, zero on fixed nodes.
  void multiply(const double* x, double* y) const;
  /// y = s D x.
  void diagonal_times(double s, const double* x, double* y) const;

  /// 3 doubles per node to 4 (the fourth zero; fixed nodes zero), and back.
  void pad(const VecX& v, VecX& v4) const;
  void unpad(const VecX& v4, VecX& v) const;

 private:
  // One triangle of A by rows: whole blocks (9 column-major doubles each, one spare double
  // at the end for the last four-wide load) and scalar blocks. Columns are kept as offsets
  // into the padded vectors (4 times the position).
  struct Rows {
    std::vector<int> d_start, d_off, d_slot;
    std::vector<double> d_val;
    std::vector<int> s_start, s_off, s_slot;
    std::vector<double> s_val;
    void build(const BlockPattern& pattern, const std::vector<int>& order, const std::vector<int>& position,
               const std::vector<char>& fixed, const double* sample, bool upper);
    /// Copies row (position) p's values from A's blocks; false when a block stored as a
    /// scalar is not a multiple of the identity.
    inline bool fill_row(int p, const double* a);
    /// The rows as raw pointers, taken once per pass (the solves' stores may alias anything,
    /// which would otherwise make the compiler reload the vectors' pointers per node).
    struct View {
      const int *s_start, *s_off, *d_start, *d_off;
      const double *s_val, *d_val;
    };
    View view() const { return {s_start.data(), s_off.data(), d_start.data(), d_off.data(), s_val.data(), d_val.data()}; }
  };
  void build(const BlockMatrix& A, const std::vector<char>& fixed, const std::vector<int>* base);
  template <bool kDot>
  double lower_solve(const double* v, double* y, const double* p, const double* t) const;
  template <bool kStep>
  void upper_solve(const double* z, double beta, double* v, double* y, double* u, double cp, double cu, double* x,
                   double a) const;

  const BlockPattern* pattern_ = nullptr;
  int blocks_ = 0;
  int n_ = 0;
  double omega_ = 1.0;
  std::vector<char> fixed_;
  std::vector<int> base_;  ///< the base order of the last layout (empty: the numbering)
  /// Nodes in the order of the solves (order_[p] is the node at position p), position_ its
  /// inverse, fixed_at_ the fixed flags by position. Vectors and rows are by position.
  std::vector<int> order_, position_;
  std::vector<char> fixed_at_;
  Rows lower_, upper_;
  std::vector<double> diag_;  ///< D_i, 12 doubles per node: three padded columns
  std::vector<double> binv_;  ///< B_i^-1 = omega D_i^-1, likewise (zero on fixed nodes)
};

}  // namespace weft
