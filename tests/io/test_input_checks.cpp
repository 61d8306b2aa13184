// Readers refuse bad input with InputError naming the file, the line or key, the value and what
// was expected: out-of-range indices, non-numbers, trailing text, integers beyond their type,
// duplicate keys, numbers too large for a double and physically absurd magnitudes.
#include <gtest/gtest.h>

#include <climits>
#include <string>

#include "io/json_util.hpp"
#include "io/obj_file.hpp"
#include "weft/error.hpp"
#include "weft/material.hpp"
#include "weft/scene.hpp"

using namespace weft;

namespace {

template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

std::string obj_error(const std::string& text) {
  return error_of([&] { cloth_mesh_from_obj(parse_obj(text, "m.obj"), 1.0, "m.obj"); });
}

const char* kTriangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

// A valid scene with `cloth` replaced, and `extra` top-level keys added.
std::string scene(const std::string& cloth = R"("mesh": {"grid": {"size": [1, 1], "vertices": [3, 3]}})",
                  const std::string& extra = "") {
  return R"({"weft_scene": 1, "duration": 0.1, "frame_interval": 0.02, )" + extra +
         R"("integrator": {"method": "implicit-midpoint", "dt": 0.01}, "cloth": {)" + cloth + "}}";
}

std::string scene_error(const std::string& text) {
  return error_of([&] {
    const Scene s = parse_scene_text(text, "s.json", ".");
    resolve_pins(s.cloth, build_cloth_mesh(s.cloth));
  });
}

}  // namespace

TEST(ObjReader, FaceIndicesOutOfRangeAreRefusedWithTheLine) {
  EXPECT_EQ(obj_error(std::string(kTriangle) + "f 1 2 1000000\n"),
            "m.obj:4: face refers to vertex 1000000, out of range (the file has 3 vertices)");
  EXPECT_EQ(obj_error(std::string(kTriangle) + "vt 0 0\nf 1/1 2/1 3/7\n"),
            "m.obj:5: face refers to texture coordinate 7, out of range (the file has 1 texture coordinates)");
  EXPECT_EQ(obj_error(std::string(kTriangle) + "f 1 2 -4\n"), "m.obj:4: vertex index -4 is out of range (3 read so far)");
  EXPECT_EQ(obj_error(std::string(kTriangle) + "f 0 1 2\n"), "m.obj:4: vertex index 0 is out of range (indices start at 1)");
  EXPECT_EQ(obj_error(std::string(kTriangle) + "f 1 2 99999999999999999999\n"),
            "m.obj:4: expected a vertex index, got '99999999999999999999'");
  EXPECT_EQ(obj_error(std::string(kTriangle) + "f 1//2 2 3\n"), "m.obj:4: face refers to normal 2, out of range (the file has 0 normals)");
}

TEST(ObjReader, TheLastIndexOfEachKindIsReadAndTheOnePastItIsRefusedNamingFileAndLine) {
  // Three vertices, two texture coordinates and one normal; the face on line 7.
  const std::string head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvn 0 0 1\n";
  EXPECT_EQ(obj_error(head + "f 1/1/1 2/2/1 3/2/1\n"), "(no error)");
  EXPECT_EQ(obj_error(head + "f -3/-2/-1 -2/-1/-1 -1/-1/-1\n"), "(no error)");  // relative: the last is -1
  EXPECT_EQ(obj_error(head + "f 1 2 4\n"), "m.obj:7: face refers to vertex 4, out of range (the file has 3 vertices)");
  EXPECT_EQ(obj_error(head + "f 1/1 2/2 3/3\n"),
            "m.obj:7: face refers to texture coordinate 3, out of range (the file has 2 texture coordinates)");
  EXPECT_EQ(obj_error(head + "f 1//1 2//2 3//1\n"), "m.obj:7: face refers to normal 2, out of range (the file has 1 normals)");
  EXPECT_EQ(obj_error(head + "f 1 2 -4\n"), "m.obj:7: vertex index -4 is out of range (3 read so far)");
  EXPECT_EQ(obj_error(head + "f 1/1 2/1 3/-3\n"), "m.obj:7: texture coordinate index -3 is out of range (2 read so far)");
}

