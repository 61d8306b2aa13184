// Symmetric block SOR preconditioned CG with Eisenstat's trick (linalg/pcg.hpp, kSsor) and
// the triangular solves it is built on (linalg/lower_blocks.hpp), against dense algebra.
#include <gtest/gtest.h>

#include <random>
#include <stdexcept>

#include "linalg/lower_blocks.hpp"
#include "linalg/pcg.hpp"
#include "support/cloth_step_problem.hpp"
#include "support/random_vectors.hpp"

namespace weft {
namespace {

using test::random_vector;
using test::zero_fixed;

// The step matrix on the free nodes as a dense matrix (pinned rows and columns replaced by
// the identity), split into its block-diagonal, strictly lower and strictly upper parts.
struct DenseSplit {
  MatX A, diag, lower, upper;
};

DenseSplit split(const BlockMatrix& M, const std::vector<char>& fixed) {
  const int n = M.pattern->num_nodes();
  DenseSplit s;
  s.A = M.to_dense();
  for (int i = 0; i < n; ++i)
    if (fixed[i]) {
      s.A.middleRows(3 * i, 3).setZero();
      s.A.middleCols(3 * i, 3).setZero();
      s.A.block<3, 3>(3 * i, 3 * i).setIdentity();
    }
  s.diag = s.lower = s.upper = MatX::Zero(3 * n, 3 * n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      MatX& part = j < i ? s.lower : (j > i ? s.upper : s.diag);
      part.block<3, 3>(3 * i, 3 * j) = s.A.block<3, 3>(3 * i, 3 * j);
    }
  return s;
}

// (B + L) y = v and (B + L^T) y = v with B = D/omega, from the compact copy, against dense
// triangular solves; pinned nodes come out zero.
TEST(Ssor, TriangularSolvesMatchDense) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(9, 0.02, p);
  std::vector<char> fixed = p.fixed();
  fixed[40] = 1;
  const int n = 81;
  const double omega = 1.3;
  LowerBlocks L;
  L.assign(p.matrix(), fixed);
  const DenseSplit d = split(p.matrix(), fixed);
  std::vector<double> binv(9 * n, 0.0);
  for (int i = 0; i < n; ++i) {
    if (fixed[i]) continue;
    const Mat3 inv = omega * Mat3(d.diag.block<3, 3>(3 * i, 3 * i)).inverse();
    std::copy_n(inv.data(), 9, binv.data() + 9 * i);
  }
  // On the free nodes B + L is block lower triangular; on pinned nodes y is zero, which the
  // identity rows give for a v that is zero there.
  std::mt19937 rng(4);
  VecX v = random_vector(3 * n, rng);
  zero_fixed(fixed, v);
  const MatX B = d.diag / omega;
  VecX y(3 * n);
  L.solve_lower(binv.data(), v.data(), y.data());
  EXPECT_LE(((B + d.lower) * y - v).norm(), 1e-12 * v.norm());
  VecX acc = VecX::Zero(3 * n);
  v(3 * 40) = 7.0;  // a pinned entry must not be read
  L.solve_upper(binv.data(), v.data(), y.data(), acc.data());
  zero_fixed(fixed, v);
  EXPECT_EQ(y.segment<3>(3 * 40).norm(), 0.0);
  EXPECT_LE(((B + d.upper) * y - v).norm(), 1e-12 * v.norm());
}

// In exact arithmetic CG on the transformed system produces the same iterates as textbook
// PCG with the explicit SSOR preconditioner M^-1 = (B + U)^-1 B (B + L)^-1. After the same
// number of iterations from the same guess both must agree to rounding.
TEST(Ssor, EisenstatIteratesEqualExplicitPreconditioner) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(9, 0.02, p);
  const auto& fixed = p.fixed();
  const double omega = 1.4;
  const DenseSplit d = split(p.matrix(), fixed);
  const MatX B = d.diag / omega;
  VecX b = p.rhs;
  zero_fixed(fixed, b);
  // Block (not scalar) triangular factors: solved densely.
  const Eigen::PartialPivLU<MatX> BL(B + d.lower), BU(B + d.upper);
  auto precondition = [&](const VecX& r) -> VecX { return BU.solve(B * BL.solve(r)); };
  for (int k : {1, 3, 6}) {
    VecX x_ref = VecX::Zero(b.size());
    VecX r = b, z = precondition(r), q = z;
    double rz = r.dot(z);
    for (int it = 0; it < k; ++it) {
      const VecX Aq = d.A * q;
      const double a = rz / q.dot(Aq);
      x_ref += a * q;
      r -= a * Aq;
      z = precondition(r);
      const double rz_new = r.dot(z);
      q = z + rz_new / rz * q;
      rz = rz_new;
    }
    PcgSettings s;
    s.preconditioner = Preconditioner::kSsor;
    s.ssor_omega = omega;
    s.relative_tolerance = 1e-300;
    s.max_iterations = k;
    PcgWorkspace ws;
    VecX x = VecX::Zero(b.size());
    const PcgResult res = solve_pcg(p.matrix(), p.rhs, fixed, s, x, ws);
    EXPECT_EQ(res.iterations, k);
    EXPECT_LE((x - x_ref).norm(), 1e-10 * x_ref.norm()) << k << " iterations";
  }
}

