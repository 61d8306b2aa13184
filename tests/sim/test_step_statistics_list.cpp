// The step statistics are declared once (WEFT_STEP_STATISTICS, weft/statistics.hpp) and that
// one list drives the checkpoint, summary.json and the Python module: every statistic
// survives a checkpoint round trip, and every one with a summary key appears in summary.json
// under it with its value.
#include <gtest/gtest.h>

#include <iterator>
#include <set>
#include <string>
#include <utility>

#include "sim/checkpoint.hpp"
#include "sim/model_data.hpp"
#include "support/contact_scene.hpp"
#include "weft/simulation.hpp"
#include "weft/statistics.hpp"

using namespace weft;

namespace {

/// Each statistic a value of its own: counts 1001, 1002, ..., the others 0.25 more than their
/// index, so that a field read into another's place shows.
StepStatistics distinct_statistics() {
  StepStatistics st;
  long k = 0;
  for (const StepStatistic& s : kStepStatistics) {
    ++k;
    if (s.count) {
      st.*s.count = 1000 + k;
    } else {
      st.*s.value = static_cast<double>(k) + 0.25;
    }
  }
  return st;
}

/// The swing dropped onto a sphere and a floor under the guarded midpoint with a Newton
/// iteration: summary.json then has its contacts, guard and newton objects.
Scene scene_with_every_group() {
  Scene scene = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/swing.json");
  set_method(scene, "implicit-midpoint", std::nullopt, "test");
  scene.integrator.newton_iterations = 1;
  scene.integrator.dt = 0.005;
  scene.duration = scene.frame_interval;
  return test::dropped_onto_sphere_and_floor(scene);
}

}  // namespace

TEST(StepStatisticsList, NamesEveryFieldOnceAndEachSummaryKeyOnce) {
  // The struct is made from the list, so its size is the list's; a field added to it by hand
  // would change the size.
  EXPECT_EQ(sizeof(StepStatistics), std::size(kStepStatistics) * sizeof(double));
  std::set<std::string> fields;
  std::set<std::pair<std::string, std::string>> keys;
  for (const StepStatistic& s : kStepStatistics) {
    EXPECT_TRUE(fields.insert(s.field).second) << s.field;
    EXPECT_NE((s.count == nullptr), (s.value == nullptr)) << s.field;
    EXPECT_EQ(s.count != nullptr, s.kind == StatisticKind::kCount) << s.field;
    if (*s.key) EXPECT_TRUE(keys.insert({s.group, s.key}).second) << s.group << "." << s.key;
  }
}

TEST(StepStatisticsList, EveryStatisticSurvivesACheckpointRoundTrip) {
  const std::unique_ptr<SimulationModel> model = build_model(scene_with_every_group());
  std::unique_ptr<SimulationData> a = make_data(*model), b = make_data(*model);
  a->statistics = distinct_statistics();
  BinaryWriter out;
  save_data(*model, *a, out);
  BinaryReader in(out.bytes(), "mem");
  restore_data(*model, *b, in);
  EXPECT_TRUE(in.at_end());
  for (const StepStatistic& s : kStepStatistics) {
    SCOPED_TRACE(s.field);
    EXPECT_EQ(s.of(b->statistics), s.of(a->statistics));
  }
}

TEST(StepStatisticsList, EveryStatisticWithAKeyIsInTheSummaryUnderIt) {
  Simulation sim(scene_with_every_group());
  RunResult r = run_simulation(sim);
  r.steps = distinct_statistics();
  const nlohmann::json j = summary_json(sim, r);
  for (const char* group : {"contacts", "guard", "newton"}) ASSERT_TRUE(j.contains(group)) << group;
  for (const StepStatistic& s : kStepStatistics) {
    if (!*s.key) continue;
    SCOPED_TRACE(std::string(s.group) + "." + s.key);
    const nlohmann::json& where = *s.group ? j.at(s.group) : j;
    ASSERT_TRUE(where.contains(s.key));
    if (s.count) {
      ASSERT_TRUE(where.at(s.key).is_number_integer());
      EXPECT_EQ(where.at(s.key).get<long>(), r.steps.*s.count);
    } else {
      EXPECT_EQ(where.at(s.key).get<double>(), r.steps.*s.value);
    }
  }
}
