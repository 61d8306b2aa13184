// IntegratorSettings::max_step_motion: an alpha-family step that would move a node farther than
// the limit is scaled down to it, every node's displacement by the same factor (the step's
// direction kept), the end velocity with it; a step within the limit is left as it is.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "integrate/integrator.hpp"
#include "support/spring_system.hpp"

using namespace weft;
using weft::test::Spring;
using weft::test::SpringSystem;

namespace {

constexpr double kDt = 0.01;

// Two nodes at the origin, each on a stiff zero-length spring to its own anchor (1 m and 0.5 m
// away, in different directions), moving across them: one step of backward Euler takes each
// most of the way to its anchor.
SpringSystem two_springs() {
  return SpringSystem(VecX::Constant(2, 1e-3), {Spring{0, -1, 1e3, 0.0, 0.0, Vec3(1, 0, 0)},
                                                Spring{1, -1, 1e3, 0.0, 0.0, Vec3(0, 0.5, 0)}});
}

struct Step {
  VecX dx, v;
};

Step one_step(double alpha, double limit) {
  SpringSystem sys = two_springs();
  IntegratorSettings settings;
  settings.method = Method::kAlphaFamily;
  settings.alpha = alpha;
  settings.dt = kDt;
  settings.cg_tolerance = 1e-14;
  settings.max_step_motion = limit;
  Integrator integ(sys, settings);
  State s;
  s.x = VecX::Zero(6);
  s.v = VecX::Zero(6);
  s.v << 0, 0, 2, 1, 0, 0;
  const VecX x0 = s.x;
  StepStatistics stats;
  integ.step(s, kDt, stats);
  return {s.x - x0, s.v};
}

double largest_motion(const VecX& dx) { return std::max(dx.segment<3>(0).norm(), dx.segment<3>(3).norm()); }

}  // namespace

TEST(StepMotionLimit, AStepMovingANodeFartherIsScaledDownToTheLimitInItsOwnDirection) {
  for (double alpha : {1.0, 0.5}) {
    const Step free = one_step(alpha, std::numeric_limits<double>::infinity());
    ASSERT_GT(largest_motion(free.dx), 0.3) << "alpha " << alpha;  // the limit below must act
    const Step limited = one_step(alpha, 0.1);
    EXPECT_NEAR(largest_motion(limited.dx), 0.1, 1e-12) << "alpha " << alpha;
    const double f = 0.1 / largest_motion(free.dx);
    EXPECT_LT((limited.dx - f * free.dx).norm(), 1e-12) << "alpha " << alpha;
    if (alpha == 1.0) {
      // backward Euler: the step's displacement is dt times its end velocity, scaled or not
      EXPECT_LT((limited.v - limited.dx / kDt).norm(), 1e-9 * limited.v.norm());
      EXPECT_LT((free.v - free.dx / kDt).norm(), 1e-9 * free.v.norm());
    }
  }
}

TEST(StepMotionLimit, AStepWithinTheLimitIsTheSameBits) {
  const Step free = one_step(1.0, std::numeric_limits<double>::infinity());
  const Step within = one_step(1.0, 10.0);
  EXPECT_TRUE(free.dx == within.dx);
  EXPECT_TRUE(free.v == within.v);
}
