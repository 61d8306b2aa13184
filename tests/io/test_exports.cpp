// The export writers' pieces: area-weighted normals, the format list, the glb of a mesh
// that does not move, and the USD stage's time-sampled points read back.
#include <gtest/gtest.h>

#include <cstring>
#include <map>
#include <regex>
#include <nlohmann/json.hpp>
#include <sstream>

#include "weft/exports.hpp"
#include "weft/error.hpp"

namespace {

TEST(VertexNormals, WeightFacesByArea) {
  // Vertex 0 is shared by a triangle of area 2 in the z = 0 plane (normal +z) and one of area
  // 1/2 in the x = 0 plane (normal +x): its normal is (1/2, 0, 2) normalised.
  const double x[] = {0, 0, 0, 2, 0, 0, 0, 2, 0, 0, 1, 0, 0, 0, 1};
  const std::vector<std::array<int, 3>> triangles = {{0, 1, 2}, {0, 3, 4}};
  const auto n = weft::vertex_normals(x, 5, triangles);
  const double len = std::hypot(0.5, 2.0);
  EXPECT_NEAR(n[0], 0.5 / len, 1e-7);
  EXPECT_NEAR(n[1], 0, 1e-7);
  EXPECT_NEAR(n[2], 2 / len, 1e-7);
  // Vertices of one face take its normal.
  EXPECT_NEAR(n[3 * 1 + 2], 1, 1e-7);
  EXPECT_NEAR(n[3 * 3 + 0], 1, 1e-7);
}

TEST(VertexNormals, AVertexWithoutAreaGetsAUnitNormal) {
  const double x[] = {0, 0, 0, 1, 0, 0, 2, 0, 0, 5, 5, 5};
  const auto n = weft::vertex_normals(x, 4, {{0, 1, 2}});
  for (int v = 0; v < 4; ++v) EXPECT_NEAR(std::hypot(n[3 * v], n[3 * v + 1], n[3 * v + 2]), 1, 1e-7) << v;
}

TEST(OutputFormats, ListsAreSplitCheckedAndKeptInOrderWithoutRepeats) {
  EXPECT_EQ(weft::split_format_list("obj, glb,pc2"), (std::vector<std::string>{"obj", "glb", "pc2"}));
  EXPECT_EQ(weft::checked_output_formats({"glb", "obj", "glb"}, "w"), (std::vector<std::string>{"glb", "obj"}));
  try {
    weft::checked_output_formats(weft::split_format_list("obj,"), "here");
    FAIL() << "an empty name was accepted";
  } catch (const weft::InputError& e) {
    EXPECT_STREQ(e.what(), "here: unknown output format '' (expected obj, ply, glb, pc2, usda)");
  }
  EXPECT_THROW(weft::checked_output_formats({}, "here"), weft::InputError);
}

TEST(Glb, AMeshThatDoesNotMoveHasNoMorphTargetsAndAFrameCountMismatchIsRefused) {
  weft::AnimatedMesh m;
  m.name = "still";
  m.triangles = {{0, 1, 2}};
  const double x[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  m.add_frame(x, 3);
  m.add_frame(x, 3);
  std::ostringstream out;
  weft::write_glb(out, {&m}, {0.0, 0.5});
  const std::string bytes = out.str();
  ASSERT_GT(bytes.size(), 20u);
  uint32_t json_length = 0;
  std::memcpy(&json_length, bytes.data() + 12, 4);
  const auto j = nlohmann::json::parse(bytes.substr(20, json_length));
  EXPECT_FALSE(j["meshes"][0]["primitives"][0].contains("targets"));
  EXPECT_FALSE(j.contains("animations"));
  EXPECT_EQ(j["accessors"][j["meshes"][0]["primitives"][0]["attributes"]["POSITION"].get<int>()]["count"], 3);
  std::ostringstream ignored;
  EXPECT_THROW(weft::write_glb(ignored, {&m}, {0.0}), std::runtime_error);
}

// The point arrays of a .usda file as written by write_usda: for each Mesh prim, its
// time-sampled points by time code (a single entry at -1 for points without samples), parsed
// from the text with the USD grammar's tuples "(x, y, z)".
struct UsdaMesh {
  std::map<int, std::vector<float>> points;
  std::vector<int> indices;
};
std::vector<float> parse_tuples(const std::string& text) {
  std::vector<float> v;
  static const std::regex number(R"([-+0-9.eE]+)");
  for (auto it = std::sregex_iterator(text.begin(), text.end(), number); it != std::sregex_iterator(); ++it)
    v.push_back(std::stof(it->str()));
  return v;
}
std::map<std::string, UsdaMesh> read_usda_meshes(const std::string& text) {
  std::map<std::string, UsdaMesh> meshes;
  static const std::regex prim(R"re(def Mesh "(\w+)")re");
  std::vector<std::pair<std::string, size_t>> starts;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), prim); it != std::sregex_iterator(); ++it)
    starts.emplace_back((*it)[1].str(), static_cast<size_t>(it->position()));
  for (size_t k = 0; k < starts.size(); ++k) {
    const std::string body = text.substr(starts[k].second, (k + 1 < starts.size() ? starts[k + 1].second : text.size()) - starts[k].second);
    UsdaMesh& m = meshes[starts[k].first];
    const size_t idx = body.find("int[] faceVertexIndices = [");
    if (idx != std::string::npos) {
      const size_t open = body.find("= [", idx) + 2, close = body.find(']', open);
      for (float f : parse_tuples(body.substr(open + 1, close - open - 1))) m.indices.push_back(static_cast<int>(f));
    }
    const size_t samples = body.find("point3f[] points.timeSamples = {");
    if (samples != std::string::npos) {
      static const std::regex sample(R"((\d+): \[([^\]]*)\])");
      const std::string block = body.substr(samples, body.find("\n        }", samples) - samples);
      for (auto it = std::sregex_iterator(block.begin(), block.end(), sample); it != std::sregex_iterator(); ++it)
        m.points[std::stoi((*it)[1].str())] = parse_tuples((*it)[2].str());
    } else if (const size_t still = body.find("point3f[] points = ["); still != std::string::npos) {
      const size_t open = body.find("= [", still) + 2, close = body.find(']', open);
      m.points[-1] = parse_tuples(body.substr(open + 1, close - open - 1));
    }
  }
  return meshes;
}

