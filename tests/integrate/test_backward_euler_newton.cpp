// Backward Euler's own step never puts energy in: an unguarded backward Euler step that does
// (its linearisation's error on a stiffening fabric) is taken again with Newton iterations
// (IntegratorSettings::backward_euler_newton), so the default settings finish where the
// linearised step blows up, and a linear material never triggers it.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "weft/scene.hpp"
#include "weft/simulation.hpp"

using namespace weft;

namespace {

RunResult run(Scene scene, bool automatic, nlohmann::json* summary = nullptr) {
  scene.integrator.backward_euler_newton = automatic;
  Simulation sim(scene);
  RunResult r = run_simulation(sim);
  if (summary) *summary = summary_json(sim, r);
  return r;
}

}  // namespace

TEST(BackwardEulerNewton, AStiffeningFabricFinishesWhereTheLinearisedStepBlowsUp) {
  // The paper's swing with the cubic flat at zero strain (scenes/paper-swing-flat.json), at
  // dt = 20 ms: the linearised backward Euler step blows up within its first 0.2 s.
  Scene scene = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/paper-swing-flat.json");
  set_method(scene, "backward-euler", std::nullopt, "test");
  scene.integrator.dt = 0.02;
  scene.duration = 1.0;
  const RunResult linearised = run(scene, false);
  EXPECT_EQ(linearised.status, "unstable");
  EXPECT_EQ(linearised.steps.newton_automatic_steps, 0);
  nlohmann::json summary;
  const RunResult iterated = run(scene, true, &summary);
  EXPECT_EQ(iterated.status, "ok") << iterated.message;
  EXPECT_GT(iterated.steps.newton_automatic_steps, 0);
  EXPECT_LT(iterated.steps.newton_automatic_steps, iterated.steps.steps);  // only where needed
  EXPECT_GT(iterated.steps.newton_iterations, 0);
  EXPECT_EQ(summary["newton"]["automatic_steps"].get<long>(), iterated.steps.newton_automatic_steps);
  EXPECT_EQ(summary["newton"]["automatic_max_iterations"].get<int>(), 4);
  // and the run keeps the energy balance: what it leaves to the integrator is dissipated
  for (const EnergyRow& e : iterated.energy) EXPECT_GE(e.numerical_dissipated, -1e-6) << "t = " << e.time;
}

TEST(BackwardEulerNewton, ALinearFabricIsNeverTakenAgain) {
  // scenes/swing.json's linear cotton-like cloth under backward Euler: no step puts energy in,
  // so the run is the same bits with the rule on and off.
  Scene scene = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/swing.json");
  set_method(scene, "backward-euler", std::nullopt, "test");
  scene.duration = 1.0;
  const RunResult on = run(scene, true), off = run(scene, false);
  EXPECT_EQ(on.steps.newton_automatic_steps, 0);
  ASSERT_EQ(on.energy.size(), off.energy.size());
  for (size_t k = 0; k < on.energy.size(); ++k) {
    EXPECT_EQ(on.energy[k].kinetic, off.energy[k].kinetic);
    EXPECT_EQ(on.energy[k].elastic, off.energy[k].elastic);
  }
}

TEST(BackwardEulerNewton, TheSceneKeyAutomaticNewtonTurnsItOff) {
  const std::string dir = std::string(WEFT_SOURCE_DIR) + "/scenes";
  std::ifstream in(dir + "/paper-swing-flat.json");
  std::stringstream text;
  text << in.rdbuf();
  std::string on = text.str();
  const std::string key = R"("integrator": {"method": "implicit-midpoint", "dt": 0.02)";
  ASSERT_NE(on.find(key), std::string::npos);
  on.replace(on.find(key), key.size(), R"("integrator": {"method": "backward-euler", "dt": 0.02)");
  std::string off = on;
  const std::string dt = R"("dt": 0.02)";
  off.replace(off.find(dt), dt.size(), R"("dt": 0.02, "automatic_newton": false)");
  EXPECT_TRUE(parse_scene_text(on, "on.json", dir).integrator.backward_euler_newton);
  EXPECT_FALSE(parse_scene_text(off, "off.json", dir).integrator.backward_euler_newton);
  // and the fingerprint tells the two apart (a checkpoint of one does not resume the other)
  EXPECT_NE(Simulation(parse_scene_text(on, "on.json", dir)).fingerprint(),
            Simulation(parse_scene_text(off, "off.json", dir)).fingerprint());
}
