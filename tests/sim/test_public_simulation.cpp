// weft::Simulation through the public API only (include/weft/, docs/api.md): what it reports
// agrees with the scene it was built from, bad collider indices and panels a garment's pattern
// lacks are refused with a message, and the frames recorded for the animations are the states
// the simulation passed through.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <thread>
#include <vector>

#include "weft/error.hpp"
#include "weft/recording.hpp"
#include "weft/scene.hpp"
#include "weft/simulation.hpp"

using namespace weft;

namespace {

// A 7 x 7 sheet pinned at two corners above a sphere and a floor.
Scene sheet_over_sphere() {
  return parse_scene_text(R"({"weft_scene": 1, "duration": 0.06, "frame_interval": 0.02,
    "integrator": {"method": "backward-euler", "dt": 0.01},
    "cloth": {"mesh": {"grid": {"size": [0.3, 0.3], "vertices": [7, 7]}},
              "placement": {"rotation_deg": [-90, 0, 0], "translation": [-0.15, 0.5, 0.15]},
              "material": "cotton", "pins": {"grid": [[0, 0], [-1, 0]]}},
    "colliders": [{"type": "sphere", "centre": [0, 0.2, 0], "radius": 0.2},
                  {"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]}]})",
                          "sheet.json", ".");
}

}  // namespace

TEST(PublicSimulation, ReportsTheSceneItWasBuiltFrom) {
  Simulation sim(sheet_over_sphere());
  EXPECT_EQ(sim.vertex_count(), 49);
  EXPECT_EQ(sim.mesh().num_vertices(), 49);
  EXPECT_EQ(sim.mesh().triangles.size(), 72u);  // 6 x 6 cells, two triangles each
  EXPECT_EQ(sim.positions().size(), 3 * 49);
  EXPECT_EQ(sim.velocities().size(), 3 * 49);
  EXPECT_EQ(sim.masses().size(), 49);  // one per vertex
  int pinned = 0;
  for (char p : sim.pinned()) pinned += p ? 1 : 0;
  EXPECT_EQ(pinned, 2);
  EXPECT_EQ(sim.collider_count(), 2u);
  EXPECT_EQ(sim.collider(0).shape, ColliderShape::kSphere);
  EXPECT_EQ(sim.collider(1).shape, ColliderShape::kPlane);
  EXPECT_EQ(sim.time(), 0.0);
  sim.advance_to(0.03);
  EXPECT_NEAR(sim.time(), 0.03, 1e-12);
  EXPECT_EQ(sim.step_statistics().steps, 3);
  EXPECT_GT(sim.damping_statistics().element_steps, 0);
}

TEST(PublicSimulation, ResetStateTakesTheSimulationsOwnVectorsAndKeepsTheirStorage) {
  // A caller may hand back the simulation's own positions with new velocities: the state must
  // not be cleared before they are read, and arrays that view the state (the Python module's)
  // keep viewing it.
  Simulation sim(sheet_over_sphere());
  sim.advance_to(0.02);
  const VecX x = sim.positions();
  const double* x_storage = sim.positions().data();
  const double* v_storage = sim.velocities().data();
  const VecX v = VecX::Constant(x.size(), 0.25);
  sim.reset_state(sim.positions(), v);
  EXPECT_EQ(sim.positions(), x);
  EXPECT_EQ(sim.velocities(), v);
  EXPECT_EQ(sim.positions().data(), x_storage);
  EXPECT_EQ(sim.velocities().data(), v_storage);
  EXPECT_EQ(sim.time(), 0.0);
  sim.reset_state(sim.positions(), sim.velocities());
  EXPECT_EQ(sim.velocities(), v);
}

TEST(PublicSimulation, ACollidersIndexOutOfRangeIsRefused) {
  Simulation sim(sheet_over_sphere());
  try {
    sim.collider(2);
    FAIL() << "no error for collider 2";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "collider 2 does not exist (the scene has 2 colliders)");
  }
  Points positions;
  Triangles triangles;
  try {
    sim.collider_surface(5, 0.0, positions, triangles);
    FAIL() << "no error for collider 5";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "collider_surface: collider 5 does not exist (the scene has 2 colliders)");
  }
}

