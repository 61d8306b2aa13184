// `weft run` on the bad inputs of the reliability issue: each exits with status 2, names the
// file, the line or key and the value, and writes nothing.
#include <chrono>
#include <string>
#include <vector>

#include "support/command.hpp"
#include "weft/scene.hpp"

using weft::test::CommandTest;

namespace {

std::string scene(const std::string& cloth, const std::string& extra = "") {
  return R"({"weft_scene": 1, "duration": 0.04, "frame_interval": 0.02, )" + extra +
         R"("integrator": {"method": "implicit-midpoint", "dt": 0.01}, "cloth": {)" + cloth + "}}";
}

const char* kGrid = R"("mesh": {"grid": {"size": [0.2, 0.2], "vertices": [5, 5]}})";

}  // namespace

class BadInputCommand : public CommandTest {
 protected:
  /// Runs the scene and checks exit status 2, the expected text, the file named, no output.
  void expect_refused(const std::string& name, const std::string& text, const std::string& expected,
                      const std::string& file_named = "") {
    const auto s = write(name + ".json", text);
    const auto out = folder_ / ("out_" + name);
    const auto r = weft("run '" + s.string() + "' --out '" + out.string() + "' --quiet");
    EXPECT_EQ(r.exit_code, 2) << name << ": " << r.error_output;
    EXPECT_NE(r.error_output.find(expected), std::string::npos) << name << ": " << r.error_output;
    const std::string file = file_named.empty() ? s.string() : (folder_ / file_named).string();
    EXPECT_NE(r.error_output.find(file), std::string::npos) << name << " should name " << file << ": " << r.error_output;
    EXPECT_EQ(r.error_output.find("internal error"), std::string::npos) << name << ": " << r.error_output;
    EXPECT_FALSE(std::filesystem::exists(out)) << name << ": output written for bad input";
  }
};

TEST_F(BadInputCommand, ObjIndicesOutOfRange) {
  write("m.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 1000000\n");
  expect_refused("vertex", scene(R"("mesh": {"obj": "m.obj"}, "pins": {"vertices": [0]})"),
                 "m.obj:4: face refers to vertex 1000000, out of range (the file has 3 vertices)", "m.obj");
  write("t.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/1000000\n");
  expect_refused("texcoord", scene(R"("mesh": {"obj": "t.obj"}, "pins": {"vertices": [0]})"),
                 "t.obj:7: face refers to texture coordinate 1000000, out of range (the file has 3 texture coordinates)",
                 "t.obj");
}

TEST_F(BadInputCommand, ObjCoordinatesThatAreNotNumbers) {
  write("nan.obj", "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n");
  expect_refused("nan", scene(R"("mesh": {"obj": "nan.obj"}, "pins": {"vertices": [0]})"),
                 "nan.obj:2: expected a finite number, got 'nan'", "nan.obj");
  write("garbage.obj", "v 0 0 0\nv 1 0 0\nv 0 0.1x 0\nf 1 2 3\n");
  expect_refused("garbage", scene(R"("mesh": {"obj": "garbage.obj"}, "pins": {"vertices": [0]})"),
                 "garbage.obj:3: expected a number, got '0.1x'", "garbage.obj");
}

TEST_F(BadInputCommand, IntegersBeyond32Bits) {
  expect_refused("grid", scene(R"("mesh": {"grid": {"size": [0.2, 0.2], "vertices": [4294967307, 11]}})"),
                 "key cloth.mesh.grid.vertices: need at least 2 per side and at most 4000000 in all, got [4294967307,11]");
  expect_refused("pin", scene(std::string(kGrid) + R"(, "pins": {"vertices": [4294967296]})"),
                 "key cloth.pins.vertices: expected vertex indices, integers in [0, 2147483647], got 4294967296");
}

TEST_F(BadInputCommand, DuplicateKeysAndNumbersTooLargeForJson) {
  expect_refused("duplicate", scene(std::string(kGrid) + R"(, "material": {"weft": 100, "weft": 200})"),
                 "key cloth.material.weft: duplicate key");
  const std::string huge = R"({"weft_scene": 1, "duration": 1e400, "frame_interval": 0.02})";
  expect_refused("huge", huge, "key duration: number 1e400 is too large");
}

TEST_F(BadInputCommand, PhysicallyAbsurdMagnitudes) {
  expect_refused("gravity", scene(kGrid, R"("gravity": [0, 1e200, 0], )"),
                 "key gravity: value [0,1e+200,0] (array) is out of range: each component must be within [-1000.0, 1000.0] m/s^2");
  expect_refused("position", scene(std::string(kGrid) + R"(, "placement": {"translation": [1e308, 0, 0]})"),
                 "key cloth.placement.translation: value [1e+308,0,0] (array) is out of range");
  expect_refused("velocity", scene(std::string(kGrid) + R"(, "initial_velocity": [0, 0, 1e308])"),
                 "key cloth.initial_velocity: value [0,0,1e+308] (array) is out of range");
  expect_refused("modulus", scene(std::string(kGrid) + R"(, "material": {"weft": 1e300})"),
                 "key cloth.material: field weft: value 1e+300 N/m is out of range (0, 1000000000] N/m");
}

