// The export writers' pieces: area-weighted normals, the format list, and the glb of a mesh
// that does not move.
#include <gtest/gtest.h>

#include <cstring>
#include <nlohmann/json.hpp>
#include <sstream>

#include "io/exports.hpp"
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
    EXPECT_STREQ(e.what(), "here: unknown output format '' (expected obj, ply, glb, pc2)");
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

}  // namespace
