// `weft run --format`: OBJ frames with texture coordinates and normals, the glb animation
// (checked by the Khronos glTF validator when node is installed) and the PC2 point cache,
// against the OBJ frames of the same run; the format choice from the scene and the command
// line, and its refusals.
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <nlohmann/json.hpp>
#include <sstream>

#include "io/obj_file.hpp"
#include "support/command.hpp"

using weft::test::CommandTest;
using weft::test::read_binary;
using weft::test::read_text;
namespace fs = std::filesystem;

namespace {

// A 0.2 m square grid of 5 x 5 vertices hung from two corners, 0.1 s at 0.02 s per frame
// (frames 0 to 5); a spinning sphere below it and a static floor. `output` is added as is.
std::string scene(const std::string& output = "") {
  return R"({"weft_scene": 1, "duration": 0.1, "frame_interval": 0.02,
  "integrator": {"method": "implicit-midpoint", "dt": 0.01},
  "cloth": {"mesh": {"grid": {"size": [0.2, 0.2], "vertices": [5, 5]}},
            "placement": {"rotation_deg": [-90, 0, 0], "translation": [0, 1, 0]},
            "material": {"surface_density": 0.15, "weft": 100, "warp": 100, "shear": 10, "bending_rigidity": 1e-4},
            "pins": {"grid": [[0, 0], [-1, 0]]}},
  "colliders": [
    {"type": "sphere", "centre": [0, 0.3, 0], "radius": 0.1, "motion": {"angular_velocity_deg": [0, 90, 0], "centre": [0, 0.3, 0]}},
    {"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]}
  ])" + (output.empty() ? "" : ",\n  " + output) + "}";
}

constexpr int kVertices = 25, kFrames = 6;

uint32_t u32_at(const std::string& bytes, size_t offset) {
  uint32_t v = 0;
  std::memcpy(&v, bytes.data() + offset, 4);
  return v;
}

float f32_at(const std::string& bytes, size_t offset) {
  float v = 0;
  std::memcpy(&v, bytes.data() + offset, 4);
  return v;
}

// The vertex positions of a frame written by weft run (3 per vertex).
std::vector<double> frame_positions(const fs::path& out, int frame) {
  char name[32];
  std::snprintf(name, sizeof name, "frame_%05d.obj", frame);
  return weft::read_obj_file((out / "frames" / name).string()).positions;
}

// The `vn` lines of an OBJ file, 3 numbers each.
std::vector<double> obj_normals(const fs::path& path) {
  std::istringstream in(read_text(path));
  std::vector<double> normals;
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("vn ", 0) == 0) {
      std::istringstream ls(line.substr(3));
      double x, y, z;
      ls >> x >> y >> z;
      normals.insert(normals.end(), {x, y, z});
    }
  return normals;
}

// A float written from a double x is within half a unit in its last place of x (2^-24 |x|);
// the OBJ frames hold x to 9 decimals (within 5e-10 m).
void expect_float_of(double expected, float got, const std::string& what) {
  EXPECT_LE(std::abs(static_cast<double>(got) - expected), std::ldexp(std::abs(expected), -23) + 1e-9) << what;
}

struct Glb {
  nlohmann::json json;
  std::string bin;
};

Glb read_glb(const fs::path& path) {
  const std::string bytes = read_binary(path);
  Glb g;
  EXPECT_GE(bytes.size(), 28u);
  if (bytes.size() < 28) return g;
  EXPECT_EQ(u32_at(bytes, 0), 0x46546C67u);  // "glTF"
  EXPECT_EQ(u32_at(bytes, 4), 2u);
  EXPECT_EQ(u32_at(bytes, 8), bytes.size());
  const uint32_t json_length = u32_at(bytes, 12);
  EXPECT_EQ(u32_at(bytes, 16), 0x4E4F534Au);  // "JSON"
  EXPECT_EQ(json_length % 4, 0u);
  g.json = nlohmann::json::parse(bytes.substr(20, json_length));
  const size_t bin_header = 20 + json_length;
  const uint32_t bin_length = u32_at(bytes, bin_header);
  EXPECT_EQ(u32_at(bytes, bin_header + 4), 0x004E4942u);  // "BIN\0"
  EXPECT_EQ(bin_header + 8 + bin_length, bytes.size());
  g.bin = bytes.substr(bin_header + 8, bin_length);
  return g;
}

