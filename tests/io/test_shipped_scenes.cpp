// Every scene shipped in scenes/ must load and build a model: a scene that drifted from
// the format (an unknown key, a wrong type) or names a missing mesh fails here, naming it.
#include <gtest/gtest.h>

#include <filesystem>

#include "weft/scene.hpp"
#include "sim/simulation_core.hpp"

using namespace weft;

TEST(ShippedScenes, EverySceneFileLoadsAndBuildsAModel) {
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(std::string(WEFT_SOURCE_DIR) + "/scenes")) {
    if (entry.path().extension() != ".json") continue;
    ++count;
    SCOPED_TRACE(entry.path().string());
    Scene scene;
    ASSERT_NO_THROW(scene = load_scene(entry.path().string()));
    EXPECT_GT(scene.duration, 0.0);
    Simulation sim(scene);
    EXPECT_GT(sim.core().model().num_vertices(), 0);
  }
  EXPECT_GE(count, 2) << "scenes/ should hold the default scene and the benchmark's sheet";
}
