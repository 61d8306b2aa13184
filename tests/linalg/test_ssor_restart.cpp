// The single-precision SSOR solve's restart rule (src/linalg/pcg.cpp): a run of
// single-precision iterations that did not at least halve the true residual hands the solve
// over to double precision. Below double precision's reach (a tolerance of 1e-17) the
// restarts stall, and the rule must make that hand-over whatever the units of the system:
// with a right-hand side of order 1e-6 (the cloth step's), the single-precision squares
// underflow near the end and the iterations break down, which also hands over; scaled up,
// nothing breaks down and only the rule stops the stalled restarts.
#include <gtest/gtest.h>

#include <limits>

#include "linalg/pcg.hpp"
#include "support/cloth_step_problem.hpp"
#include "support/random_vectors.hpp"

using namespace weft;

TEST(SsorRestart, StalledSinglePrecisionRestartsHandOverToDoubleWhateverTheScale) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(33, 0.02, p);
  const BlockMatrix& A = p.matrix();
  const std::vector<char>& fixed = p.pinned();
  for (double scale : {1.0, 1e10, 1e20}) {
    PcgSettings s;
    s.relative_tolerance = 1e-17;
    s.max_iterations = 150;
    s.preconditioner = Preconditioner::kSsor;
    s.node_order = p.sim->core().system().solver_order();
    s.ssor_single_precision = true;
    PcgWorkspace ws;
    VecX x = scale * p.guess;
    const VecX rhs = scale * p.rhs;
    const PcgResult r = solve_pcg(A, rhs, fixed, s, x, ws);
    EXPECT_FALSE(r.converged) << "scale " << scale;
    EXPECT_EQ(ws.ssor_single_fallbacks, 1) << "scale " << scale;
    EXPECT_LE(r.iterations, s.max_iterations) << "scale " << scale;
    // It ends at double precision's rounding level: a few eps |A| |x| (as in test_ssor.cpp).
    VecX b = rhs, abs_product;
    test::zero_fixed(fixed, b);
    BlockMatrix abs_A = A;
    for (Mat3& m : abs_A.block) m = m.cwiseAbs();
    abs_A.multiply(x.cwiseAbs(), abs_product);
    test::zero_fixed(fixed, abs_product);
    const double rounding = 16 * std::numeric_limits<double>::epsilon() * abs_product.norm() / b.norm();
    EXPECT_LE(r.relative_residual, 100 * rounding) << "scale " << scale;
  }
}