// The float at `element`, component `component` of accessor `index`.
float accessor_float(const Glb& g, int index, size_t element, int component, int components) {
  const auto& acc = g.json["accessors"][index];
  const auto& view = g.json["bufferViews"][acc["bufferView"].get<int>()];
  const size_t offset = view.value("byteOffset", 0u) + acc.value("byteOffset", 0u) + 4 * (element * components + component);
  return f32_at(g.bin, offset);
}

}  // namespace

class RunExports : public CommandTest {
 protected:
  fs::path run_with(const std::string& options, const std::string& scene_text = scene()) {
    const auto s = write("scene.json", scene_text);
    const auto out = folder_ / "out";
    const auto r = weft("run '" + s.string() + "' --out '" + out.string() + "' --quiet " + options);
    EXPECT_EQ(r.exit_code, 0) << r.error_output;
    return out;
  }
};

TEST_F(RunExports, ObjFramesCarryPatternTextureCoordinatesAndUnitNormals) {
  const auto out = run_with("--format obj");
  const weft::ObjData first = weft::read_obj_file((out / "frames" / "frame_00000.obj").string());
  ASSERT_EQ(first.vertex_count(), kVertices);
  // A grid's pattern coordinates: vertex (i, j) at (0.05 i, 0.05 j) m.
  ASSERT_EQ(first.texcoords.size(), 2u * kVertices);
  for (int j = 0; j < 5; ++j)
    for (int i = 0; i < 5; ++i) {
      EXPECT_NEAR(first.texcoords[2 * (5 * j + i)], 0.05 * i, 1e-7);
      EXPECT_NEAR(first.texcoords[2 * (5 * j + i) + 1], 0.05 * j, 1e-7);
    }
  for (const auto& t : first.triangles)
    for (const auto& corner : t) EXPECT_EQ(corner.texcoord, corner.vertex);
  // Frame 0 is the flat grid turned -90 degrees about x: its normal (0, 0, 1) becomes (0, 1, 0).
  const auto n0 = obj_normals(out / "frames" / "frame_00000.obj");
  ASSERT_EQ(n0.size(), 3u * kVertices);
  for (int i = 0; i < kVertices; ++i) {
    EXPECT_NEAR(n0[3 * i], 0, 1e-6);
    EXPECT_NEAR(n0[3 * i + 1], 1, 1e-6);
    EXPECT_NEAR(n0[3 * i + 2], 0, 1e-6);
  }
  const auto n5 = obj_normals(out / "frames" / "frame_00005.obj");
  ASSERT_EQ(n5.size(), 3u * kVertices);
  for (int i = 0; i < kVertices; ++i)
    EXPECT_NEAR(std::hypot(n5[3 * i], n5[3 * i + 1], n5[3 * i + 2]), 1, 1e-6);
  // The colliders' frames are written as before, and weft check reads the new frames.
  EXPECT_TRUE(fs::exists(out / "frames" / "collider0_00005.obj"));
  EXPECT_TRUE(fs::exists(out / "frames" / "collider1_00005.obj"));
  const auto check = weft("check '" + out.string() + "'");
  EXPECT_EQ(check.exit_code, 0) << check.error_output;
}

TEST_F(RunExports, Pc2ReadBackGivesEveryFramesPositions) {
  const auto out = run_with("--format obj,pc2");
  const std::string pc2 = read_binary(out / "animation.pc2");
  ASSERT_GE(pc2.size(), 32u);
  EXPECT_EQ(pc2.substr(0, 12), std::string("POINTCACHE2\0", 12));
  EXPECT_EQ(u32_at(pc2, 12), 1u);  // version
  EXPECT_EQ(u32_at(pc2, 16), static_cast<uint32_t>(kVertices));
  EXPECT_EQ(f32_at(pc2, 20), 0.0f);  // start frame
  EXPECT_EQ(f32_at(pc2, 24), 1.0f);  // one sample per frame
  EXPECT_EQ(u32_at(pc2, 28), static_cast<uint32_t>(kFrames));
  ASSERT_EQ(pc2.size(), 32u + 12u * kVertices * kFrames);
  for (int f = 0; f < kFrames; ++f) {
    const auto x = frame_positions(out, f);
    ASSERT_EQ(x.size(), 3u * kVertices);
    for (size_t k = 0; k < x.size(); ++k)
      expect_float_of(x[k], f32_at(pc2, 32 + 4 * (f * x.size() + k)), "frame " + std::to_string(f) + " coordinate " + std::to_string(k));
  }
  // The rest mesh: frame 0's vertices in the cache's order, with texture coordinates.
  const weft::ObjData rest = weft::read_obj_file((out / "animation_rest.obj").string());
  const auto x0 = frame_positions(out, 0);
  ASSERT_EQ(rest.positions.size(), x0.size());
  for (size_t k = 0; k < x0.size(); ++k) expect_float_of(x0[k], static_cast<float>(rest.positions[k]), "rest coordinate");
  EXPECT_EQ(rest.texcoords.size(), 2u * kVertices);
}

