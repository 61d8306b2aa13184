#pragma once
// The symmetric block SOR operators of the SSOR-preconditioned conjugate gradient
// (linalg/pcg.hpp, Preconditioner::kSsor), on a copy of the symmetric step matrix laid out for
// SIMD: kLanes lanes of one 32-byte vector, four in double precision (SsorOperator) and eight
// in single precision (SsorOperatorT<float>, whose solves do the same work per group, so about
// half per node).
//
// The nodes are split into kLanes stretches of a base order (the cloth's rows across its
// pattern, mesh/mesh.hpp banded_order; else the node numbering), each of `stretch` nodes
// (the last ones shorter), and a group holds the g-th node of every stretch, one per lane.
// The solves' order takes the groups in turn and a group's lanes in turn. Nodes of one group
// lie a stretch apart in the base order, so on all but tiny meshes they are never coupled and
// a triangular solve works on a whole group at once: each lane runs the same sequence of
// operations as the solve in that order would, so the result is the same. (Gauss-Seidel-type
// solves need neighbours close together in the order: on a scrambled numbering SSOR needs
// about twice the iterations.) With A = L + D + L^T on the free nodes in that order
// (L strictly lower, D block diagonal) and B = D/omega, the operator provides the two
// block-triangular solves (B + L) y = v and (B + L^T) y = v, y = A x and y = s D x.
//
// Vectors are by group: 3 kLanes numbers, the three components of the group's nodes (x0 of
// every lane, then x1, then x2). Only the lower triangle is kept, by rows of groups: an entry
// is a source group, a lane shift (lane k couples to lane k - shift of the source, almost
// always the same lane) and the lanes' 3x3 blocks (zero where a lane has no such coupling),
// applied with nine vector multiply-adds. Entries whose blocks are all multiples of the
// identity (the hinge couplings of the bending elements, about half the off-diagonal blocks of
// a cloth) are stored as one number per lane. The lower solve
// gathers each group's row; the upper solve uses the same rows by columns, adding the
// transposed blocks times a solved group's values to the sums of the groups they couple to.
// The stretch length is chosen near n / kLanes so that the lanes' coupling patterns coincide
// (on a grid, lanes start in the same column and row parity), which keeps the union of their
// entries small. Groups whose nodes are coupled (tiny meshes) are solved lane by lane. Fixed
// nodes and the lanes past the last node hold zero blocks and come out zero. The arrays start
// on cache lines (linalg/aligned_allocator.hpp), so no 32-byte load straddles two.
#include <vector>

#include "linalg/aligned_allocator.hpp"
#include "linalg/block_sparse.hpp"

namespace weft {

template <class T>
class SsorOperatorT {
 public:
  /// Nodes per group: stretches of the base order solved side by side (one 32-byte vector).
  static constexpr int kLanes = 32 / static_cast<int>(sizeof(T));
  /// A vector in the operator's layout.
  using Vector = Eigen::Matrix<T, Eigen::Dynamic, 1>;
  /// Copies A's free-node values with relaxation omega in (0, 2), laying the copy out again
  /// when the pattern, fixed set or base order changed or a block stored as a scalar stopped
  /// being one. `base` (a permutation of the nodes, neighbours close together, e.g. rows of a
  /// mesh) is the order whose stretches are solved side by side; the nodes' numbering when
  /// null.
  /// `all_whole`: keep every block whole, none as a scalar (for matrices whose blocks change
  /// shape from solve to solve, as contact constraints make them: the layout then never
  /// changes, and depends on nothing but the pattern).
  void assign(const BlockMatrix& A, const std::vector<char>& fixed, double omega,
              const std::vector<int>* base = nullptr, bool all_whole = false);

  int num_nodes() const { return n_; }
  int num_groups() const { return groups_; }
  /// Nodes per stretch (= groups).
  int stretch() const { return groups_; }
  /// Numbers in one of the operator's vectors (3 kLanes per group).
  long vector_size() const { return 3L * kLanes * groups_; }
  /// The node at each position of the solves' order (index() places a position in the
  /// operator's vectors).
  const std::vector<int>& order() const { return order_; }
  /// Where component c of the node at position p lies in a vector.
  long index(int p, int c) const {
    return 3L * kLanes * (slot_[p] / kLanes) + kLanes * c + slot_[p] % kLanes;
  }
  double omega() const { return omega_; }
  /// Blocks kept (each coupling once, in the lower triangle, plus both blocks of couplings
  /// inside a group): stored whole, stored as a scalar.
  long num_whole() const;
  long num_scalar() const;
  /// Groups solved lane by lane because their nodes are coupled.
  int num_sequential_groups() const;

