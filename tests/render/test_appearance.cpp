// The look `weft render` shares with the viewer (include/weft/render/appearance.hpp): the ramps' shape
// (lightness monotonic away from their light end), the strain field and its percentile scale,
// and the same colours, strain and scale from the viewer's JavaScript (run in node on the same
// inputs) as from weft's C++.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "weft/render/appearance.hpp"

namespace weft::render {
namespace {

namespace fs = std::filesystem;

double luminance(const Colour& c) { return 0.2126 * c.x() + 0.7152 * c.y() + 0.0722 * c.z(); }

TEST(Appearance, SequentialRampDarkensFromItsStartToItsEnd) {
  for (int k = 0; k < 100; ++k) EXPECT_GT(luminance(sequential_colour(k / 100.0)), luminance(sequential_colour((k + 1) / 100.0))) << k;
  EXPECT_TRUE(sequential_colour(2).isApprox(sequential_colour(1)));    // clamped
  EXPECT_TRUE(sequential_colour(-1).isApprox(sequential_colour(0)));
  EXPECT_GT(sequential_colour(1).x(), 3 * sequential_colour(1).z());  // ends in red
}

TEST(Appearance, DivergingRampIsLightestAtZeroAndDarkensBothWays) {
  for (int k = 0; k < 100; ++k) {
    EXPECT_GT(luminance(diverging_colour(k / 100.0)), luminance(diverging_colour((k + 1) / 100.0))) << k;
    EXPECT_GT(luminance(diverging_colour(-k / 100.0)), luminance(diverging_colour(-(k + 1) / 100.0))) << k;
  }
  EXPECT_GT(diverging_colour(1).x(), 3 * diverging_colour(1).z());    // stretched: red
  EXPECT_GT(diverging_colour(-1).z(), 3 * diverging_colour(-1).x());  // compressed: blue
  EXPECT_TRUE(diverging_colour(std::nan("")).isApprox(diverging_colour(0)));
}

// A 4 x 3 grid of pattern points (metres), 12 triangles.
struct Sheet {
  std::vector<double> pattern;  // 2 per vertex
  std::vector<std::array<int, 3>> triangles;
};
Sheet sheet() {
  Sheet s;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 4; ++i) s.pattern.insert(s.pattern.end(), {0.1 * i, 0.08 * j});
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 3; ++i) {
      const int a = 4 * j + i;
      s.triangles.push_back({a, a + 1, a + 5});
      s.triangles.push_back({a, a + 5, a + 4});
    }
  return s;
}
std::vector<double> corners_of(const Sheet& s, double scale) {
  std::vector<double> uv;
  for (const auto& t : s.triangles)
    for (int k : t) uv.insert(uv.end(), {s.pattern[2 * k] * scale, s.pattern[2 * k + 1] * scale});
  return uv;
}

TEST(Appearance, VertexStrainIsZeroAtRestAndTheStretchOfAUniformStretch) {
  const Sheet s = sheet();
  const Eigen::AngleAxisd turn(0.9, Vec3(1, -2, 0.5).normalized());
  auto placed = [&](double sx, double sy) {
    std::vector<double> xyz;
    for (size_t i = 0; i < s.pattern.size() / 2; ++i) {
      const Vec3 p = turn * Vec3(sx * s.pattern[2 * i], sy * s.pattern[2 * i + 1], 0);
      xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
    }
    return xyz;
  };
  // Texture coordinates in units of 0.25 m: times uv_scale 0.25 they are the pattern.
  const std::vector<double> uv = corners_of(s, 4.0);
  for (double v : vertex_strain(placed(1, 1), s.triangles, uv, 0.25)) EXPECT_NEAR(v, 0, 1e-12);
  for (double v : vertex_strain(placed(1.1, 0.95), s.triangles, uv, 0.25)) EXPECT_NEAR(v, 0.1, 1e-12);
  // Read with the wrong scale (1), the pattern is 4 times the cloth: compressed to a quarter.
  for (double v : vertex_strain(placed(1, 1), s.triangles, uv, 1.0)) EXPECT_NEAR(v, -0.75, 1e-12);
}

TEST(Appearance, StrainScaleIsAPercentileThatOneOutlierDoesNotMove) {
  std::vector<double> values(1000);
  for (size_t k = 0; k < values.size(); ++k) values[k] = (k % 2 ? -1.0 : 1.0) * 0.001 * static_cast<double>(k % 10);
  // A tenth of the values have |value| 0.009, the largest: the 99th percentile is that.
  const double scale = strain_scale(values);
  EXPECT_EQ(scale, 0.001 * 9);
  values[17] = 50;  // one far outlier
  EXPECT_EQ(strain_scale(values), scale);
  EXPECT_EQ(strain_scale({}), 0);
}

TEST(Appearance, TheScaleOfValuesInPartsIsTheScaleOfTheWhole) {
  // More values than the scale samples, so that it takes every k-th, across the parts.
  std::vector<double> all;
  StrainScaleSampler sampler(1234567);
  for (int part = 0; part < 7; ++part) {
    std::vector<double> values(part == 6 ? 1234567 - 6 * 176367 : 176367);
    for (size_t k = 0; k < values.size(); ++k) values[k] = std::sin(0.001 * static_cast<double>(all.size() + k)) * (1 + part);
    all.insert(all.end(), values.begin(), values.end());
    sampler.add(values);
  }
  ASSERT_EQ(all.size(), 1234567u);
  EXPECT_EQ(sampler.scale(), strain_scale(all));
  EXPECT_GT(sampler.scale(), 6);  // the last part's values reach 7
}