TEST_F(BadInputCommand, GridsTooLargeForMemoryAreRefusedQuicklyWithTheEstimate) {
  // 2000 x 2000 vertices: beyond the cap on a run's memory on every machine, refused before
  // anything is built.
  ASSERT_GT(weft::estimated_run_bytes(4'000'000), weft::kMaxRunBytes);
  const auto start = std::chrono::steady_clock::now();
  expect_refused("big", scene(R"("mesh": {"grid": {"size": [1, 1], "vertices": [2000, 2000]}})"),
                 "key cloth.mesh.grid.vertices: a 2000 x 2000 grid (4000000 vertices) needs about ");
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 10.0);
}

TEST_F(BadInputCommand, ColliderDescriptions) {
  auto with = [](const std::string& collider) {
    return scene(kGrid, R"("colliders": [)" + collider + "], ");
  };
  expect_refused("type", with(R"({"type": "cylinder"})"),
                 "key colliders[0].type: unknown collider type 'cylinder' (expected plane, sphere, capsule, box, mesh or body)");
  expect_refused("thickness", with(R"({"type": "sphere", "centre": [0, 0, 0], "radius": 0.1, "thickness": -0.01})"),
                 "key colliders[0].thickness: value -0.01 is out of range (0.0, 0.1]");
  expect_refused("friction", with(R"({"type": "plane", "friction": -1})"), "key colliders[0].friction: value -1");
  expect_refused("missing_obj", with(R"({"type": "mesh", "obj": "nope.obj"})"), "key colliders[0].obj: no such file: ");
  expect_refused("unknown_key", with(R"({"type": "sphere", "centre": [0, 0, 0], "radius": 0.1, "colour": 1})"),
                 "key colliders[0].colour: unknown key for a sphere collider (expected type, thickness, friction, "
                 "motion, centre, radius)");
  expect_refused("radius", with(R"({"type": "sphere", "centre": [0, 0, 0], "radius": 0})"), "key colliders[0].radius");
  expect_refused("keyframes",
                 with(R"({"type": "box", "centre": [0, 0, 0], "half_extents": [1, 1, 1],
                          "motion": {"keyframes": [{"time": 1}, {"time": 0.5}]}})"),
                 "key colliders[0].motion.keyframes[1].time: keyframe times must increase, got 0.5 after 1.0");
  expect_refused("both_motions", with(R"({"type": "plane", "motion": {"linear_velocity": [0, 1, 0], "keyframes": []}})"),
                 "key colliders[0].motion.keyframes: give either keyframes or linear_velocity/angular_velocity_deg/centre, "
                 "not both");
  expect_refused("edge_radius", with(R"({"type": "box", "centre": [0, 0, 0], "half_extents": [1, 0.25, 1], "edge_radius": 0.25})"),
                 "key colliders[0].edge_radius: expected a radius below the smallest half extent (0.25 m), got 0.25");
  expect_refused("zero_normal", with(R"({"type": "plane", "normal": [0, 0, 0]})"), "key colliders[0].normal: must not be zero");
  write("bad.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\n");
  expect_refused("bad_obj", with(R"({"type": "mesh", "obj": "bad.obj"})"),
                 "colliders[0] (mesh): ", "bad.obj");
  expect_refused("cloth_thickness", scene(std::string(kGrid) + R"(, "thickness": 0)"),
                 "key cloth.thickness: value 0.0 is out of range (0.0, 0.1]");
  expect_refused("self_collision", scene(std::string(kGrid) + R"(, "self_collision": "yes")"), "key cloth.self_collision");
  expect_refused("clamp_empty", scene(std::string(kGrid) + R"(, "clamps": [{"motion": {"linear_velocity": [1, 0, 0]}}])"),
                 "key cloth.clamps[0].vertices: a clamp needs at least one vertex");
  expect_refused("clamp_vertex", scene(std::string(kGrid) + R"(, "clamps": [{"vertices": [25]}])"),
                 "cloth.clamps[0].vertices: vertex 25 does not exist (the mesh has 25 vertices)");
  expect_refused("clamp_pinned",
                 scene(std::string(kGrid) + R"(, "pins": {"vertices": [3]}, "clamps": [{"grid": [[3, 0]]}])"),
                 "cloth.clamps[0]: vertex 3 is already pinned or in another clamp");
  expect_refused("clamp_key", scene(std::string(kGrid) + R"(, "clamps": [{"vertices": [1], "speed": 2}])"),
                 "key cloth.clamps[0].speed: unknown key");
}

TEST_F(BadInputCommand, AGarmentPanelOfAnUnknownMaterial) {
  const std::string shirt = std::string(WEFT_SOURCE_DIR) + "/data/patterns/garmentcode/shirt_mean_specification.json";
  expect_refused("panel_material",
                 scene(R"("mesh": {"pattern": {"file": ")" + shirt +
                           R"(", "panels": {"left_sleeve_f": {"material": "velvet"}}}})",
                       R"("colliders": [{"type": "body", "bind_pose_hold": 0.5}], )"),
                 "key cloth.mesh.pattern.panels.left_sleeve_f.material: unknown material preset \"velvet\"");
}

TEST_F(BadInputCommand, AGarmentPanelThePatternLacks) {
  // Checked when the garment is made rather than when the scene is read: still before anything
  // is written.
  const std::string shirt = std::string(WEFT_SOURCE_DIR) + "/data/patterns/garmentcode/shirt_mean_specification.json";
  expect_refused("panel_name",
                 scene(R"("mesh": {"pattern": {"file": ")" + shirt + R"(", "panels": {"collar": {"part": "head"}}}})",
                       R"("colliders": [{"type": "body", "bind_pose_hold": 0.5}], )"),
                 "key cloth.mesh.pattern.panels.collar: the pattern " + shirt + " has no panel 'collar'");
}
