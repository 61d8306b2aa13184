// The contact statistics of summary.json: a step taken in parts (the guarded midpoint's
// halvings) counts each part's linear solve once, so the mean number of node contacts held by
// a solve is never above the most held by one.
#include <gtest/gtest.h>

#include <string>

#include "weft/scene.hpp"
#include "weft/simulation.hpp"

using namespace weft;

TEST(ContactStatistics, TheMeanOfNodeContactsIsPerSolveAndNeverAboveTheMaximum) {
  // The stacked sheets landing on the box under the guarded midpoint, whose steps with
  // contacts are often taken in several parts.
  Scene scene = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/stacked-sheets.json");
  set_method(scene, "implicit-midpoint", std::nullopt, "test");
  scene.duration = 0.6;
  Simulation sim(scene);
  const RunResult result = run_simulation(sim);
  const StepStatistics& st = result.steps;
  ASSERT_GT(st.contact_solves, 0);
  // The property is only tested where parts outnumber steps (a mean per step would then exceed
  // the maximum per part when contacts hold steady).
  ASSERT_GT(st.guard_parts, st.steps);
  EXPECT_GE(st.contact_solves, st.steps / 2);
  EXPECT_LE(st.contacts, st.max_contacts * st.contact_solves);
  const nlohmann::json summary = summary_json(sim, result);
  const double mean = summary["contacts"]["node_contacts_mean"].get<double>();
  const long max = summary["contacts"]["node_contacts_max"].get<long>();
  EXPECT_DOUBLE_EQ(mean, static_cast<double>(st.contacts) / st.contact_solves);
  EXPECT_LE(mean, static_cast<double>(max));
  EXPECT_GT(mean, 0);
}