TEST(ObjReader, CoordinatesMustBeFiniteNumbersWithNothingAfterThem) {
  EXPECT_EQ(obj_error("v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), "m.obj:1: expected a finite number, got 'nan'");
  EXPECT_EQ(obj_error("v 0 0 0\nv 0.1x 0 0\nv 0 1 0\nf 1 2 3\n"), "m.obj:2: expected a number, got '0.1x'");
  EXPECT_EQ(obj_error("v 0 0 0\nv 1 0 0\nv 0 1e400 0\nf 1 2 3\n"), "m.obj:3: number '1e400' is out of range");
  EXPECT_EQ(obj_error("v 0 0 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
            "m.obj:1: expected a vertex (x y z, x y z w or x y z r g b), got 5 values (trailing text '0')");
  EXPECT_EQ(obj_error(std::string(kTriangle) + "vt 0.5 0.5 0 7\n"),
            "m.obj:4: expected a texture coordinate (u [v [w]]), got 4 values (trailing text '7')");
  EXPECT_EQ(obj_error(std::string(kTriangle) + "f 1 2 3x\n"), "m.obj:4: expected a vertex index, got '3x'");
  EXPECT_EQ(obj_error(std::string(kTriangle) + "vertex 1 2 3\n"),
            "m.obj:4: unknown statement 'vertex' (expected v, vt, vn, f, g, o, s, l, p, vp, usemtl or mtllib)");
  EXPECT_EQ(obj_error("v 0 0 0\nv 1 0 0\nv 0 2e6 0\nf 1 2 3\n"),
            "m.obj:3: coordinate '2e6' is out of range (expected a magnitude of at most 1e6)");
  // Within the file format's range but not a cloth: beyond 10 km.
  EXPECT_EQ(obj_error("v 0 0 0\nv 1 0 0\nv 0 2e4 0\nf 1 2 3\n"),
            "m.obj:3: vertex 3 lies beyond 10000.0 m (a cloth mesh is in metres; each coordinate must be within [-1e4, 1e4])");
}

TEST(ObjReader, CoordinatesAreReadInDoublePrecision) {
  const ObjData obj = parse_obj("v 0.1 0.7 1e-9\nv 1 0 0\nv 0 1 0\nvt 0.3 0.9\nf 1/1 2/1 3/1\n", "m.obj");
  // In single precision 0.1f != 0.1: the double nearest the decimal text must come back.
  EXPECT_EQ(obj.positions[0], 0.1);
  EXPECT_EQ(obj.positions[1], 0.7);
  EXPECT_EQ(obj.positions[2], 1e-9);
  EXPECT_EQ(obj.texcoords[0], 0.3);
  EXPECT_EQ(obj.texcoords[1], 0.9);
}

TEST(ObjReader, ReadsPolygonsGroupsAndCornerForms) {
  const ObjData obj = parse_obj(
      "# comment\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0 # trailing comment\nvt 0 0\nvn 0 0 1\n"
      "g top\nf 1/1/1 2//1 3/1 4\no other\ns off\nf -4 -3 -2\n",
      "m.obj");
  ASSERT_EQ(obj.triangles.size(), 3u);
  EXPECT_EQ(obj.triangles[1][2].vertex, 3);
  EXPECT_EQ(obj.triangles[0][0].texcoord, 0);
  EXPECT_EQ(obj.triangles[0][1].texcoord, -1);
  ASSERT_EQ(obj.groups.size(), 2u);
  EXPECT_EQ(obj.groups[0].name, "top");
  EXPECT_EQ(obj.groups[0].end_triangle, 2u);
  EXPECT_EQ(obj.groups[1].name, "other");
  EXPECT_EQ(obj.triangle_line[2], 12);
}

TEST(SceneRanges, ClothFrictionIsTakenFromZeroToTenAndRefusedOutside) {
  const auto with_friction = [](const std::string& value) {
    return scene(R"("mesh": {"grid": {"size": [1, 1], "vertices": [3, 3]}}, "friction": )" + value);
  };
  EXPECT_EQ(parse_scene_text(with_friction("0"), "s.json", ".").cloth.friction, 0.0);
  EXPECT_EQ(parse_scene_text(with_friction("10"), "s.json", ".").cloth.friction, 10.0);
  EXPECT_EQ(scene_error(with_friction("-1")), "s.json: key cloth.friction: value -1.0 is out of range [0.0, 10.0]");
  EXPECT_EQ(scene_error(with_friction("10.5")), "s.json: key cloth.friction: value 10.5 is out of range [0.0, 10.0]");
}

TEST(JsonReader, DuplicateKeysAreRefusedNamingTheKey) {
  EXPECT_EQ(error_of([] { json_util::parse_json(R"({"a": {"b": 1, "c": [{"d": 1, "d": 2}]}})", "f.json"); }),
            "f.json: key a.c[0].d: duplicate key (a key may appear only once in an object)");
  EXPECT_EQ(error_of([] { json_util::parse_json(R"({"a": 1, "b": [1, {"x": 1}], "a": 2})", "f.json"); }),
            "f.json: key a: duplicate key (a key may appear only once in an object)");
  // The same key in two objects is fine.
  EXPECT_NO_THROW(json_util::parse_json(R"({"a": {"k": 1}, "b": {"k": 2}, "c": [{"k": 1}, {"k": 2}]})", "f.json"));
}

TEST(JsonReader, NumbersTooLargeForADoubleNameTheKey) {
  EXPECT_EQ(error_of([] { json_util::parse_json("{\"x\": 1,\n \"duration\": 1e400}", "f.json"); }),
            "f.json: key duration: number 1e400 is too large (expected a finite number, at most about 1.8e308 in magnitude)");
  EXPECT_EQ(error_of([] { json_util::parse_json(R"({"v": [1, 2, -1e999]})", "f.json"); }),
            "f.json: key v[2]: number -1e999 is too large (expected a finite number, at most about 1.8e308 in magnitude)");
}

TEST(JsonReader, MalformedJsonNamesTheLineAndDeepNestingIsRefused) {
  EXPECT_EQ(error_of([] { json_util::parse_json("{\"a\": 1,\n\n \"b\": }", "f.json"); }).rfind("f.json:3: malformed JSON: parse error", 0),
            0u);
  const std::string deep = std::string(100, '[') + std::string(100, ']');
  EXPECT_EQ(error_of([&] { json_util::parse_json(deep, "f.json"); }),
            "f.json: key [0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0]"
            "[0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0]"
            ": arrays and objects are nested deeper than 64 levels");
}

TEST(JsonReader, IntegersBeyondLongAreNotIntegers) {
  EXPECT_EQ(json_util::integer_value(nlohmann::json::parse("9223372036854775807")), LONG_MAX);
  EXPECT_FALSE(json_util::integer_value(nlohmann::json::parse("9223372036854775808")));
  EXPECT_FALSE(json_util::integer_value(nlohmann::json::parse("1.0")));
  EXPECT_EQ(json_util::integer_value(nlohmann::json::parse("-3")), -3);
}

TEST(SceneReader, IntegersAreCheckedBeforeNarrowing) {
  EXPECT_EQ(scene_error(scene(R"("mesh": {"grid": {"size": [1, 1], "vertices": [4294967307, 11]}})")),
            "s.json: key cloth.mesh.grid.vertices: need at least 2 per side and at most 4000000 in all, got "
            "[4294967307,11] (array)");
  EXPECT_EQ(scene_error(scene(R"("mesh": {"grid": {"size": [1, 1], "vertices": [3, 3]}}, "pins": {"vertices": [4294967296]})")),
            "s.json: key cloth.pins.vertices: expected vertex indices, integers in [0, 2147483647], got 4294967296 (number)");
  EXPECT_EQ(scene_error(scene(R"("mesh": {"grid": {"size": [1, 1], "vertices": [3, 3]}}, "pins": {"grid": [[4294967296, 0]]})")),
            "s.json: key cloth.pins.grid: node [4294967296,0] is outside the 3 x 3 grid");
  EXPECT_EQ(scene_error(R"({"weft_scene": 18446744073709551615})"),
            "s.json: key weft_scene: expected an integer, got 18446744073709551615 (number)");
}

TEST(SceneReader, DuplicateKeysAndHugeNumbersAreRefused) {
  EXPECT_EQ(scene_error(scene(R"("mesh": {"grid": {"size": [1, 1], "vertices": [3, 3]}}, "mesh": {})")),
            "s.json: key cloth.mesh: duplicate key (a key may appear only once in an object)");
  EXPECT_EQ(scene_error(R"({"weft_scene": 1, "duration": 1e400})"),
            "s.json: key duration: number 1e400 is too large (expected a finite number, at most about 1.8e308 in magnitude)");
}

TEST(SceneReader, PhysicallyAbsurdMagnitudesAreRefused) {
  EXPECT_EQ(scene_error(scene(R"("mesh": {"grid": {"size": [1, 1], "vertices": [3, 3]}})", R"("gravity": [0, -1e200, 0], )")),
            "s.json: key gravity: value [0,-1e+200,0] (array) is out of range: each component must be within "
            "[-1000.0, 1000.0] m/s^2");
  EXPECT_EQ(scene_error(scene(R"("mesh": {"grid": {"size": [1, 1], "vertices": [3, 3]}}, "initial_velocity": [1e308, 0, 0])")),
            "s.json: key cloth.initial_velocity: value [1e+308,0,0] (array) is out of range: each component must be "
            "within [-1000.0, 1000.0] m/s");
  EXPECT_EQ(scene_error(scene(R"("mesh": {"grid": {"size": [1, 1], "vertices": [3, 3]}}, "placement": {"translation": [0, 1e308, 0]})")),
            "s.json: key cloth.placement.translation: value [0,1e+308,0] (array) is out of range: each component must "
            "be within [-10000.0, 10000.0] m");
  EXPECT_EQ(scene_error(scene(R"("mesh": {"grid": {"size": [1, 1], "vertices": [3, 3]}}, "placement": {"rotation_deg": [1e300, 0, 0]})")),
            "s.json: key cloth.placement.rotation_deg: value [1e+300,0,0] (array) is out of range: each component must "
            "be within [-3600.0, 3600.0] degrees");
  EXPECT_EQ(scene_error(scene(R"("mesh": {"grid": {"size": [1, 1], "vertices": [3, 3]}}, "material": {"surface_density": 1e6})")),
            "s.json: key cloth.material: field surface_density: value 1000000 kg/m2 is out of range (0, 100] kg/m2");
  // At the bounds is fine.
  EXPECT_EQ(scene_error(scene(R"("mesh": {"grid": {"size": [1, 1], "vertices": [3, 3]}}, "initial_velocity": [1000, 0, -1000])",
                              R"("gravity": [0, -1000, 0], )")),
            "(no error)");
}

TEST(SceneReader, RunsThatCannotFitInMemoryAreRefusedWithTheEstimate) {
  const double estimate = estimated_run_bytes(1'000'000'000);
  EXPECT_GT(estimate, kMaxRunBytes);
  const std::string e = error_of([] { check_memory_estimate(1'000'000'000, "m.obj: the mesh"); });
  char expected[128];
  std::snprintf(expected, sizeof expected, "needs about %.1f GB to simulate", estimate / 1e9);
  EXPECT_EQ(e.rfind("m.obj: the mesh (1000000000 vertices) " + std::string(expected), 0), 0u) << e;
  // More vertices never need less memory.
  EXPECT_LT(estimated_run_bytes(1000), estimated_run_bytes(2000));
  EXPECT_NO_THROW(check_memory_estimate(121, "small"));
}

TEST(SceneReader, AGarmentNeedsABodyInItsBindPoseAndKnownBodyParts) {
  const std::string shirt = std::string(WEFT_SOURCE_DIR) + "/data/patterns/garmentcode/shirt_mean_specification.json";
  const std::string cloth = R"("mesh": {"pattern": {"file": ")" + shirt + R"("}})";
  const std::string body = R"("colliders": [{"type": "body", "bind_pose_hold": 0.5}], )";
  const std::string walking = R"("colliders": [{"type": "body"}], )";
  EXPECT_EQ(error_of([&] { parse_scene_text(scene(cloth), "s.json", "."); }),
            "s.json: key cloth.mesh.pattern: a garment is placed and sewn on the body; the scene has no collider of type body");
  EXPECT_EQ(error_of([&] { parse_scene_text(scene(cloth, walking), "s.json", "."); }),
            "s.json: key cloth.mesh.pattern: the garment is sewn on the body in its bind pose, so the body must start in "
            "it: give its collider a bind_pose_hold or blend above 0");
  EXPECT_EQ(error_of([&] { parse_scene_text(scene(cloth, body), "s.json", "."); }), "(no error)");
  const std::string tail = R"("mesh": {"pattern": {"file": ")" + shirt + R"(", "panels": {"left_sleeve_f": {"part": "tail"}}}})";
  EXPECT_NE(error_of([&] { parse_scene_text(scene(tail, body), "s.json", "."); }).find("unknown body part \"tail\""),
            std::string::npos);
  EXPECT_EQ(error_of([&] {
              parse_scene_text(scene(R"("mesh": {"pattern": {"file": "none.json"}})", body), "s.json", ".");
            }),
            "s.json: key cloth.mesh.pattern.file: pattern file './none.json' does not exist");
}

TEST(SceneReader, GarmentPanelsTakeAMaterialAndAGrain) {
  const std::string shirt = std::string(WEFT_SOURCE_DIR) + "/data/patterns/garmentcode/shirt_mean_specification.json";
  const std::string body = R"("colliders": [{"type": "body", "bind_pose_hold": 0.5}], )";
  const auto cloth = [&](const std::string& panel) {
    return R"("mesh": {"pattern": {"file": ")" + shirt + R"(", "panels": {"left_sleeve_f": )" + panel + "}}}";
  };
  const Scene s = parse_scene_text(
      scene(cloth(R"({"material": "denim", "grain_deg": 45, "shift": 0.01})") +
                R"(, "material": {"preset": "silk"})",
            body),
      "s.json", ".");
  ASSERT_TRUE(s.cloth.garment);
  ASSERT_EQ(s.cloth.garment->panel_materials.count("left_sleeve_f"), 1u);
  EXPECT_TRUE(same_parameters(s.cloth.garment->panel_materials.at("left_sleeve_f"), material_preset("denim")));
  EXPECT_EQ(s.cloth.garment->panel_materials.size(), 1u);
  EXPECT_EQ(s.cloth.garment->panel_grain_deg.at("left_sleeve_f"), 45);
  EXPECT_TRUE(same_parameters(s.cloth.material, material_preset("silk")));
  // An inline material is parsed like cloth.material.
  const Scene inline_material =
      parse_scene_text(scene(cloth(R"({"material": {"preset": "wool", "surface_density": 0.4}})"), body), "s.json", ".");
  EXPECT_EQ(inline_material.cloth.garment->panel_materials.at("left_sleeve_f").surface_density_kg_m2, 0.4);

  // Bad ones name the key and the value.
  EXPECT_EQ(error_of([&] { parse_scene_text(scene(cloth(R"({"material": "velvet"})"), body), "s.json", "."); })
                .rfind("s.json: key cloth.mesh.pattern.panels.left_sleeve_f.material: unknown material preset \"velvet\"", 0),
            0u);
  EXPECT_EQ(error_of([&] {
              parse_scene_text(scene(cloth(R"({"material": {"surface_density": 1e6}})"), body), "s.json", ".");
            }),
            "s.json: key cloth.mesh.pattern.panels.left_sleeve_f.material: field surface_density: value 1000000 kg/m2 is "
            "out of range (0, 100] kg/m2");
  EXPECT_NE(error_of([&] { parse_scene_text(scene(cloth(R"({"grain_deg": 1000})"), body), "s.json", "."); })
                .find("s.json: key cloth.mesh.pattern.panels.left_sleeve_f.grain_deg"),
            std::string::npos);
  EXPECT_NE(error_of([&] { parse_scene_text(scene(cloth(R"({"grain": 10})"), body), "s.json", "."); })
                .find("s.json: key cloth.mesh.pattern.panels.left_sleeve_f"),
            std::string::npos);
}