TEST(PublicSimulation, AGarmentsPanelsAreCheckedAgainstItsPatternBeforeItIsSewn) {
  // Reading the scene reads no pattern: the panel names are checked where the garment is made,
  // and the error names the scene's key, as the scene reader's errors do.
  const std::string shirt = std::string(WEFT_SOURCE_DIR) + "/data/patterns/garmentcode/shirt_mean_specification.json";
  const Scene scene = parse_scene_text(
      R"({"weft_scene": 1, "duration": 0.04, "frame_interval": 0.02,
          "integrator": {"method": "implicit-midpoint", "dt": 0.01},
          "colliders": [{"type": "body", "bind_pose_hold": 0.5}],
          "cloth": {"mesh": {"pattern": {"file": ")" + shirt + R"(", "panels": {"collar": {"part": "head"}}}}}})",
      "s.json", ".");
  std::vector<std::string> stages;
  try {
    Simulation sim(scene, [&](const std::string& stage, double) { stages.push_back(stage); });
    FAIL() << "no error for the panel 'collar'";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "s.json: key cloth.mesh.pattern.panels.collar: the pattern " + shirt + " has no panel 'collar'");
  }
  for (const std::string& stage : stages) EXPECT_EQ(stage.find("sewing"), std::string::npos) << stage;
}

TEST(FrameRecording, HoldsTheStatesItWasGivenAndTheCollidersAsked) {
  Simulation sim(sheet_over_sphere());
  FrameRecording with(sim, true, true), without(sim, false, false);
  for (double t : {0.0, 0.02, 0.04}) {
    if (t > 0) sim.advance_to(t);
    with.add_frame(sim);
    without.add_frame(sim);
  }
  ASSERT_EQ(with.frame_count(), 3u);
  EXPECT_EQ(with.times().back(), sim.time());
  const auto meshes = with.meshes();
  ASSERT_EQ(meshes.size(), 3u);  // the cloth, then both colliders
  EXPECT_EQ(meshes[0]->name, "cloth");
  EXPECT_EQ(meshes[1]->name, "collider0");
  EXPECT_EQ(meshes[2]->name, "collider1");
  EXPECT_EQ(without.meshes().size(), 1u);
  // The last frame is the state now, in single precision.
  const AnimatedMesh& cloth = with.cloth();
  ASSERT_EQ(cloth.frame_count(), 3);
  for (int i = 0; i < 3 * sim.vertex_count(); ++i)
    EXPECT_EQ(cloth.positions[3 * 2 * sim.vertex_count() + i], static_cast<float>(sim.positions()[i]));
  EXPECT_EQ(cloth.viscosity.size(), 3u * sim.vertex_count());
  EXPECT_TRUE(without.cloth().viscosity.empty());
}

TEST(FrameRecording, NamesABodyAfterItsBodyAndOtherCollidersAfterTheirPlace) {
  ColliderSpec body;
  body.shape = ColliderShape::kBody;
  body.body = 1;
  ColliderSpec box;
  box.shape = ColliderShape::kBox;
  EXPECT_EQ(collider_output_name(body, 4), "body1");
  EXPECT_EQ(collider_output_name(box, 4), "collider4");
}

TEST(PublicSimulation, SimulationsOfOneModelOnTwoThreadsStepAsIfEachWereAlone) {
  // Two simulations of one shared model, one of them pushed, stepped at the same time on two
  // threads: each must end with the bits of a simulation built alone and stepped alone, so
  // nothing a step changes may live in the model.
  const Scene scene = sheet_over_sphere();
  const auto model = std::make_shared<const Model>(scene);
  Simulation a(model), b(model);
  EXPECT_EQ(a.model(), model);
  EXPECT_EQ(b.fingerprint(), model->fingerprint());
  EXPECT_EQ(model->vertex_count(), 49);
  VecX push = b.velocities();
  for (Eigen::Index i = 0; i < push.size(); i += 3)
    if (!b.pinned()[i / 3]) push[i] += 0.4 * std::sin(0.9 * static_cast<double>(i));
  b.reset_state(b.positions(), push);
  std::thread run_a([&a] { a.advance_to(0.3); }), run_b([&b] { b.advance_to(0.3); });
  run_a.join();
  run_b.join();
  Simulation alone_a(scene), alone_b(scene);
  alone_b.reset_state(alone_b.positions(), push);
  alone_a.advance_to(0.3);
  alone_b.advance_to(0.3);
  ASSERT_GT(a.step_statistics().contacts, 0);
  EXPECT_NE(a.positions(), b.positions());
  EXPECT_EQ(a.positions(), alone_a.positions());
  EXPECT_EQ(a.velocities(), alone_a.velocities());
  EXPECT_EQ(b.positions(), alone_b.positions());
  EXPECT_EQ(b.velocities(), alone_b.velocities());
  EXPECT_EQ(b.step_statistics().cg_iterations, alone_b.step_statistics().cg_iterations);
  // A third, made after the others ran, starts at the scene's start.
  Simulation c(a.model());
  EXPECT_EQ(c.time(), 0.0);
  EXPECT_EQ(c.positions(), Simulation(scene).positions());
}

TEST(PublicSimulation, ANullModelIsRefused) {
  try {
    Simulation sim{std::shared_ptr<const Model>()};
    FAIL() << "a simulation of no model was built";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "Simulation: no model (a null pointer)");
  }
}