TEST(Usda, ReadBackGivesEveryFramesPointsAndTheTriangles) {
  weft::AnimatedMesh cloth, still;
  cloth.name = "cloth";
  cloth.triangles = {{0, 1, 2}, {0, 2, 3}};
  cloth.texcoords = {0, 0, 1, 0, 1, 1, 0, 1};
  still.name = "collider0";
  still.triangles = {{0, 2, 1}};
  std::vector<double> times;
  for (int f = 0; f < 4; ++f) {
    // Coordinates with many digits, so that a float written short would not read back the same.
    const double x[] = {0.1 * f, 1.0 / 3, -2e-7 * f, 1 + 0.01 * f, std::sqrt(2.0), 0.3, 1.234567891, 1 + f / 7.0, 0, 0, 1, -5e3};
    cloth.add_frame(x, 4);
    const double y[] = {0, 0, 0, 1, 0, 0, 0, 1, 0.125};
    still.add_frame(y, 3);
    times.push_back(0.04 * f);
  }
  std::ostringstream out;
  weft::write_usda(out, {&cloth, &still}, times);
  const std::string text = out.str();
  EXPECT_EQ(text.rfind("#usda 1.0\n", 0), 0u);
  EXPECT_NE(text.find("timeCodesPerSecond = 25"), std::string::npos) << text.substr(0, 300);
  EXPECT_NE(text.find("endTimeCode = 3"), std::string::npos);
  const auto meshes = read_usda_meshes(text);
  ASSERT_EQ(meshes.size(), 2u);
  const UsdaMesh& c = meshes.at("cloth");
  EXPECT_EQ(c.indices, (std::vector<int>{0, 1, 2, 0, 2, 3}));
  ASSERT_EQ(c.points.size(), 4u);
  for (int f = 0; f < 4; ++f) {
    ASSERT_TRUE(c.points.count(f)) << f;
    const std::vector<float> expected(cloth.positions.begin() + 12 * f, cloth.positions.begin() + 12 * (f + 1));
    EXPECT_EQ(c.points.at(f), expected) << "frame " << f;  // the same floats, bit for bit
  }
  // A mesh that does not move has its points once, without time samples.
  const UsdaMesh& s = meshes.at("collider0");
  EXPECT_EQ(s.indices, (std::vector<int>{0, 2, 1}));
  ASSERT_EQ(s.points.size(), 1u);
  EXPECT_EQ(s.points.at(-1), std::vector<float>(still.positions.begin(), still.positions.begin() + 9));
  EXPECT_NE(text.find("texCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)]"), std::string::npos);
  // A mesh whose frame count is not the times' is refused.
  EXPECT_THROW(weft::write_usda(out, {&cloth}, {0.0, 0.5}), std::runtime_error);
}

}  // namespace
