// Energy accounting on the default scene: with the RK45 reference at a tight tolerance,
// kinetic + elastic + gravity + viscous dissipation stays at its initial value.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "sim/simulation_core.hpp"

using namespace weft;

TEST(EnergyBalance, Rk45KeepsTheTotalOnTheSwingScene) {
  Scene scene = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/swing.json");
  set_method(scene, "rk45", std::nullopt, "test");
  scene.integrator.error_tolerance = 1e-6;
  scene.duration = 2.0;
  // Some material viscosity, so that the viscous term of the balance is exercised.
  scene.cloth.material.viscosity_Ns_m = 0.002;
  Simulation sim(scene);
  const RunResult r = run_simulation(sim);
  ASSERT_EQ(r.status, "ok") << r.message;
  double scale = 0, worst = 0;
  for (const auto& e : r.energy) scale = std::max(scale, std::abs(e.gravity));
  for (const auto& e : r.energy) worst = std::max(worst, std::abs(e.total() + e.viscous_dissipated));
  RecordProperty("relative_imbalance", std::to_string(worst / scale));
  RecordProperty("viscous_dissipated_J", std::to_string(r.energy.back().viscous_dissipated));
  EXPECT_GT(r.energy.back().viscous_dissipated, 0.01 * scale) << "the viscous term should matter in this test";
  EXPECT_LT(worst, 0.005 * scale);
}

TEST(EnergyBalance, ImplicitMidpointDissipatesLessThanBackwardEulerOnTheSwingScene) {
  Scene scene = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/swing.json");
  scene.duration = 2.0;
  auto dissipated = [&](const char* method) {
    Scene s = scene;
    set_method(s, method, std::nullopt, "test");
    Simulation sim(s);
    const RunResult r = run_simulation(sim);
    EXPECT_EQ(r.status, "ok") << method << ": " << r.message;
    const EnergyRow& e = r.energy.back();
    return e.viscous_dissipated + e.numerical_dissipated;
  };
  const double im = dissipated("implicit-midpoint"), be = dissipated("backward-euler");
  RecordProperty("implicit_midpoint_J", std::to_string(im));
  RecordProperty("backward_euler_J", std::to_string(be));
  EXPECT_LT(im, be);
}
