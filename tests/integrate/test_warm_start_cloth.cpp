// The warm start on a smooth sequence of cloth steps: a falling sheet's right-hand sides
// change slowly from step to step, so the combination of the last solutions that fits the
// new right-hand side (SolutionHistory) starts each solve closer than the previous step's
// dv alone does, and the solves take fewer iterations in all. No exact count is asserted:
// it depends on how rounding falls; a clear margin is.
#include <gtest/gtest.h>

#include "support/cloth_step_problem.hpp"

using namespace weft;

TEST(WarmStart, HistoryCutsTheIterationsOfASmoothClothSequence) {
  long iterations[2] = {0, 0};
  const int histories[2] = {3, 0};
  for (int h = 0; h < 2; ++h) {
    Scene s = weft::test::cloth_step_scene(12);
    s.integrator.dt = s.frame_interval = 0.002;  // small steps: right-hand sides close together
    s.integrator.warm_start_history = histories[h];
    Simulation sim(s);
    sim.advance_to(0.3);
    ASSERT_EQ(sim.core().statistics().cg_failures, 0) << "history " << histories[h];
    iterations[h] = sim.core().statistics().cg_iterations;
  }
  RecordProperty("iterations_with_history", std::to_string(iterations[0]));
  RecordProperty("iterations_without", std::to_string(iterations[1]));
  EXPECT_LT(iterations[0], 0.8 * iterations[1]) << iterations[0] << " with history, " << iterations[1] << " without";
}
