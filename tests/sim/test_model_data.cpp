// SimulationModel and SimulationData (sim/model_data.hpp): the model is constant and the data
// holds everything a step reads and writes, so several data of one model are independent
// simulations, and a data written out (save_data) and read back steps to the same bits.
#include <gtest/gtest.h>

#include <cstring>

#include "sim/checkpoint.hpp"
#include "sim/model_data.hpp"
#include "sim/simulation_core.hpp"
#include "support/contact_scene.hpp"
#include "weft/error.hpp"

using namespace weft;

namespace {

bool same_bits(const VecX& a, const VecX& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0;
}

/// The swing dropped onto a sphere and a floor: contacts, friction, self-contact and the warm
/// start all carry state from step to step.
Scene contact_scene(const char* method) {
  Scene scene = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/swing.json");
  set_method(scene, method, std::nullopt, "test");
  scene.integrator.dt = 0.005;
  return test::dropped_onto_sphere_and_floor(scene);
}

/// A push of every free vertex, different per vertex, so that two runs differ from the start.
VecX pushed(const SimulationModel& model, const VecX& v) {
  VecX out = v;
  for (int i = 0; i < model.num_vertices(); ++i)
    if (!model.cloth->pinned[i]) out[3 * i] += 0.3 * std::sin(0.7 * i);
  return out;
}

}  // namespace

TEST(ModelData, TwoDataOfOneModelStepLikeTwoSeparateSimulations) {
  // Stepped in turns, frame by frame: if a step left anything in the model (a warm start, a
  // viscosity, a contact flag), the other data's next step would read it and its bits would
  // differ from a simulation of its own.
  for (const char* method : {"implicit-midpoint", "bdf2"}) {
    SCOPED_TRACE(method);
    const Scene scene = contact_scene(method);
    const std::unique_ptr<SimulationModel> model = build_model(scene);
    std::unique_ptr<SimulationData> a = make_data(*model), b = make_data(*model);
    b->state.v = pushed(*model, b->state.v);
    set_energy_reference(*model, *b);
    SimulationCore alone_a(scene), alone_b(scene);
    alone_b.reset_state(alone_b.state().x, pushed(*model, alone_b.state().v));
    for (double t = 0.02; t < 0.3 + 1e-9; t += 0.02) {
      advance(*model, *a, t);
      advance(*model, *b, t);
      alone_a.advance_to(t);
      alone_b.advance_to(t);
    }
    ASSERT_GT(a->statistics.contacts, 0);
    EXPECT_FALSE(same_bits(a->state.x, b->state.x)) << "the two runs should differ";
    EXPECT_TRUE(same_bits(a->state.x, alone_a.state().x));
    EXPECT_TRUE(same_bits(a->state.v, alone_a.state().v));
    EXPECT_TRUE(same_bits(b->state.x, alone_b.state().x));
    EXPECT_TRUE(same_bits(b->state.v, alone_b.state().v));
    EXPECT_EQ(a->statistics.cg_iterations, alone_a.statistics().cg_iterations);
    EXPECT_EQ(b->statistics.cg_iterations, alone_b.statistics().cg_iterations);
    EXPECT_EQ(b->statistics.contacts, alone_b.statistics().contacts);
  }
}

TEST(ModelData, DataWrittenOutAndReadBackStepsToTheSameBits) {
  const Scene scene = contact_scene("implicit-midpoint");
  const std::unique_ptr<SimulationModel> model = build_model(scene);
  std::unique_ptr<SimulationData> a = make_data(*model);
  advance(*model, *a, 0.15);
  BinaryWriter out;
  save_data(*model, *a, out);
  // Read into a data that has run elsewhere: nothing of its own past may remain.
  std::unique_ptr<SimulationData> b = make_data(*model);
  b->state.v = pushed(*model, b->state.v);
  advance(*model, *b, 0.05);
  BinaryReader in(out.bytes(), "mem");
  restore_data(*model, *b, in);
  EXPECT_TRUE(in.at_end());
  advance(*model, *a, 0.3);
  advance(*model, *b, 0.3);
  EXPECT_TRUE(same_bits(a->state.x, b->state.x));
  EXPECT_TRUE(same_bits(a->state.v, b->state.v));
  EXPECT_EQ(a->statistics.cg_iterations, b->statistics.cg_iterations);
  EXPECT_EQ(a->statistics.contacts, b->statistics.contacts);
  EXPECT_EQ(a->system.statistics.membrane_kappa.count(), b->system.statistics.membrane_kappa.count());
  const EnergyRow ea = energies(*model, *a), eb = energies(*model, *b);
  EXPECT_EQ(ea.total(), eb.total());
  EXPECT_EQ(ea.numerical_dissipated, eb.numerical_dissipated);
}

TEST(ModelData, DataOfAnotherModelIsRefused) {
  Scene scene = contact_scene("implicit-midpoint");
  const std::unique_ptr<SimulationModel> model = build_model(scene);
  std::unique_ptr<SimulationData> a = make_data(*model);
  advance(*model, *a, 0.02);
  BinaryWriter out;
  save_data(*model, *a, out);
  scene.integrator.dt = 0.0025;
  const std::unique_ptr<SimulationModel> other = build_model(scene);
  std::unique_ptr<SimulationData> b = make_data(*other);
  BinaryReader in(out.bytes(), "data.bin");
  try {
    restore_data(*other, *b, in);
    FAIL() << "the data of another dt was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("data.bin: checkpoint belongs to another cloth or other settings"),
              std::string::npos)
        << e.what();
  }
}
