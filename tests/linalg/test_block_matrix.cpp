// BlockMatrix's product against the dense matrix it stands for.
#include <gtest/gtest.h>

#include <random>

#include "linalg/block_sparse.hpp"
#include "support/random_vectors.hpp"

namespace weft {
namespace {

// Random (unsymmetric) blocks on a small pattern, so every entry of every block, the last
// block's included (the product reads it apart from the others), reaches the result.
TEST(BlockMatrix, ProductEqualsDenseProduct) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const BlockPattern P(6, {{0, 1}, {1, 2}, {2, 5}, {3, 4}, {0, 5}, {4, 5}});
  BlockMatrix A;
  A.reset(P);
  for (auto& b : A.block)
    for (int k = 0; k < 9; ++k) b.data()[k] = u(rng);
  const VecX x = test::random_vector(18, rng);
  VecX y;
  A.multiply(x, y);
  const VecX expected = A.to_dense() * x;
  ASSERT_EQ(y.size(), expected.size());
  EXPECT_LE((y - expected).norm(), 1e-14 * expected.norm());
}

}  // namespace
}  // namespace weft
