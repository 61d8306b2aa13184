// `weft experiment walk`'s building blocks on a tiny garment walk: every frame measured,
// frames written where weft render and weft view read them, the tables written, bad labels refused.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "weft/experiments/walk.hpp"
#include "weft/error.hpp"

using namespace weft;

namespace {

Scene tiny_walk() {
  const std::string text = R"({
    "weft_scene": 1, "duration": 0.12, "frame_interval": 0.02,
    "integrator": {"method": "backward-euler", "dt": 0.005},
    "cloth": {"mesh": {"pattern": {"file": "../data/patterns/garmentcode/shirt_mean_specification.json",
                                   "edge_length": 0.04}},
              "material": "cotton", "self_collision": true},
    "colliders": [{"type": "body", "bind_pose_hold": 0.1, "blend": 0.5, "thickness": 0.004}]})";
  return parse_scene_text(text, "tiny-walk.json", std::string(WEFT_SOURCE_DIR) + "/scenes");
}

}  // namespace

TEST(WalkExperiment, MeasuresEveryFrameAndWritesTheRunsFramesAndTables) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "weft_walk_experiment_test";
  std::filesystem::remove_all(dir);
  WalkExperimentOptions o;
  o.only = {"be-5ms"};
  const WalkExperiment ex = run_walk_experiment(tiny_walk(), o, dir);
  ASSERT_EQ(ex.runs.size(), 1u);
  const WalkRun& r = ex.runs[0];
  EXPECT_EQ(r.entry.configuration.label, "be-5ms");
  EXPECT_EQ(r.result.status, "ok") << r.result.message;
  const size_t frames = 7;  // 0, 0.02, ..., 0.12
  EXPECT_EQ(r.time.size(), frames);
  EXPECT_EQ(r.intersections.size(), frames);
  EXPECT_EQ(r.relative_kinetic.size(), frames);
  EXPECT_EQ(r.hem_forward.size(), frames);
  for (double e : r.relative_kinetic) EXPECT_GE(e, 0.0);
  EXPECT_EQ(r.relative_kinetic.front(), 0.0);  // the garment starts at rest on a body at rest
  EXPECT_TRUE(ex.reference.empty());           // im-2ms was not run: no distances
  EXPECT_TRUE(r.distance.empty());
  for (size_t f = 0; f < frames; ++f) {
    char name[64];
    std::snprintf(name, sizeof name, "frame_%05zu.ply", f);
    EXPECT_TRUE(std::filesystem::exists(dir / "be-5ms" / "frames" / name)) << name;
    std::snprintf(name, sizeof name, "body0_%05zu.obj", f);
    EXPECT_TRUE(std::filesystem::exists(dir / "be-5ms" / "frames" / name)) << name;
  }
  write_walk_experiment(ex, dir);
  for (const char* file : {"results.md", "results.csv", "results.json", "liveliness.csv", "be-5ms/energy.csv", "be-5ms/summary.json"})
    EXPECT_TRUE(std::filesystem::exists(dir / file)) << file;
  std::ifstream json_in(dir / "results.json");
  const nlohmann::json results = nlohmann::json::parse(json_in);
  ASSERT_EQ(results.at("runs").size(), 1u);
  EXPECT_EQ(results["runs"][0]["label"], "be-5ms");
  EXPECT_EQ(results["runs"][0]["intersections_per_frame"].size(), frames);
  std::ifstream csv(dir / "liveliness.csv");
  std::string line;
  size_t lines = 0;
  while (std::getline(csv, line)) ++lines;
  EXPECT_EQ(lines, frames + 1);
  std::filesystem::remove_all(dir);
}

TEST(WalkExperiment, AnUnknownConfigurationIsRefusedByName) {
  WalkExperimentOptions o;
  o.only = {"be-5ms", "rk4-1ms"};
  try {
    run_walk_experiment(tiny_walk(), o, std::filesystem::temp_directory_path());
    FAIL() << "accepted rk4-1ms";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 "--configs: unknown configuration 'rk4-1ms' (expected some of im-5ms, im-2ms, be-2ms, be-5ms, "
                 "bdf2-2ms, bdf2-alpha-2ms, bdf2-alpha-guarded-5ms)");
  }
}