  /// (B + L) y = v. y is zero on fixed nodes.
  void solve_lower(const T* v, T* y) const;
  /// The same solve, returning p . (y + t) (a CG step's curvature, in the same pass).
  double solve_lower_dot(const T* v, T* y, const T* p, const T* t) const;
  /// (B + L^T) y = v; also writes u = cp v + cu (L^T y) when u is not null.
  void solve_upper(const T* v, T* y, T* u = nullptr, double cp = 0, double cu = 0) const;
  /// p = z + beta p, then the upper solve with v = p (one pass: a CG step's new direction);
  /// first, at each group, x += a y with y's old value (the previous step's update of x,
  /// applied while y streams by).
  void step_and_solve_upper(const T* z, double beta, T* p, T* y, T* u, double cp, double cu,
                            T* x, double a) const;
  /// A CG update in one pass: r -= a (q + t), z = s D r; returns r.r and sets rz = r.z.
  /// (x += a t is left to the next step_and_solve_upper or axpy.)
  double update(double a, const T* t, const T* q, T* r, double s, T* z, double& rz) const;
  /// x += a t.
  void axpy(double a, const T* t, T* x) const;
  /// y = A x on the free nodes, zero on fixed nodes.
  void multiply(const T* x, T* y) const;
  /// y = s D x.
  void diagonal_times(double s, const T* x, T* y) const;

  /// A node-ordered vector (3 numbers per node) to the operator's layout (zero on fixed nodes
  /// and past the last node), and back.
  void pad(const VecX& v, Vector& g) const;
  void unpad(const Vector& g, VecX& v) const;

 private:
  // The lower triangle of A by rows of groups (upper_ holds only the couplings inside
  // groups solved lane by lane, those to later lanes). Entries of a row: whole blocks of the same
  // lanes (w_), scalar blocks of the same lanes (s_), blocks of shifted lanes (x_, whole) and, in
  // groups whose nodes are coupled, single blocks between lanes of the group (i_). Whole values are
  // 9 kLanes numbers per entry, (3 c + r) kLanes + lane for block entry (r, c); sources are
  // offsets into the vectors (3 kLanes times the group). Slots are A's block slots per entry and
  // lane (-1: none).
  struct Rows {
    std::vector<int> w_start, w_src, w_slot;
    AlignedVector<T> w_val;
    std::vector<int> s_start, s_src, s_slot;
    AlignedVector<T> s_val;
    /// The scalar entries' lanes (indices into s_slot) whose slots are among the matrix's
    /// constant slots (BlockMatrix::constant_slots), and the others.
    std::vector<int> s_constant, s_variable;
    std::vector<int> x_start, x_src, x_shift, x_slot;
    AlignedVector<T> x_val;
    std::vector<int> i_start, i_lane, i_from, i_slot;
    AlignedVector<T> i_val;  ///< 9 numbers per entry, column-major
    /// Copies the values from A's blocks, those of the constant scalar entries only when
    /// `constants`; false when a block stored as a scalar is not a multiple of the identity.
    bool fill(const double* a, bool constants);
  };
  void build(const BlockMatrix& A, const std::vector<char>& fixed, const std::vector<int>* base);
  void build_rows(Rows& rows, const std::vector<char>& whole_slot,
                  const std::vector<char>* constant_slots, bool upper) const;
  template <bool kUpper>
  void lane_by_lane(const Rows& rows, int g, const T* v, T* y, T* acc) const;
  template <bool kDot>
  double lower_solve(const T* v, T* y, const T* p, const T* t) const;
  template <bool kStep>
  void upper_solve(const T* z, double beta, T* v, T* y, T* u, double cp, double cu, T* x,
                   double a) const;

  const BlockPattern* pattern_ = nullptr;
  /// The matrix's constant slots when laid out, and the version of their values copied
  /// (none: 0; the versions start at 1).
  const std::vector<char>* constant_slots_ = nullptr;
  long constant_version_ = 0;
  int blocks_ = 0;
  int n_ = 0;
  int groups_ = 0;
  double omega_ = 1.0;
  std::vector<char> fixed_;
  bool all_whole_ = false;  ///< assign's all_whole of the last layout
  std::vector<int> base_;  ///< the base order of the last layout (empty: the numbering)
  /// order_[p]: the node at position p; slot_[p] = kLanes * group + lane; node_slot_[i] the
  /// slot of node i.
  std::vector<int> order_, slot_, node_slot_;
  Rows lower_, upper_;
  /// D per group: 6 kLanes numbers, the lower triangles of the lanes' symmetric blocks
  /// ((0, 0), (1, 0), (2, 0), (1, 1), (2, 1), (2, 2), every lane each).
  AlignedVector<T> diag_;
  AlignedVector<T> binv_;  ///< B^-1 = omega D^-1 likewise (zero on fixed and absent nodes)
  /// Per slot: A's diagonal block slot and 1.0 for a free node (-1 and 0.0 for fixed and
  /// absent nodes).
  std::vector<int> diag_slot_;
  AlignedVector<T> present_;
  /// The upper solve's row sums, gathered by columns (zero between solves).
  mutable AlignedVector<T> acc_;
};

/// The operator in double precision, four lanes: the one the conjugate gradient uses.
using SsorOperator = SsorOperatorT<double>;
extern template class SsorOperatorT<double>;
extern template class SsorOperatorT<float>;

}  // namespace weft