// The reported residual is the true one: |b - A x| <= tol |b| recomputed from the full
// matrix, pinned nodes held at zero, and a new fixed set on the same workspace is honoured.
// The SSOR preconditioner is much stronger than block-Jacobi on the cloth (its iteration
// count grows like the square root of block-Jacobi's for these grid-ordered meshes), so it
// must need clearly fewer iterations.
TEST(Ssor, SolvesToTheTrueResidualInFewerIterationsThanBlockJacobi) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(33, 0.02, p);
  const BlockMatrix& A = p.matrix();
  std::vector<char> fixed = p.fixed();
  PcgWorkspace ws, ws_bj;
  for (int round = 0; round < 2; ++round) {
    if (round == 1) fixed[500] = 1;
    for (double omega : {1.0, 1.5}) {
      PcgSettings s;
      s.relative_tolerance = 1e-8;
      VecX x_bj = p.guess;
      const PcgResult bj = solve_pcg(A, p.rhs, fixed, s, x_bj, ws_bj);
      s.preconditioner = Preconditioner::kSsor;
      s.ssor_omega = omega;
      VecX x = p.guess;
      const PcgResult r = solve_pcg(A, p.rhs, fixed, s, x, ws);
      ASSERT_TRUE(bj.converged);
      ASSERT_TRUE(r.converged);
      EXPECT_LT(2 * r.iterations, bj.iterations) << "omega " << omega;
      VecX b = p.rhs, res;
      zero_fixed(fixed, b);
      for (size_t i = 0; i < fixed.size(); ++i)
        if (fixed[i]) EXPECT_EQ(x.segment<3>(3 * i).norm(), 0.0) << "node " << i;
      A.multiply(x, res);
      res -= b;
      zero_fixed(fixed, res);
      EXPECT_LE(res.norm(), 1e-8 * b.norm());
      EXPECT_NEAR(r.relative_residual, res.norm() / b.norm(), 1e-12);
      EXPECT_LE((x - x_bj).norm(), 1e-5 * x_bj.norm());
    }
  }
}

// Outside 0 < omega < 2 the SSOR operator is not positive definite; the solver refuses.
TEST(Ssor, RejectsRelaxationOutsideTheOpenInterval) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(5, 0.0, p);
  PcgSettings s;
  s.preconditioner = Preconditioner::kSsor;
  PcgWorkspace ws;
  for (double omega : {0.0, 2.0, -1.0}) {
    s.ssor_omega = omega;
    VecX x = p.guess;
    try {
      solve_pcg(p.matrix(), p.rhs, p.fixed(), s, x, ws);
      ADD_FAILURE() << "omega " << omega << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()),
                "SSOR relaxation must be in (0, 2), got " + std::to_string(omega));
    }
  }
}

}  // namespace
}  // namespace weft
