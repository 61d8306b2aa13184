#include "linalg/solution_history.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <stdexcept>
#include <string>

namespace weft {

SolutionHistory::SolutionHistory(int capacity) : capacity_(capacity) {
  if (capacity < 0)
    throw std::invalid_argument("solution history capacity must be >= 0, got " + std::to_string(capacity));
  gram_ = MatX::Zero(capacity, capacity);
}

bool SolutionHistory::guess(const VecX& b, VecX& x) const {
  if (size_ == 0 || b_.rows() != b.size()) return false;
  // The stored b_i are zero on their fixed rows, so b's rows there drop out of b_i . b.
  const VecX g = b_.leftCols(size_).transpose() * b;
  // Normal equations G c = g, solved through G's eigen-decomposition with the directions
  // below 1e-12 of the largest dropped, so nearly parallel right-hand sides do not blow c up.
  Eigen::SelfAdjointEigenSolver<MatX> eig(gram_.topLeftCorner(size_, size_));
  const VecX& lambda = eig.eigenvalues();
  const double cut = 1e-12 * std::max(lambda.cwiseAbs().maxCoeff(), 1e-300);
  VecX proj = eig.eigenvectors().transpose() * g;
  for (int i = 0; i < size_; ++i) proj(i) = lambda(i) > cut ? proj(i) / lambda(i) : 0.0;
  const VecX c = eig.eigenvectors() * proj;
  if (!c.allFinite()) return false;
  x.noalias() = x_.leftCols(size_) * c;
  return true;
}

void SolutionHistory::record(const VecX& b, const std::vector<char>& fixed, const VecX& x) {
  if (capacity_ == 0) return;
  if (b_.rows() != b.size()) {
    b_.resize(b.size(), capacity_);
    x_.resize(b.size(), capacity_);
    clear();
  }
  const int s = next_;
  b_.col(s) = b;
  for (size_t i = 0; i < fixed.size(); ++i)
    if (fixed[i]) b_.col(s).segment<3>(3 * i).setZero();
  x_.col(s) = x;
  size_ = std::min(size_ + 1, capacity_);
  next_ = (next_ + 1) % capacity_;
  // The filled slots are 0..size_-1: they fill in order from 0 after a clear.
  const VecX row = b_.leftCols(size_).transpose() * b_.col(s);
  for (int i = 0; i < size_; ++i) gram_(s, i) = gram_(i, s) = row(i);
}

SolutionHistory::Snapshot SolutionHistory::snapshot() const { return {size_, next_, b_, x_, gram_}; }

void SolutionHistory::restore(const Snapshot& s) {
  const bool fits = s.size >= 0 && s.size <= capacity_ && s.next >= 0 && (s.next < capacity_ || capacity_ == 0) &&
                    s.gram.rows() == capacity_ && s.gram.cols() == capacity_ && s.b.rows() == s.x.rows() &&
                    (s.b.rows() == 0 || (s.b.cols() == capacity_ && s.x.cols() == capacity_));
  if (!fits)
    throw std::invalid_argument("solution history snapshot does not fit a history of capacity " +
                                std::to_string(capacity_));
  size_ = s.size;
  next_ = s.next;
  b_ = s.b;
  x_ = s.x;
  gram_ = s.gram;
}

}  // namespace weft
