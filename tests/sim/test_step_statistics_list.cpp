// The step statistics are declared once (WEFT_STEP_STATISTICS, weft/statistics.hpp) and that
// one list drives the checkpoint, summary.json and the Python module: every statistic
// survives a checkpoint round trip, and every one with a summary key appears in summary.json
// under it with its value. The cloth-cloth fail-safe's counts (WEFT_SELF_CONTACT_STATISTICS,
// collision/self_contact.hpp) likewise, under summary.json's contacts.self.
#include <gtest/gtest.h>

#include <iterator>
#include <set>
#include <string>
#include <utility>

#include "collision/self_contact.hpp"
#include "sim/checkpoint.hpp"
#include "sim/model_data.hpp"
#include "sim/simulation_core.hpp"
#include "support/contact_scene.hpp"
#include "weft/simulation.hpp"
#include "weft/statistics.hpp"

using namespace weft;

namespace {

/// Each statistic of a list (kStepStatistics, kSelfContactStatistics) a value of its own:
/// counts 1001, 1002, ..., the others 0.25 more than their index, so that a field read into
/// another's place shows.
template <class Statistics, class List>
Statistics distinct_values(const List& list) {
  Statistics st;
  long k = 0;
  for (const auto& s : list) {
    ++k;
    if (s.count) {
      st.*s.count = 1000 + k;
    } else {
      st.*s.value = static_cast<double>(k) + 0.25;
    }
  }
  return st;
}

StepStatistics distinct_statistics() { return distinct_values<StepStatistics>(kStepStatistics); }

SelfContactStatistics distinct_self_contact_statistics() {
  return distinct_values<SelfContactStatistics>(kSelfContactStatistics);
}

double value_of(const SelfContactStatistic& s, const SelfContactStatistics& st) {
  return s.count ? static_cast<double>(st.*s.count) : st.*s.value;
}

/// The stacked sheets (self-collision on), for one frame.
Scene scene_with_self_contacts() {
  Scene scene = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/stacked-sheets.json");
  scene.duration = scene.frame_interval;
  return scene;
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

TEST(SelfContactStatisticsList, NamesEveryFieldOnceAndEachSummaryKeyOnce) {
  EXPECT_EQ(sizeof(SelfContactStatistics), std::size(kSelfContactStatistics) * sizeof(double));
  std::set<std::string> fields, keys;
  for (const SelfContactStatistic& s : kSelfContactStatistics) {
    EXPECT_TRUE(fields.insert(s.field).second) << s.field;
    EXPECT_TRUE(keys.insert(s.key).second) << s.key;
    EXPECT_NE((s.count == nullptr), (s.value == nullptr)) << s.field;
  }
  // thickness and friction share the object: no statistic may take their keys.
  EXPECT_EQ(keys.count("thickness") + keys.count("friction"), 0u);
}

TEST(SelfContactStatisticsList, EveryStatisticSurvivesACheckpointRoundTrip) {
  const std::unique_ptr<SimulationModel> model = build_model(scene_with_self_contacts());
  std::unique_ptr<SimulationData> a = make_data(*model), b = make_data(*model);
  ASSERT_TRUE(a->self_contacts && b->self_contacts);
  a->self_contacts->set_statistics(distinct_self_contact_statistics());
  BinaryWriter out;
  save_data(*model, *a, out);
  BinaryReader in(out.bytes(), "mem");
  restore_data(*model, *b, in);
  EXPECT_TRUE(in.at_end());
  for (const SelfContactStatistic& s : kSelfContactStatistics) {
    SCOPED_TRACE(s.field);
    EXPECT_EQ(value_of(s, b->self_contacts->statistics()), value_of(s, a->self_contacts->statistics()));
  }
}

TEST(SelfContactStatisticsList, EveryStatisticIsInTheSummaryUnderItsKey) {
  Simulation sim(scene_with_self_contacts());
  const SelfContactStatistics st = distinct_self_contact_statistics();
  sim.core().simulation_data().self_contacts->set_statistics(st);
  const nlohmann::json j = summary_json(sim, RunResult{});
  ASSERT_TRUE(j.contains("contacts") && j.at("contacts").contains("self"));
  const nlohmann::json& self = j.at("contacts").at("self");
  EXPECT_EQ(self.size(), std::size(kSelfContactStatistics) + 2);  // and thickness, friction
  for (const SelfContactStatistic& s : kSelfContactStatistics) {
    SCOPED_TRACE(s.key);
    ASSERT_TRUE(self.contains(s.key));
    if (s.count) {
      ASSERT_TRUE(self.at(s.key).is_number_integer());
      EXPECT_EQ(self.at(s.key).get<long>(), st.*s.count);
    } else {
      EXPECT_EQ(self.at(s.key).get<double>(), st.*s.value);
    }
  }
}
