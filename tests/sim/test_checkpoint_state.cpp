// Simulation::save/restore and the checkpoint file: a simulation restored from a checkpoint
// steps to the same bits as the one it was taken from (the same binary repeats its
// arithmetic exactly), and a checkpoint of another scene or a damaged one is refused.
#include <gtest/gtest.h>

#include <cstring>

#include "sim/checkpoint.hpp"
#include "support/contact_scene.hpp"
#include "weft/error.hpp"
#include "sim/simulation_core.hpp"

using namespace weft;

namespace {

Scene swing(const char* method) {
  Scene scene = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/swing.json");
  set_method(scene, method, std::nullopt, "test");
  scene.integrator.dt = 0.005;
  scene.duration = 0.2;
  return scene;
}

bool same_bits(const VecX& a, const VecX& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0;
}

}  // namespace

TEST(CheckpointState, RestoredSimulationStepsToTheSameBits) {
  for (const char* method : {"implicit-midpoint", "bdf2", "rk45"}) {
    SCOPED_TRACE(method);
    const Scene scene = swing(method);
    Simulation a(scene);
    a.advance_to(0.1);
    RunResult so_far;
    so_far.energy.push_back(a.energies());
    const std::string bytes = checkpoint_bytes({{"note", "test"}}, a, so_far);
    EXPECT_EQ(checkpoint_header(bytes, "mem")["note"], "test");
    Simulation b(scene);
    const RunResult restored = restore_checkpoint(bytes, "mem", b);
    ASSERT_EQ(restored.energy.size(), 1u);
    EXPECT_EQ(std::memcmp(&restored.energy[0], &so_far.energy[0], sizeof(EnergyRow)), 0);
    a.advance_to(0.2);
    b.advance_to(0.2);
    EXPECT_TRUE(same_bits(a.core().state().x, b.core().state().x));
    EXPECT_TRUE(same_bits(a.core().state().v, b.core().state().v));
    EXPECT_EQ(a.core().statistics().cg_iterations, b.core().statistics().cg_iterations);
    EXPECT_EQ(a.core().system().statistics().membrane_kappa.count(), b.core().system().statistics().membrane_kappa.count());
    EXPECT_EQ(a.core().system().statistics().membrane_lambda.median(), b.core().system().statistics().membrane_lambda.median());
  }
}

TEST(CheckpointState, AnotherSceneOrADamagedFileIsRefusedNamingTheFile) {
  Simulation a(swing("implicit-midpoint"));
  a.advance_to(0.05);
  const std::string bytes = checkpoint_bytes(nlohmann::json::object(), a, RunResult{});
  Scene other = swing("implicit-midpoint");
  other.integrator.dt = 0.01;
  Simulation b(other);
  try {
    restore_checkpoint(bytes, "ckpt.weft", b);
    FAIL() << "a checkpoint of another dt was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("ckpt.weft: checkpoint belongs to another cloth or other settings"),
              std::string::npos) << e.what();
  }
  Simulation c(swing("implicit-midpoint"));
  EXPECT_THROW(restore_checkpoint(bytes.substr(0, bytes.size() - 1), "ckpt.weft", c), InputError);
  std::string flipped = bytes;
  flipped[100] ^= 4;
  EXPECT_THROW(restore_checkpoint(flipped, "ckpt.weft", c), InputError);
  EXPECT_THROW(checkpoint_header("not a checkpoint", "ckpt.weft"), InputError);
}

// With contacts the checkpoint also holds which contacts pulled and which stuck, so a restored
// run with friction and colliders steps to the same bits.
TEST(CheckpointState, RestoredSimulationWithContactsStepsToTheSameBits) {
  const Scene scene = test::dropped_onto_sphere_and_floor(swing("bdf2"));
  Simulation a(scene);
  a.advance_to(0.3);
  ASSERT_GT(a.core().statistics().contacts, 0);
  const std::string bytes = checkpoint_bytes({}, a, RunResult{});
  Simulation b(scene);
  restore_checkpoint(bytes, "mem", b);
  a.advance_to(0.4);
  b.advance_to(0.4);
  EXPECT_TRUE(same_bits(a.core().state().x, b.core().state().x));
  EXPECT_TRUE(same_bits(a.core().state().v, b.core().state().v));
  EXPECT_EQ(a.core().state().contact_work, b.core().state().contact_work);
  EXPECT_EQ(a.core().statistics().contacts, b.core().statistics().contacts);
  EXPECT_EQ(a.core().statistics().released_contacts, b.core().statistics().released_contacts);
}

TEST(CheckpointState, GuardedStepsResumeToTheSameBitsWhileTheGuardActs) {
  // On the 21x21 swing the guards act from the first swing on (the midpoint's halves steps,
  // BDF-2's raises alpha): the checkpoint is taken at the first frame where the next step
  // starts halved or at a raised alpha, so what the checkpoint carries of the guard decides
  // the next step.
  for (const auto& [guarded, plain_name] : {std::pair<const char*, const char*>{"implicit-midpoint", "implicit-midpoint-plain"},
                                            {"bdf2-alpha-guarded", "bdf2-alpha"}}) {
    SCOPED_TRACE(guarded);
    Scene scene = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/swing-21x21.json");
    scene.duration = 2.0;
    set_method(scene, guarded, std::nullopt, "test");
    Simulation a(scene);
    double t = 0;
    for (;;) {
      const Integrator::Data& at = a.core().integrator().data();
      if (at.guard_depth + at.guard_rung > 0) break;
      ASSERT_LT(t, 1.0) << "the guard never acted";
      t += scene.frame_interval;
      a.advance_to(t);
    }
    const std::string bytes = checkpoint_bytes(nlohmann::json::object(), a, RunResult{});
    Simulation b(scene);
    restore_checkpoint(bytes, "mem", b);
    a.advance_to(t + 0.4);
    b.advance_to(t + 0.4);
    EXPECT_TRUE(same_bits(a.core().state().x, b.core().state().x));
    EXPECT_TRUE(same_bits(a.core().state().v, b.core().state().v));
    EXPECT_EQ(a.core().statistics().guard_split_steps, b.core().statistics().guard_split_steps);
    EXPECT_EQ(a.core().statistics().guard_redone_steps, b.core().statistics().guard_redone_steps);
    EXPECT_EQ(a.core().statistics().guard_parts, b.core().statistics().guard_parts);
    // The plain step's checkpoint is another method's.
    set_method(scene, plain_name, std::nullopt, "test");
    Simulation plain(scene);
    EXPECT_THROW(restore_checkpoint(bytes, "mem", plain), InputError);
  }
}
