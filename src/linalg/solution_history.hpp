#pragma once
// Initial guesses for a sequence of linear solves A_n x_n = b_n whose matrices change little
// from one to the next (the steps of a simulation): the last few right-hand sides and their
// solutions are kept, and the guess for a new right-hand side b is the combination
// sum_i c_i x_i whose right-hand sides fit it best, c minimising |b - sum_i c_i b_i|. Were
// the matrix the same, that combination's residual would be exactly b's part outside the
// span of the b_i. Rows of fixed (filtered) nodes take no part in the fit.
#include <vector>

#include "weft/types.hpp"

namespace weft {

class SolutionHistory {
 public:
  /// Keeps up to `capacity` pairs (b_i, x_i); 0 keeps none (guess always declines).
  explicit SolutionHistory(int capacity = 0);
  int capacity() const { return capacity_; }
  int size() const { return size_; }
  void clear() { size_ = next_ = 0; }
  /// The guess for b, written to x; false (x untouched) when the history is empty or holds
  /// vectors of another size. The fit leaves out the rows `record` was told are fixed.
  bool guess(const VecX& b, VecX& x) const;
  /// Adds b and its solution x, dropping the oldest pair when full. Nodes flagged in
  /// `fixed` (three rows each) are left out of the fits that use this b.
  void record(const VecX& b, const std::vector<char>& fixed, const VecX& x);

  /// Everything a later guess depends on, exactly (checkpoints): the pairs by slot, the
  /// Gram matrix as accumulated (recomputing it could round differently), the fill state.
  struct Snapshot {
    int size = 0, next = 0;
    MatX b, x, gram;
  };
  Snapshot snapshot() const;
  /// Restores a snapshot taken from a history of the same capacity; throws
  /// std::invalid_argument for one that does not fit.
  void restore(const Snapshot& s);

 private:
  int capacity_ = 0, size_ = 0, next_ = 0;  ///< next_: the slot the next record fills
  MatX b_, x_;                              ///< one pair per column; b_ with the fixed rows zeroed
  MatX gram_;                               ///< b_i . b_j, by slot
};

}  // namespace weft
