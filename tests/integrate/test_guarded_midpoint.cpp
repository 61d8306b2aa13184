// The energy guard of Implicit Midpoint (docs/guarded-midpoint.md): a step whose energy balance
// shows that it put energy in is taken again as two halves, then with a larger alpha.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "integrate/integrator.hpp"
#include "support/spinning_spring.hpp"
#include "support/spring_system.hpp"
#include "weft/simulation.hpp"

using namespace weft;
using weft::test::Spring;
using weft::test::SpringSystem;
using weft::test::mechanical_energy;
using weft::test::spinning_spring_state;

namespace {

IntegratorSettings midpoint(double dt, bool guard) {
  IntegratorSettings st;
  st.alpha = 0.5;
  st.dt = dt;
  st.cg_tolerance = 1e-12;
  st.guard = guard;
  return st;
}

}  // namespace

TEST(GuardedMidpoint, StiffSpinningSpringGainsEnergyOnlyWithoutTheGuard) {
  // kappa = k dt^2 / m = 400, a quarter turn every 8 steps: the linearised step, whose
  // Jacobian points along the spring at the step's start, stretches the spring it turns.
  const double k = 1e6, dt = 0.02;
  for (bool guard : {false, true}) {
    SpringSystem sys(VecX::Constant(1, 1.0), {Spring{0, -1, k, 1.0, 0.0}});
    State s = spinning_spring_state(k, 5.0);
    Integrator in(sys, midpoint(dt, guard));
    StepStatistics st;
    const double e0 = mechanical_energy(sys, s);
    double e = e0, highest = e0;
    for (int n = 0; n < 200; ++n) {
      in.step(s, dt, st);
      const double next = mechanical_energy(sys, s);
      // No energy scale was set, so the guard's tolerance is a fraction of the state's own
      // (kinetic plus elastic) energy; the margin covers this test's own rounding.
      if (guard) EXPECT_LE(next, e * (1 + kGuardTolerance) + 1e-12 * e) << "step " << n;
      e = next;
      highest = std::max(highest, e);
    }
    if (guard) {
      EXPECT_GT(st.guard_split_steps, 0);
      EXPECT_LE(highest, e0 * (1 + 200 * kGuardTolerance));
      EXPECT_LT(e, e0);
    } else {
      EXPECT_GT(highest, 1.5 * e0);
    }
  }
}

TEST(GuardedMidpoint, SameResultsAsThePlainStepWhereTheGuardNeverActs) {
  // Zero-rest-length springs are linear, and on a linear system Implicit Midpoint's energy
  // changes by exactly the viscous work it books: only rounding is left for the guard to see.
  const std::vector<Spring> chain = {{0, -1, 30.0, 0.0, 0.4}, {0, 1, 20.0, 0.0, 0.7}, {1, 2, 45.0, 0.0, 0.3}};
  VecX mass(3);
  mass << 0.2, 0.35, 0.15;
  State start;
  start.x = VecX(9);
  start.x << 0.3, -0.2, 0.1, 0.9, -0.5, -0.2, 1.4, -0.1, 0.4;
  start.v = VecX(9);
  start.v << 0.5, 1.2, -0.3, -0.8, 0.2, 0.6, 0.1, -1.1, 0.9;
  std::vector<State> ends;
  for (bool guard : {false, true}) {
    SpringSystem sys(mass, chain, Vec3(0, -9.81, 0));
    Integrator in(sys, midpoint(0.05, guard));
    StepStatistics st;
    State s = start;
    for (int n = 0; n < 100; ++n) in.step(s, 0.05, st);
    EXPECT_EQ(st.guard_split_steps + st.guard_redone_steps + st.guard_raised_steps, 0);
    ends.push_back(s);
  }
  EXPECT_TRUE((ends[0].x.array() == ends[1].x.array()).all());
  EXPECT_TRUE((ends[0].v.array() == ends[1].v.array()).all());
  EXPECT_EQ(ends[0].viscous_dissipated, ends[1].viscous_dissipated);
}

TEST(GuardedMidpoint, EnergyBalanceClosesWhereTheGuardActs) {
  // The 21x21 swing, where plain Implicit Midpoint blows up within a second: the guard takes
  // steps again, and the account must not book a discarded attempt's viscous work. Every
  // accepted (part) step puts in at most kGuardTolerance of the scale, so the numerical
  // dissipation can fall below zero by no more than that much per step and half step.
  Scene scene = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/swing-21x21.json");
  scene.duration = 1.0;
  Simulation sim(scene);
  const RunResult r = run_simulation(sim);
  ASSERT_EQ(r.status, "ok") << r.message;
  EXPECT_GT(r.steps.guard_split_steps, 0);
  double scale = sim.energy_scale();
  for (const EnergyRow& e : r.energy) scale = std::max(scale, e.kinetic + e.elastic);
  const double parts = static_cast<double>(r.steps.steps + r.steps.guard_split_steps);
  for (const EnergyRow& e : r.energy) {
    EXPECT_GE(e.numerical_dissipated, -parts * kGuardTolerance * scale) << "t = " << e.time;
    EXPECT_GE(e.viscous_dissipated, 0.0);
  }
  // The plain step on the same scene is not stable: the guard is what keeps it.
  set_method(scene, "implicit-midpoint-plain", std::nullopt, "test");
  Simulation plain(scene);
  EXPECT_EQ(run_simulation(plain).status, "unstable");
}