TEST_F(RunExports, UsdaHoldsEveryFramesPositionsAsTimeSamples) {
  const auto out = run_with("--format obj,usda");
  const std::string text = read_text(out / "animation.usda");
  EXPECT_EQ(text.rfind("#usda 1.0\n", 0), 0u);
  EXPECT_NE(text.find("def Mesh \"cloth\""), std::string::npos);
  EXPECT_NE(text.find("endTimeCode = " + std::to_string(kFrames - 1) + "\n"), std::string::npos);
  // Each frame's sample: "            F: [(x, y, z), ...]," in the cloth's prim, the first.
  for (int f = 0; f < kFrames; ++f) {
    const std::string key = "\n            " + std::to_string(f) + ": [";
    const size_t at = text.find(key);
    ASSERT_NE(at, std::string::npos) << "frame " << f;
    const std::string sample = text.substr(at + key.size(), text.find(']', at) - at - key.size());
    std::vector<float> read;
    std::string number;
    for (char c : sample + ",") {
      if (c == '(' || c == ' ' || c == '\n') continue;
      if (c == ',' || c == ')') {
        if (!number.empty()) read.push_back(std::stof(number));
        number.clear();
      } else {
        number += c;
      }
    }
    const auto x = frame_positions(out, f);
    ASSERT_EQ(read.size(), x.size()) << "frame " << f;
    for (size_t k = 0; k < x.size(); ++k) expect_float_of(x[k], read[k], "frame " + std::to_string(f) + " coordinate " + std::to_string(k));
  }
}

TEST_F(RunExports, GlbHoldsEveryFrameAsMorphTargetsOfTheFirst) {
  const auto out = run_with("--format obj,glb --damping-ratio 0.05");
  const Glb g = read_glb(out / "animation.glb");
  const auto& j = g.json;
  ASSERT_TRUE(j.contains("meshes"));
  EXPECT_EQ(j["asset"]["version"], "2.0");
  // The cloth, the spinning sphere (animated) and the floor (static).
  ASSERT_EQ(j["meshes"].size(), 3u);
  const auto& cloth = j["meshes"][0]["primitives"][0];
  EXPECT_EQ(j["meshes"][0]["name"], "cloth");
  const int position = cloth["attributes"]["POSITION"];
  EXPECT_EQ(j["accessors"][position]["count"], kVertices);
  for (const char* attribute : {"NORMAL", "TEXCOORD_0", "COLOR_0"})
    EXPECT_TRUE(cloth["attributes"].contains(attribute)) << attribute;
  ASSERT_EQ(cloth["targets"].size(), static_cast<size_t>(kFrames - 1));
  EXPECT_TRUE(j["meshes"][1]["primitives"][0].contains("targets"));
  EXPECT_FALSE(j["meshes"][2]["primitives"][0].contains("targets"));
  // One animation: a keyframe per frame, at the frames' times.
  ASSERT_EQ(j["animations"].size(), 1u);
  const auto& sampler = j["animations"][0]["samplers"][0];
  const int times = sampler["input"];
  ASSERT_EQ(j["accessors"][times]["count"], kFrames);
  for (int f = 0; f < kFrames; ++f) EXPECT_NEAR(accessor_float(g, times, f, 0, 1), 0.02 * f, 1e-6);
  EXPECT_EQ(j["accessors"][sampler["output"].get<int>()]["count"], kFrames * (kFrames - 1));
  // Base plus target f - 1 is frame f, to float precision.
  for (int f = 0; f < kFrames; ++f) {
    const auto x = frame_positions(out, f);
    for (int i = 0; i < kVertices; ++i)
      for (int d = 0; d < 3; ++d) {
        float v = accessor_float(g, position, i, d, 3);
        if (f > 0) v += accessor_float(g, cloth["targets"][f - 1]["POSITION"], i, d, 3);
        EXPECT_NEAR(v, x[3 * i + d], 4e-7) << "frame " << f << " vertex " << i;
      }
  }
}