// Runs `command`, returns its standard output, or "" with `ok` false when it fails.
std::string output_of(const std::string& command, bool& ok) {
  const fs::path out = fs::temp_directory_path() / ("weft_appearance_" + std::to_string(::getpid()) + ".txt");
  const int status = std::system((command + " > '" + out.string() + "'").c_str());
  std::ifstream in(out);
  std::stringstream s;
  s << in.rdbuf();
  fs::remove(out);
  ok = WIFEXITED(status) && WEXITSTATUS(status) == 0;
  return s.str();
}

void expect_colour(const nlohmann::json& js, const Colour& cpp, const std::string& what) {
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(js.at(c).get<double>(), cpp[c], 1e-6) << what << " channel " << c;
}

TEST(Appearance, TheViewersJavaScriptGivesTheSameColoursStrainAndScale) {
#ifndef WEFT_NODE_EXE
  GTEST_SKIP() << "node was not found when weft was configured";
#else
  nlohmann::json request;
  std::vector<double> fractions, signed_fractions;
  for (int k = -10; k <= 110; ++k) fractions.push_back(k / 100.0 + 0.0013);
  for (int k = -110; k <= 110; ++k) signed_fractions.push_back(k / 100.0 + 0.0017);
  request["fractions"] = fractions;
  request["signed_fractions"] = signed_fractions;
  // A sheet deformed unevenly, per-vertex texture coordinates in units of 0.37 m.
  const Sheet s = sheet();
  const double uv_scale = 0.37;
  std::vector<double> xyz, texcoords;
  std::vector<int> indices;
  for (size_t i = 0; i < s.pattern.size() / 2; ++i) {
    const double u = s.pattern[2 * i], v = s.pattern[2 * i + 1];
    xyz.insert(xyz.end(), {u * (1 + 0.3 * v), v + 0.2 * u * u, 0.05 * std::sin(7 * u)});
    texcoords.insert(texcoords.end(), {u / uv_scale, v / uv_scale});
  }
  for (const auto& t : s.triangles) indices.insert(indices.end(), t.begin(), t.end());
  request["positions"] = xyz;
  request["texcoords"] = texcoords;
  request["indices"] = indices;
  request["uv_scale"] = uv_scale;
  std::vector<double> values;
  for (int k = 0; k < 997; ++k) values.push_back(std::sin(0.37 * k) * (k % 13) * 0.01);
  request["values"] = values;
  // More than the scale's max_samples, so that it samples with a stride.
  const int generated_count = 450001;
  request["generated_values"] = generated_count;
  const fs::path request_path = fs::temp_directory_path() / ("weft_appearance_request_" + std::to_string(::getpid()) + ".json");
  std::ofstream(request_path) << request.dump();
  bool ok = false;
  const std::string text = output_of(std::string("'") + WEFT_NODE_EXE + "' '" + WEFT_SOURCE_DIR +
                                         "/viewer/test/appearance_dump.mjs' '" + request_path.string() + "'",
                                     ok);
  fs::remove(request_path);
  ASSERT_TRUE(ok) << text;
  const nlohmann::json js = nlohmann::json::parse(text);

  ASSERT_EQ(js.at("sequential").size(), fractions.size());
  for (size_t k = 0; k < fractions.size(); ++k)
    expect_colour(js["sequential"][k], sequential_colour(fractions[k]), "sequential " + std::to_string(fractions[k]));
  ASSERT_EQ(js.at("diverging").size(), signed_fractions.size());
  for (size_t k = 0; k < signed_fractions.size(); ++k)
    expect_colour(js["diverging"][k], diverging_colour(signed_fractions[k]), "diverging " + std::to_string(signed_fractions[k]));
  expect_colour(js.at("cloth_front"), cloth_colour(), "cloth front");
  expect_colour(js.at("cloth_back"), cloth_back_colour(), "cloth back");
  expect_colour(js.at("collider"), collider_colour(), "collider");

  std::vector<double> corner_uv;
  for (const auto& t : s.triangles)
    for (int k : t) corner_uv.insert(corner_uv.end(), {texcoords[2 * k], texcoords[2 * k + 1]});
  const std::vector<double> strain = vertex_strain(xyz, s.triangles, corner_uv, uv_scale);
  ASSERT_EQ(js.at("strain").size(), strain.size());
  double largest = 0;
  for (size_t i = 0; i < strain.size(); ++i) {
    EXPECT_NEAR(js["strain"][i].get<double>(), strain[i], 1e-12) << "vertex " << i;
    largest = std::max(largest, std::abs(strain[i]));
  }
  EXPECT_GT(largest, 0.01);  // the sheet is strained: the comparison means something

  EXPECT_EQ(js.at("scale").get<double>(), strain_scale(values));
  std::vector<double> generated(generated_count);
  for (int k = 0; k < generated_count; ++k) generated[k] = static_cast<double>((static_cast<long>(k) * 7919) % 10007) / 10007 - 0.5;
  EXPECT_EQ(js.at("generated_scale").get<double>(), strain_scale(generated));
#endif
}

}  // namespace
}  // namespace weft::render
