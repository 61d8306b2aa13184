// The run's instability rule (run_simulation): with static pins nothing adds energy, so
// mechanical energy rising above its initial value by more than the scene's energy scale
// (initial kinetic + elastic energy + weight times the cloth's size) marks the run unstable.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/model_data.hpp"
#include "sim/simulation_core.hpp"

using namespace weft;

namespace {

/// A 0.6 m x 0.4 m sheet held at two corners, horizontal at rest: no elastic energy.
Scene sheet(const std::string& method, double dt) {
  Scene s;
  s.cloth.grid = GridSpec{0.6, 0.4, 7, 5};
  s.cloth.rotation_deg = Vec3(-90, 0, 0);
  s.cloth.pin_grid_nodes = {{0, 0}, {-1, 0}};
  set_method(s, method, std::nullopt, "test");
  s.integrator.dt = dt;
  s.frame_interval = dt;
  s.duration = 0.2;
  return s;
}

/// Gives every free vertex the velocity u along z.
void set_velocity(Simulation& sim, double u) {
  for (int i = 0; i < sim.core().model().num_vertices(); ++i)
    if (!sim.core().model().pinned[i]) node(sim.core().state().v, i) = Vec3(0, 0, u);
}

/// The speed that gives the free vertices kinetic energy `e`.
double speed_for(const Simulation& sim, double e) {
  double free_mass = 0;
  for (int i = 0; i < sim.core().model().num_vertices(); ++i)
    if (!sim.core().model().pinned[i]) free_mass += sim.core().model().mass[i];
  return std::sqrt(2 * e / free_mass);
}

}  // namespace

TEST(InstabilityRule, EnergyScaleIsInitialEnergyPlusWeightTimesSize) {
  Scene s = sheet("implicit-midpoint", 0.01);
  const double weight = 0.6 * 0.4 * s.cloth.material.surface_density_kg_m2 * 9.81;
  const double size = std::hypot(0.6, 0.4);  // the bounding box's diagonal
  {
    Simulation sim(s);
    EXPECT_NEAR(sim.energy_scale(), weight * size, 1e-9 * weight * size);
  }
  // Initial motion adds its kinetic energy.
  s.cloth.initial_velocity = Vec3(0.5, 0, 0);
  Simulation sim(s);
  double free_mass = 0;
  for (int i = 0; i < sim.core().model().num_vertices(); ++i)
    if (!sim.core().model().pinned[i]) free_mass += sim.core().model().mass[i];
  const double kinetic = 0.5 * free_mass * 0.25;
  EXPECT_NEAR(sim.energy_scale(), weight * size + kinetic, 1e-9 * weight * size);
}

TEST(InstabilityRule, ARiseAboveTheScaleTripsItAndOneBelowDoesNot) {
  // Energy put into the state after the reference was taken counts as a rise; a stable,
  // dissipative run (backward Euler) then only loses energy.
  for (double fraction : {1.5, 0.5}) {
    Simulation sim(sheet("backward-euler", 0.01));
    set_velocity(sim, speed_for(sim, fraction * sim.energy_scale()));
    const RunResult r = run_simulation(sim);
    if (fraction > 1) {
      EXPECT_EQ(r.status, "unstable");
      EXPECT_EQ(r.unstable_time, 0.0);
      EXPECT_EQ(r.message.rfind("mechanical energy rose by", 0), 0u) << r.message;
    } else {
      EXPECT_EQ(r.status, "ok") << r.message;
      EXPECT_EQ(r.energy.size(), 21u);
    }
  }
}

TEST(InstabilityRule, ForwardEulerBeyondItsLimitTripsOnTheEnergyRiseBeforeAnythingIsNonFinite) {
  // Stiff cloth, explicit steps far beyond the stability limit: the energy grows by orders of
  // magnitude per step, and the rule must see it while the values are still finite.
  Scene s = sheet("forward-euler", 0.01);
  s.cloth.material.weft = s.cloth.material.warp = StressCurve::linear(2000);
  Simulation sim(s);
  const RunResult r = run_simulation(sim);
  EXPECT_EQ(r.status, "unstable");
  EXPECT_GT(r.unstable_time, 0.0);
  EXPECT_LT(r.unstable_time, 0.2);
  EXPECT_EQ(r.message.rfind("mechanical energy rose by", 0), 0u) << r.message;
  // Every frame kept rose by no more than the scale.
  for (const EnergyRow& e : r.energy) EXPECT_LE(e.total() - sim.initial_total_energy(), sim.energy_scale());
  // The same scene at a stable step is not flagged.
  s.integrator.dt = s.frame_interval = 0.01;
  set_method(s, "implicit-midpoint", std::nullopt, "test");
  Simulation stable(s);
  EXPECT_EQ(run_simulation(stable).status, "ok");
}

TEST(InstabilityRule, ABlowUpEndsItsFrameAtTheStepItRanAway) {
  // Explicit steps far beyond the limit, frames of many steps: the run stops at the step at
  // which the energy rose by a thousand scales, inside the frame, rather than stepping the
  // exploding cloth (whose collision handling can take minutes a step) to the frame's end.
  Scene s = sheet("forward-euler", 0.001);
  s.cloth.material.weft = s.cloth.material.warp = StressCurve::linear(2000);
  s.frame_interval = 0.1;
  Simulation sim(s);
  const RunResult r = run_simulation(sim);
  ASSERT_EQ(r.status, "unstable");
  const double steps = r.unstable_time / 0.001;
  EXPECT_NEAR(steps, std::round(steps), 1e-6) << "stops on a step";
  EXPECT_LT(r.unstable_time, 0.1 - 1e-9) << "inside the first frame";
  EXPECT_GT(r.unstable_time, 0.0);
  EXPECT_EQ(r.steps.steps, std::lround(steps));
  // It ran away at that step: its rise is past a thousand scales, by then far below the frame's
  // end, where the steps would have taken it on.
  EXPECT_NE(r.message.find(" rose by "), std::string::npos) << r.message;
  const EnergyRow e = sim.energies();
  EXPECT_GT(e.total() - sim.initial_total_energy(), s.integrator.runaway_energy_factor * sim.energy_scale());
  // Stepped the same way without the stop, the state at that time is the same.
  Simulation plain(s);
  plain.advance_to(r.unstable_time);
  EXPECT_EQ(plain.core().state().x, sim.core().state().x);
}

TEST(InstabilityRule, ASmallerRunawayFactorStopsTheBlowUpNoLaterPastItsOwnRise) {
  // The scene's integrator.runaway_energy_factor sets the rise at which the steps stop.
  Scene s = sheet("forward-euler", 0.001);
  s.cloth.material.weft = s.cloth.material.warp = StressCurve::linear(2000);
  s.frame_interval = 0.1;
  const auto stop = [&s](double factor, double& rise_in_scales) {
    s.integrator.runaway_energy_factor = factor;
    Simulation sim(s);
    const RunResult r = run_simulation(sim);
    EXPECT_EQ(r.status, "unstable");
    rise_in_scales = (sim.energies().total() - sim.initial_total_energy()) / sim.energy_scale();
    return r.unstable_time;
  };
  double rise_low = 0, rise_high = 0;
  const double t_low = stop(10, rise_low), t_high = stop(1000, rise_high);
  EXPECT_GT(rise_low, 10);
  EXPECT_GT(rise_high, 1000);
  EXPECT_LE(t_low, t_high);
}
