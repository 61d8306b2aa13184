// Newton iterations within a semi-implicit step (IntegratorSettings::newton_iterations): the
// step's nonlinear equations are solved, not only their linearisation at the step's start.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "integrate/integrator.hpp"
#include "support/spinning_spring.hpp"
#include "support/spring_system.hpp"

using namespace weft;
using weft::test::Spring;
using weft::test::SpringSystem;
using weft::test::mechanical_energy;
using weft::test::spinning_spring_state;

namespace {

IntegratorSettings settings(double alpha, double dt, int newton_iterations, double newton_tolerance) {
  IntegratorSettings st;
  st.alpha = alpha;
  st.dt = dt;
  st.cg_tolerance = 1e-13;
  st.newton_iterations = newton_iterations;
  st.newton_tolerance = newton_tolerance;
  st.backward_euler_newton = false;  // 0 iterations: the linearised step
  return st;
}

/// |M^-1/2 g| / |M^1/2 dv| of the alpha-family step's equations before linearisation,
/// g = M dv - dt f(x0 + alpha dx, v0 + alpha dv), for the step that went from s0 to s1
/// (whose dx must be dt (v0 + alpha dv)).
double relative_residual(SpringSystem& sys, const State& s0, const State& s1, double alpha, double dt) {
  const VecX dv = s1.v - s0.v, dx = s1.x - s0.x;
  EXPECT_LT((dx - dt * (s0.v + alpha * dv)).norm(), 1e-12 * (1 + dx.norm()));
  Evaluation e;
  sys.evaluate(s0.x + alpha * dx, s0.v + alpha * dv, false, e);
  double g2 = 0, dv2 = 0;
  for (int i = 0; i < sys.num_nodes(); ++i) {
    const double m = sys.node_mass()[i];
    g2 += (m * node(dv, i) - dt * node(e.force, i)).squaredNorm() / m;
    dv2 += m * node(dv, i).squaredNorm();
  }
  return std::sqrt(g2 / dv2);
}

}  // namespace

TEST(NewtonStep, SolvesTheStepsNonlinearEquationsWhereTheLinearisedStepDoesNot) {
  const double k = 1e6, dt = 0.02;
  for (double alpha : {0.5, 1.0}) {
    SCOPED_TRACE(alpha);
    double residual[2] = {0, 0};
    for (int newton : {0, 1}) {
      SpringSystem sys(VecX::Constant(1, 1.0), {Spring{0, -1, k, 1.0, 0.0}});
      State s = spinning_spring_state(k, 5.0);  // kappa = k dt^2 / m = 400, a quarter turn in 8 steps
      const State start = s;
      Integrator in(sys, settings(alpha, dt, newton ? 30 : 0, 1e-10));
      StepStatistics st;
      in.step(s, dt, st);
      residual[newton] = relative_residual(sys, start, s, alpha, dt);
      if (newton) {
        EXPECT_GT(st.newton_iterations, 0);
        EXPECT_EQ(st.newton_unconverged, 0);
      } else {
        EXPECT_EQ(st.newton_iterations, 0);
      }
    }
    EXPECT_GT(residual[0], 1e-2);     // the linearisation misses the turn
    EXPECT_LT(residual[1], 1e-9);     // Newton meets its tolerance (1e-10 of the larger norm)
  }
}

