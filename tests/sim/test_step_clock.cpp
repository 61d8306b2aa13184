// The fixed-step methods' clock (State::step_clock): a run cut into calls of any length (how
// often frames are written) steps through the same times, so it gives the same bits as the
// run made in one call, while each call still ends at the time it asked for exactly.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "sim/simulation_core.hpp"

using namespace weft;

namespace {

bool same_bits(const VecX& a, const VecX& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0;
}

// The spinning sphere at 13 x 13: the collider's pose, and so every contact, follows the time.
Scene spinning(const char* method) {
  Scene scene = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/spinning-sphere.json");
  scene.cloth.grid->vertices_u = scene.cloth.grid->vertices_v = 13;
  set_method(scene, method, std::nullopt, "test");
  return scene;
}

}  // namespace

TEST(StepClock, HowARunIsCutIntoCallsDoesNotChangeIt) {
  constexpr double kEnd = 0.3;
  for (const char* method : {"bdf2", "implicit-midpoint", "backward-euler"}) {
    SCOPED_TRACE(method);
    const Scene scene = spinning(method);
    const double dt = scene.integrator.dt;
    Simulation whole(scene);
    whole.advance_to(kEnd);
    ASSERT_GT(whole.core().statistics().contacts, 0) << "the cloth never reached the sphere";
    EXPECT_EQ(whole.core().state().t, kEnd);
    // Calls of 1, 3 and 7 steps, each ending at k times its length (times that the sum of the
    // steps misses in the last bits), then the end.
    for (int per_call : {1, 3, 7}) {
      SCOPED_TRACE(per_call);
      Simulation cut(scene);
      for (int k = 1; k * per_call * dt < kEnd - 0.5 * dt; ++k) {
        cut.advance_to(k * (per_call * dt));
        EXPECT_EQ(cut.core().state().t, k * (per_call * dt));
      }
      cut.advance_to(kEnd);
      EXPECT_EQ(cut.core().state().t, kEnd);
      EXPECT_TRUE(same_bits(whole.core().state().x, cut.core().state().x));
      EXPECT_TRUE(same_bits(whole.core().state().v, cut.core().state().v));
      EXPECT_EQ(whole.core().statistics().steps, cut.core().statistics().steps);
    }
  }
}
