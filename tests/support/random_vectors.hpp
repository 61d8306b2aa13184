#pragma once
// Random vectors and pinned-node filtering shared by the solver tests.
#include <random>
#include <vector>

#include "weft/types.hpp"

namespace weft::test {

/// Standard normal entries.
inline VecX random_vector(int size, std::mt19937& rng) {
  std::normal_distribution<double> g;
  VecX v(size);
  for (auto& e : v) e = g(rng);
  return v;
}

/// Zeroes the three entries of every node with fixed[i] != 0.
inline void zero_fixed(const std::vector<char>& fixed, VecX& v) {
  for (size_t i = 0; i < fixed.size(); ++i)
    if (fixed[i]) v.segment<3>(3 * i).setZero();
}

/// A random vector over the nodes of `fixed`, zero on the fixed ones.
inline VecX random_free_vector(const std::vector<char>& fixed, std::mt19937& rng) {
  VecX v = random_vector(3 * static_cast<int>(fixed.size()), rng);
  zero_fixed(fixed, v);
  return v;
}

}  // namespace weft::test
