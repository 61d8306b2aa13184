// A checkpoint resumes only the simulation it was taken from (docs/scene-format.md,
// "Checkpoints"): restoring it into a simulation whose scene differs in any key that changes
// the motion (each scene key, each material key, each collider's) is refused, through the
// library as through Python, which have no scene hash to compare; keys that change only what
// is written or where the run starts (the state comes from the checkpoint) are not.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "sim/checkpoint.hpp"
#include "weft/error.hpp"
#include "weft/scene.hpp"
#include "weft/simulation.hpp"

using namespace weft;
using nlohmann::json;

namespace {

// A small cloth over one collider of each rigid kind, a clamp and a pin, of a material with a
// tabulated curve; its OBJ files in `dir`.
json base_scene() {
  return json::parse(R"({
    "weft_scene": 1, "description": "fingerprint", "duration": 0.04, "frame_interval": 0.02,
    "gravity": [0, -9.81, 0],
    "integrator": {"method": "implicit-midpoint", "dt": 0.01},
    "damping": {"ratio": 0.05},
    "cloth": {
      "mesh": {"grid": {"size": [0.2, 0.2], "vertices": [4, 4]}},
      "placement": {"rotation_deg": [-90, 0, 0], "translation": [0, 0.5, 0]},
      "material": {"surface_density": 0.15, "weft": {"strain": [0, 0.05, 0.1], "stress": [0, 20, 80]},
                   "warp": 400, "shear": 40, "poisson_ratio": 0.1, "bending_rigidity": 1e-5, "viscosity": 0.001},
      "bending_model": "hinge",
      "pins": {"vertices": [0]},
      "clamps": [{"vertices": [3], "motion": {"linear_velocity": [0, 0.1, 0]}}],
      "initial_velocity": [0, 0, 0],
      "thickness": 0.003, "friction": 0.3, "self_collision": true
    },
    "colliders": [
      {"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "thickness": 0.002, "friction": 0.3},
      {"type": "sphere", "centre": [0, 0.2, 0], "radius": 0.1},
      {"type": "capsule", "ends": [[-0.2, 0.1, 0], [0.2, 0.1, 0]], "radius": 0.03},
      {"type": "box", "centre": [0.5, 0.2, 0], "half_extents": [0.1, 0.1, 0.1], "rotation_deg": [0, 10, 0],
       "edge_radius": 0.01},
      {"type": "mesh", "obj": "tetra.obj", "scale": 1, "rotation_deg": [0, 0, 0], "translation": [-0.5, 0, 0],
       "closed": true, "motion": {"keyframes": [{"time": 0, "translation": [0, 0, 0]},
                                                {"time": 0.04, "translation": [0, 0.01, 0]}]}}
    ],
    "output": {"formats": ["obj"]}
  })");
}

// The same cloth as an OBJ of two triangles with texture coordinates.
json obj_cloth_scene() {
  json j = base_scene();
  j["cloth"]["mesh"] = {{"obj", "square.obj"}, {"uv_scale", 0.5}};
  j["cloth"].erase("clamps");
  return j;
}

std::string test_dir() {
  const std::string dir = testing::TempDir() + "weft_fingerprint_test";
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/tetra.obj") << "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
  std::ofstream(dir + "/tetra2.obj") << "v 0 0 0\nv 0.1 0 0\nv 0 0.12 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
  std::ofstream(dir + "/square.obj") << "v 0 0.5 0\nv 0.2 0.5 0\nv 0.2 0.5 0.2\nv 0 0.5 0.2\n"
                                        "vt 0 0\nvt 0.4 0\nvt 0.4 0.4\nvt 0 0.4\nf 1/1 4/4 3/3 2/2\n";
  return dir;
}

Scene scene_of(const json& j, const std::string& dir) { return parse_scene(j, dir + "/s.json", dir); }

// The restore's error, or "" when it was accepted.
std::string restore_error(const std::string& bytes, const Scene& scene) {
  Simulation sim(scene);
  try {
    restore_checkpoint(bytes, "ckpt.weft", sim);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

struct Change {
  std::string pointer;  // a JSON pointer into the scene
  json value;
};

void expect_refused(const json& base, const std::vector<Change>& changes, const std::string& dir) {
  Simulation a(scene_of(base, dir));
  a.advance_to(0.02);
  const std::string bytes = checkpoint_bytes(json::object(), a, RunResult{});
  EXPECT_EQ(restore_error(bytes, scene_of(base, dir)), "") << "the scene's own checkpoint";
  for (const Change& c : changes) {
    json j = base;
    j[json::json_pointer(c.pointer)] = c.value;
    Scene changed;
    try {
      changed = scene_of(j, dir);
    } catch (const InputError& e) {
      ADD_FAILURE() << c.pointer << " = " << c.value << " does not make a valid scene: " << e.what();
      continue;
    }
    EXPECT_NE(restore_error(bytes, changed).find("ckpt.weft: checkpoint belongs to another cloth or other settings"),
              std::string::npos)
        << "a checkpoint was resumed with " << c.pointer << " = " << c.value;
  }
}

}  // namespace

TEST(CheckpointFingerprint, EverySceneMaterialAndColliderKeyThatChangesTheMotionIsRefused) {
  const std::string dir = test_dir();
  const std::vector<Change> changes = {
      {"/duration", 0.06},
      {"/frame_interval", 0.01},
      {"/gravity", {0, -9.0, 0}},
      {"/integrator/method", "bdf2"},
      {"/integrator/dt", 0.005},
      {"/integrator/tolerance", 1e-5},
      {"/integrator/max_iterations", 500},
      {"/integrator/ssor_relaxation", 1.1},
      {"/integrator/ssor_precision", "double"},
      {"/integrator/newton_iterations", 2},
      {"/integrator/newton_tolerance", 1e-4},
      {"/integrator/preconditioner", "block-jacobi"},
      {"/integrator/contact_solve", "bounds"},
      {"/integrator/automatic_newton", false},
      {"/damping/ratio", 0.1},
      {"/cloth/mesh/grid/size", {0.2, 0.25}},
      {"/cloth/mesh/grid/vertices", {4, 5}},
      {"/cloth/mesh/grid/pattern", "shifted-rows"},
      {"/cloth/placement/rotation_deg", {-80, 0, 0}},
      {"/cloth/placement/translation", {0, 0.6, 0}},
      {"/cloth/material", "denim"},
      {"/cloth/material/surface_density", 0.2},
      {"/cloth/material/weft/stress", {0, 20, 90}},
      {"/cloth/material/weft/strain", {0, 0.05, 0.11}},
      {"/cloth/material/warp", 450},
      {"/cloth/material/shear", 45},
      {"/cloth/material/poisson_ratio", 0.2},
      {"/cloth/material/bending_rigidity", 2e-5},
      {"/cloth/material/viscosity", 0.002},
      {"/cloth/bending_model", "plate"},
      {"/cloth/pins/vertices", {1}},
      {"/cloth/clamps/0/vertices", {2}},
      {"/cloth/clamps/0/motion/linear_velocity", {0, 0.2, 0}},
      {"/cloth/thickness", 0.004},
      {"/cloth/friction", 0.9},
      {"/cloth/self_collision", false},
      {"/colliders/0/point", {0, 0.01, 0}},
      {"/colliders/0/normal", {0, 1, 0.1}},
      {"/colliders/0/thickness", 0.003},
      {"/colliders/0/friction", 0.5},
      {"/colliders/0/motion", {{"linear_velocity", {0, 0.1, 0}}}},
      {"/colliders/1/centre", {0, 0.21, 0}},
      {"/colliders/1/radius", 0.11},
      {"/colliders/2/ends", {{-0.2, 0.1, 0}, {0.2, 0.12, 0}}},
      {"/colliders/2/radius", 0.04},
      {"/colliders/3/centre", {0.5, 0.21, 0}},
      {"/colliders/3/half_extents", {0.1, 0.1, 0.12}},
      {"/colliders/3/rotation_deg", {0, 20, 0}},
      {"/colliders/3/edge_radius", 0.02},
      {"/colliders/4/obj", "tetra2.obj"},
      {"/colliders/4/scale", 1.1},
      {"/colliders/4/rotation_deg", {0, 5, 0}},
      {"/colliders/4/translation", {-0.5, 0.01, 0}},
      {"/colliders/4/closed", false},
      {"/colliders/4/motion/keyframes/1/translation", {0, 0.02, 0}},
      {"/colliders/4/motion/keyframes/1/rotation_deg", {0, 10, 0}},
      {"/colliders/4/motion/keyframes/1/time", 0.03},
  };
  expect_refused(base_scene(), changes, dir);
  // An OBJ cloth's pattern scale.
  expect_refused(obj_cloth_scene(), {{"/cloth/mesh/uv_scale", 0.6}}, dir);
}

TEST(CheckpointFingerprint, EveryKeyOfAWalkingBodyIsRefused) {
  const std::string dir = test_dir();
  {
    // The shipped walk played at another pace: the same motion, another file.
    std::ifstream in(std::string(WEFT_SOURCE_DIR) + "/data/motion/35_01.bvh");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const size_t at = text.find("Frame Time:");
    ASSERT_NE(at, std::string::npos);
    text.replace(at, text.find('\n', at) - at, "Frame Time: 0.01");
    std::ofstream(dir + "/walk.bvh") << text;
  }
  json base = base_scene();
  base["cloth"].erase("clamps");
  base["cloth"]["placement"]["translation"] = {0, 2.5, 0};
  base["colliders"] = json::parse(R"([{"type": "body", "speed": 0.75, "skinning": "lbs", "start_time": 0,
                                        "bind_pose_hold": 0, "blend": 0, "arm_spread_deg": 0,
                                        "thickness": 0.003, "friction": 0.5}])");
  expect_refused(base,
                 {{"/colliders/0/speed", 0.8},
                  {"/colliders/0/skinning", "dqs"},
                  {"/colliders/0/start_time", 0.5},
                  {"/colliders/0/bind_pose_hold", 0.1},
                  {"/colliders/0/blend", 0.1},
                  {"/colliders/0/arm_spread_deg", 5},
                  {"/colliders/0/motion", "walk.bvh"},
                  {"/colliders/0/thickness", 0.004},
                  {"/colliders/0/friction", 0.6}},
                 dir);
}

TEST(CheckpointFingerprint, KeysThatChangeOnlyTheOutputOrTheStartAreNotRefused) {
  // The state (where the run is, how fast it moves) comes from the checkpoint: the scene's
  // initial velocity is not the resumed run's; the description and the output formats are not
  // the motion's.
  const std::string dir = test_dir();
  const json base = base_scene();
  Simulation a(scene_of(base, dir));
  a.advance_to(0.02);
  const std::string bytes = checkpoint_bytes(json::object(), a, RunResult{});
  for (const Change& c : std::vector<Change>{{"/description", "another"},
                                             {"/output/formats", {"ply"}},
                                             {"/cloth/initial_velocity", {0, 1, 0}}}) {
    json j = base;
    j[json::json_pointer(c.pointer)] = c.value;
    EXPECT_EQ(restore_error(bytes, scene_of(j, dir)), "") << c.pointer;
  }
}