TEST(NewtonStep, MidpointKeepsTheSpinningSpringsEnergyBoundedWhereTheLinearisedStepInflatesIt) {
  // The undamped linearised Implicit Midpoint step raises the stiff spinning spring's energy by
  // more than half within 200 steps (tests/integrate/test_guarded_midpoint.cpp). Solved to
  // convergence, the midpoint rule excites the spring's stiff stretching mode at the first steps
  // but puts no energy in after that: over ten times as many steps the energy stays in a band
  // below that rise, and above a tenth under the start (nothing dissipates it either).
  const double k = 1e6, dt = 0.02;
  SpringSystem sys(VecX::Constant(1, 1.0), {Spring{0, -1, k, 1.0, 0.0}});
  State s = spinning_spring_state(k, 5.0);
  Integrator in(sys, settings(0.5, dt, 30, 1e-10));
  StepStatistics st;
  const double e0 = mechanical_energy(sys, s);
  double lowest = e0, highest = e0;
  for (int n = 0; n < 2000; ++n) {
    in.step(s, dt, st);
    const double e = mechanical_energy(sys, s);
    lowest = std::min(lowest, e);
    highest = std::max(highest, e);
  }
  EXPECT_EQ(st.newton_unconverged, 0);
  EXPECT_LT(highest, 1.5 * e0);
  EXPECT_GT(lowest, 0.9 * e0);
}

TEST(NewtonStep, LinearSystemTakesNoIterationAndTheSameBits) {
  // Zero-rest-length springs are linear: the linearised step already solves the step's equations
  // (up to the linear solve's tolerance), so Newton iterations change nothing.
  auto chain = [] {
    SpringSystem sys(VecX::Constant(3, 0.1),
                     {Spring{0, -1, 50.0, 0.0, 0.1}, Spring{0, 1, 80.0, 0.0, 0.05}, Spring{1, 2, 30.0, 0.0, 0.0}},
                     Vec3(0, -9.81, 0));
    return sys;
  };
  for (double alpha : {0.5, 1.0}) {
    SpringSystem a = chain(), b = chain();
    State sa, sb;
    sa.x = VecX::LinSpaced(9, 0.1, 0.9);
    sa.v = VecX::LinSpaced(9, -0.3, 0.2);
    sb = sa;
    Integrator plain(a, settings(alpha, 0.01, 0, 1e-3)), newton(b, settings(alpha, 0.01, 5, 1e-3));
    StepStatistics st_plain, st_newton;
    for (int n = 0; n < 20; ++n) {
      plain.step(sa, 0.01, st_plain);
      newton.step(sb, 0.01, st_newton);
    }
    EXPECT_EQ(st_newton.newton_iterations, 0);
    EXPECT_EQ(st_newton.newton_unconverged, 0);
    EXPECT_TRUE(sa.x == sb.x);
    EXPECT_TRUE(sa.v == sb.v);
    EXPECT_EQ(sa.viscous_dissipated, sb.viscous_dissipated);
  }
}

TEST(NewtonStep, AStiffStepHalvesWhereTheFullNewtonStepWouldRaiseTheResidualAndConverges) {
  // The spinning spring at kappa = k dt^2 / m = 100, turning 2 rad in the step: from the
  // linearised iterate the full Newton step overshoots the turn and raises the residual of the
  // step's equations; the line search halves it (StepStatistics::newton_halvings, summary.json's
  // newton.line_search_halvings) until the residual falls, and the iterations converge.
  const double k = 1e4, dt = 0.1;
  for (double alpha : {0.5, 1.0}) {
    SCOPED_TRACE(alpha);
    SpringSystem linear_sys(VecX::Constant(1, 1.0), {Spring{0, -1, k, 1.0, 0.0}});
    SpringSystem newton_sys(VecX::Constant(1, 1.0), {Spring{0, -1, k, 1.0, 0.0}});
    const State start = spinning_spring_state(k, 20.0);
    State linear = start, newton = start;
    Integrator plain(linear_sys, settings(alpha, dt, 0, 1e-10)), iterated(newton_sys, settings(alpha, dt, 40, 1e-10));
    StepStatistics sp, sn;
    plain.step(linear, dt, sp);
    iterated.step(newton, dt, sn);
    EXPECT_GT(sn.newton_halvings, 0) << "the line search halved";
    EXPECT_EQ(sn.newton_unconverged, 0);
    const double r_linear = relative_residual(linear_sys, start, linear, alpha, dt);
    const double r_newton = relative_residual(newton_sys, start, newton, alpha, dt);
    EXPECT_GT(r_linear, 1e-2);
    EXPECT_LT(r_newton, 1e-9);
  }
}
