// The solver's compact lower copy of a symmetric block matrix (linalg/lower_blocks.hpp):
// products and Gauss-Seidel sweeps against the full matrix.
#include <gtest/gtest.h>

#include <random>

#include "linalg/lower_blocks.hpp"
#include "support/cloth_step_problem.hpp"
#include "support/random_vectors.hpp"

namespace weft {
namespace {

using test::random_vector;
using test::zero_fixed;

// The cloth's step matrix has whole (membrane) and scalar (bending-only) lower blocks; the
// product from the copy must equal the full product with pinned rows and columns removed.
TEST(LowerBlocks, ProductEqualsFilteredFullProduct) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(17, 0.02, p);
  std::vector<char> fixed = p.pinned();
  fixed[100] = 1;
  LowerBlocks L;
  L.assign(p.matrix(), fixed);
  EXPECT_GT(L.num_scalar(), 0) << "the hinge couplings are multiples of the identity";
  EXPECT_GT(L.num_dense(), 0);
  std::mt19937 rng(1);
  VecX x = random_vector(3 * 17 * 17, rng);
  VecX filtered = x;
  zero_fixed(fixed, filtered);
  VecX expected, got;
  p.matrix().multiply(filtered, expected);
  zero_fixed(fixed, expected);
  L.multiply(x, got);  // x's pinned entries must not be read
  EXPECT_LE((got - expected).norm(), 1e-13 * expected.norm());
}

// Without a sample every block is stored whole; a matrix whose block kept as a scalar is no
// longer one makes fill fail, and assign lays the copy out again.
TEST(LowerBlocks, ScalarLayoutFollowsTheMatrix) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(9, 0.0, p);
  const auto& fixed = p.pinned();
  LowerBlocks whole;
  whole.build(*p.matrix().pattern, fixed, nullptr);
  EXPECT_EQ(whole.num_scalar(), 0);
  ASSERT_TRUE(whole.fill(p.matrix()));

  LowerBlocks L;
  L.assign(p.matrix(), fixed);
  const long scalars = L.num_scalar();
  ASSERT_GT(scalars, 0);
  // Break one scalar block (and its transpose).
  BlockMatrix A = p.matrix();
  ASSERT_TRUE(test::break_one_scalar_block(A, fixed));
  LowerBlocks stale = L;
  EXPECT_FALSE(stale.fill(A));
  L.assign(A, fixed);
  EXPECT_EQ(L.num_scalar(), scalars - 1);
  std::mt19937 rng(2);
  VecX x = random_vector(3 * 81, rng);
  zero_fixed(fixed, x);
  VecX expected, got;
  A.multiply(x, expected);
  zero_fixed(fixed, expected);
  L.multiply(x, got);
  EXPECT_LE((got - expected).norm(), 1e-13 * expected.norm());
}

// The forward sweep solves (D + L) x = r and returns t = r - A x; the backward sweep solves
// (D + U) x' = r - L x. Checked with the dense matrix on the free nodes.
TEST(LowerBlocks, SweepsAreBlockGaussSeidel) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(9, 0.02, p);
  const auto& fixed = p.pinned();
  const int n = 81;
  LowerBlocks L;
  L.assign(p.matrix(), fixed);
  MatX A = p.matrix().to_dense();
  for (int i = 0; i < n; ++i)
    if (fixed[i]) {
      A.middleRows<3>(3 * i).setZero();
      A.middleCols<3>(3 * i).setZero();
      A.block<3, 3>(3 * i, 3 * i).setIdentity();
    }
  MatX lower = MatX::Zero(3 * n, 3 * n), upper = lower, diag = lower;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      MatX& part = j < i ? lower : (j > i ? upper : diag);
      part.block<3, 3>(3 * i, 3 * j) = A.block<3, 3>(3 * i, 3 * j);
    }
  std::vector<double> dinv(9 * n, 0.0);
  for (int i = 0; i < n; ++i) {
    if (fixed[i]) continue;
    const Mat3 inv = Mat3(A.block<3, 3>(3 * i, 3 * i)).inverse();
    std::copy_n(inv.data(), 9, dinv.data() + 9 * i);
  }
  std::mt19937 rng(3);
  VecX r = random_vector(3 * n, rng);
  zero_fixed(fixed, r);
  VecX x = VecX::Zero(3 * n), t = VecX::Zero(3 * n);
  L.forward_sweep(dinv.data(), r.data(), x.data(), t.data());
  EXPECT_LE(((diag + lower) * x - r).norm(), 1e-12 * r.norm());
  VecX residual = r - A * x;
  zero_fixed(fixed, residual);
  EXPECT_LE((t - residual).norm(), 1e-12 * r.norm());

  const VecX before = x;
  VecX acc = VecX::Zero(3 * n);
  L.backward_sweep(dinv.data(), r.data(), x.data(), acc.data());
  VecX rhs = r - lower * before;
  zero_fixed(fixed, rhs);
  EXPECT_LE(((diag + upper) * x - rhs).norm(), 1e-12 * r.norm());
}

}  // namespace
}  // namespace weft

namespace weft {
namespace {

// The diagonal-block inverse the preconditioners share: the inverse of a symmetric positive
// definite block (ill-conditioned ones included), and the inverse of the diagonal's magnitudes
// for a singular or indefinite block.
TEST(BlockInverse, InvertsSymmetricPositiveDefiniteBlocks) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    Mat3 g;
    for (int k = 0; k < 9; ++k) g.data()[k] = u(rng);
    const double shift = trial < 25 ? 0.1 : 1e-6;  // the second half nearly singular
    const Mat3 d = g * g.transpose() + shift * Mat3::Identity();
    const Mat3 inv = invert_spd_block(d);
    const double cond = d.norm() * d.inverse().norm();
    EXPECT_LT((inv * d - Mat3::Identity()).norm(), 1e-13 * cond) << "trial " << trial;
    EXPECT_LT((inv - inv.transpose()).norm(), 1e-14 * inv.norm());
  }
  Mat3 singular = Mat3::Zero();
  singular.diagonal() << 2.0, -4.0, 0.0;
  const Mat3 fallback = invert_spd_block(singular);
  EXPECT_EQ(fallback(0, 0), 0.5);
  EXPECT_EQ(fallback(1, 1), 0.25);
  EXPECT_EQ(fallback(2, 2), 1.0 / 1e-300);  // a zero pivot: the floor
  EXPECT_EQ((fallback - Mat3(fallback.diagonal().asDiagonal())).norm(), 0.0);
}

}  // namespace
}  // namespace weft
