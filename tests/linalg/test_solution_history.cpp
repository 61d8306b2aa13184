// The warm start's history of solutions (linalg/solution_history.hpp) against dense algebra.
#include <gtest/gtest.h>

#include <random>
#include <stdexcept>

#include "linalg/solution_history.hpp"
#include "support/random_vectors.hpp"

namespace weft {
namespace {

using test::random_vector;

// A random symmetric positive definite matrix of n nodes (3 n rows).
MatX random_spd(int n, std::mt19937& rng) {
  MatX R(3 * n, 3 * n);
  for (int c = 0; c < 3 * n; ++c) R.col(c) = random_vector(3 * n, rng);
  return R * R.transpose() + 3.0 * n * MatX::Identity(3 * n, 3 * n);
}

TEST(SolutionHistory, GuessIsTheSolutionsCombinedAsTheRightHandSidesFit) {
  std::mt19937 rng(11);
  const int n = 5;
  const MatX A = random_spd(n, rng);
  const Eigen::LDLT<MatX> solve(A);
  SolutionHistory history(3);
  const std::vector<char> fixed(n, 0);
  std::vector<VecX> b, x;
  for (int i = 0; i < 3; ++i) {
    b.push_back(random_vector(3 * n, rng));
    x.push_back(solve.solve(b.back()));
    history.record(b.back(), fixed, x.back());
  }
  // A right-hand side in the span of the recorded ones: the guess is its solution.
  const VecX in_span = 2.0 * b[0] - 3.0 * b[1] + 0.5 * b[2];
  VecX g;
  ASSERT_TRUE(history.guess(in_span, g));
  const VecX expected = 2.0 * x[0] - 3.0 * x[1] + 0.5 * x[2];
  EXPECT_LT((g - expected).norm(), 1e-10 * expected.norm());
  // Outside the span: the least-squares combination, whose misfit is orthogonal to every b_i.
  const VecX other = random_vector(3 * n, rng);
  ASSERT_TRUE(history.guess(other, g));
  MatX B(3 * n, 3), X(3 * n, 3);
  for (int i = 0; i < 3; ++i) {
    B.col(i) = b[i];
    X.col(i) = x[i];
  }
  const VecX c = (B.transpose() * B).ldlt().solve(B.transpose() * other);
  EXPECT_LT((g - X * c).norm(), 1e-10 * (X * c).norm());
  EXPECT_LT((B.transpose() * (other - B * c)).norm(), 1e-10 * other.norm() * B.norm());
}

TEST(SolutionHistory, FixedRowsTakeNoPartInTheFit) {
  std::mt19937 rng(12);
  const int n = 4;
  std::vector<char> fixed(n, 0);
  fixed[1] = 1;
  SolutionHistory history(2);
  const VecX b0 = random_vector(3 * n, rng), b1 = random_vector(3 * n, rng);
  const VecX x0 = random_vector(3 * n, rng), x1 = random_vector(3 * n, rng);
  history.record(b0, fixed, x0);
  history.record(b1, fixed, x1);
  // b0 with anything on the fixed node's rows still fits b0 exactly.
  VecX b = b0;
  b.segment<3>(3) = Vec3(1e3, -2e3, 5e2);
  VecX g;
  ASSERT_TRUE(history.guess(b, g));
  EXPECT_LT((g - x0).norm(), 1e-10 * x0.norm());
}

TEST(SolutionHistory, KeepsTheLatestPairsOnly) {
  std::mt19937 rng(13);
  const int n = 4;
  const std::vector<char> fixed(n, 0);
  SolutionHistory history(2);
  std::vector<VecX> b, x;
  for (int i = 0; i < 3; ++i) {
    b.push_back(random_vector(3 * n, rng));
    x.push_back(random_vector(3 * n, rng));
    history.record(b[i], fixed, x[i]);
  }
  EXPECT_EQ(history.size(), 2);
  VecX g;
  ASSERT_TRUE(history.guess(b[2], g));
  EXPECT_LT((g - x[2]).norm(), 1e-10 * x[2].norm());
  ASSERT_TRUE(history.guess(b[1], g));
  EXPECT_LT((g - x[1]).norm(), 1e-10 * x[1].norm());
  ASSERT_TRUE(history.guess(b[0], g));  // dropped: only fitted by b[1] and b[2]
  EXPECT_GT((g - x[0]).norm(), 0.1 * x[0].norm());
}

TEST(SolutionHistory, DeclinesWhenEmptyOrOfAnotherSize) {
  std::mt19937 rng(14);
  SolutionHistory history(3);
  VecX x = VecX::Constant(6, 7.0);
  EXPECT_FALSE(history.guess(random_vector(6, rng), x));
  EXPECT_EQ(x, VecX::Constant(6, 7.0));  // untouched
  history.record(random_vector(6, rng), std::vector<char>(2, 0), random_vector(6, rng));
  EXPECT_FALSE(history.guess(random_vector(9, rng), x));
  EXPECT_EQ(x, VecX::Constant(6, 7.0));
  history.clear();
  EXPECT_FALSE(history.guess(random_vector(6, rng), x));
  SolutionHistory none(0);
  none.record(random_vector(6, rng), std::vector<char>(2, 0), random_vector(6, rng));
  EXPECT_EQ(none.size(), 0);
  EXPECT_FALSE(none.guess(random_vector(6, rng), x));
}

TEST(SolutionHistory, ParallelRightHandSidesGiveAFiniteGuess) {
  std::mt19937 rng(15);
  const std::vector<char> fixed(3, 0);
  const VecX b = random_vector(9, rng), x = random_vector(9, rng);
  SolutionHistory history(3);
  history.record(b, fixed, x);
  history.record(2.0 * b, fixed, 2.0 * x);  // the Gram matrix is singular
  VecX g;
  ASSERT_TRUE(history.guess(3.0 * b, g));
  EXPECT_LT((g - 3.0 * x).norm(), 1e-8 * x.norm());
}

TEST(SolutionHistory, NegativeCapacityIsRejected) {
  try {
    SolutionHistory history(-1);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "solution history capacity must be >= 0, got -1");
  }
}

TEST(SolutionHistory, SnapshotRestoresTheSameGuesses) {
  std::mt19937 rng(7);
  SolutionHistory h(2), copy(2);
  const std::vector<char> fixed(2, 0);
  for (int k = 0; k < 3; ++k) h.record(random_vector(6, rng), fixed, random_vector(6, rng));
  copy.restore(h.snapshot());
  const VecX b = random_vector(6, rng);
  VecX x1, x2;
  ASSERT_TRUE(h.guess(b, x1));
  ASSERT_TRUE(copy.guess(b, x2));
  EXPECT_EQ(x1, x2);
  // The same next slot: both drop the same pair on the next record.
  h.record(b, fixed, x1);
  copy.record(b, fixed, x2);
  EXPECT_EQ(h.snapshot().b, copy.snapshot().b);
  SolutionHistory smaller(1);
  EXPECT_THROW(smaller.restore(h.snapshot()), std::invalid_argument);
}

}  // namespace
}  // namespace weft