TEST_F(RunExports, GlbPassesTheKhronosValidator) {
  if (std::system("command -v node > /dev/null 2>&1") != 0)
    GTEST_SKIP() << "node is not installed: the glTF validator (tools/validate) cannot run";
  const fs::path validator = fs::path(WEFT_SOURCE_DIR) / "tools" / "validate";
  ASSERT_TRUE(fs::exists(validator / "node_modules" / "gltf-validator"))
      << "the validator is not installed: run `npm ci --prefix " << validator.string() << "` (make test does)";
  const auto out = run_with("--format glb --damping-ratio 0.05");
  EXPECT_FALSE(fs::exists(out / "frames" / "frame_00000.obj"));
  const auto report_path = folder_ / "report.json";
  const std::string command = "node '" + (validator / "validate.js").string() + "' '" + (out / "animation.glb").string() +
                              "' > '" + report_path.string() + "'";
  const int status = std::system(command.c_str());
  const auto report = nlohmann::json::parse(read_text(report_path));
  EXPECT_EQ(report["errors"], 0) << report.dump(2);
  EXPECT_EQ(report["warnings"], 0) << report.dump(2);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << report.dump(2);
}

TEST_F(RunExports, TheSceneChoosesFormatsAndFrameFormatTakesThePlaceOfItsFrames) {
  const std::string with_output = scene(R"("output": {"formats": ["pc2", "obj"]})");
  auto out = run_with("", with_output);
  EXPECT_TRUE(fs::exists(out / "animation.pc2"));
  EXPECT_TRUE(fs::exists(out / "frames" / "frame_00005.obj"));
  EXPECT_EQ(nlohmann::json::parse(read_text(out / "summary.json"))["formats"], nlohmann::json({"pc2", "obj"}));
  out = run_with("--frame-format ply", with_output);
  EXPECT_TRUE(fs::exists(out / "frames" / "frame_00005.ply"));
  EXPECT_FALSE(fs::exists(out / "frames" / "frame_00005.obj"));
  EXPECT_TRUE(fs::exists(out / "animation.pc2"));
  // --format replaces the scene's list; a later run leaves no file of an earlier one.
  out = run_with("--format glb", with_output);
  EXPECT_TRUE(fs::exists(out / "animation.glb"));
  EXPECT_FALSE(fs::exists(out / "animation.pc2"));
  EXPECT_FALSE(fs::exists(out / "frames" / "frame_00005.ply"));
  // A scene without an output section still writes OBJ frames only.
  out = run_with("");
  EXPECT_TRUE(fs::exists(out / "frames" / "frame_00005.obj"));
  EXPECT_FALSE(fs::exists(out / "animation.glb"));
}

TEST_F(RunExports, UnknownOrConflictingFormatsExitTwoNamingTheValue) {
  const auto s = write("scene.json", scene());
  const auto out = folder_ / "out";
  auto r = weft("run '" + s.string() + "' --out '" + out.string() + "' --format obj,fbx");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("command line: --format: unknown output format 'fbx' (expected obj, ply, glb, pc2, usda)"),
            std::string::npos) << r.error_output;
  EXPECT_FALSE(fs::exists(out));
  r = weft("run '" + s.string() + "' --out '" + out.string() + "' --format obj,ply");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("obj and ply cannot both be chosen"), std::string::npos) << r.error_output;
  r = weft("run '" + s.string() + "' --out '" + out.string() + "' --format glb --frame-format ply");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("--frame-format cannot be combined with --format"), std::string::npos) << r.error_output;
  const auto bad = write("bad.json", scene(R"("output": {"formats": ["obj", "usd"]})"));
  r = weft("run '" + bad.string() + "' --out '" + out.string() + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find(bad.string() + ": key output.formats: unknown output format 'usd' (expected obj, ply, glb, pc2, usda)"),
            std::string::npos) << r.error_output;
  EXPECT_FALSE(fs::exists(out));
}
