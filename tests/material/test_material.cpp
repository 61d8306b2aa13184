// Material files: units, references (preset, file), validation messages and shipped presets.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <nlohmann/json.hpp>
#include <string>

#include <unistd.h>

#include "weft/error.hpp"
#include "weft/material.hpp"

namespace weft {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

/// A fresh folder for the files of one test, removed at the end of the test.
struct ScratchDir {
  explicit ScratchDir(const std::string& name)
      : dir(fs::temp_directory_path() /
            ("weft_material_test_" + std::to_string(::getpid()) + "_" + name)) {
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  const fs::path dir;
};

std::string write(const fs::path& path, const json& j) {
  std::ofstream(path) << j.dump(2);
  return path.string();
}

std::string write_text(const fs::path& path, const std::string& text) {
  std::ofstream(path) << text;
  return path.string();
}

/// The message of the InputError thrown by f, or "" if none was thrown.
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

json table_material(const std::string& stress_unit, double stress_scale) {
  const std::vector<double> strain{0.0, 0.01, 0.02, 0.04, 0.06};
  std::vector<double> stress{0.0, 4.0, 10.0, 40.0, 120.0};
  for (double& s : stress) s *= stress_scale;
  return {{"weft_material", 1},
          {"source", "Estimated, not measured: a test table"},
          {"weft", {{"strain", strain}, {"stress", stress}, {"unit", stress_unit}}},
          {"shear", {{"strain", {0.0, 0.05, 0.1}}, {"stress", {0.0, stress[1], stress[3]}},
                     {"unit", stress_unit}}},
          {"warp", {{"linear", 300.0 * stress_scale}, {"unit", stress_unit}}}};
}

TEST(MaterialUnits, KawabataStressEqualsSiTimesFactor) {
  const ScratchDir scratch("units_stress");
  const fs::path& dir = scratch.dir;
  const Material kes = load_material_file(write(dir / "kes.json", table_material("gf/cm", 1.0)));
  const Material si = load_material_file(write(dir / "si.json", table_material("N/m", 1.0)));
  for (int i = -20; i <= 100; ++i) {
    const double e = 0.001 * i;
    EXPECT_NEAR(kes.weft.stress(e), 0.980665 * si.weft.stress(e), 1e-9 * (1 + std::abs(si.weft.stress(e))));
    EXPECT_NEAR(kes.weft.tangent(e), 0.980665 * si.weft.tangent(e), 1e-9 * si.weft.tangent(e));
    EXPECT_NEAR(kes.weft.energy(e), 0.980665 * si.weft.energy(e), 1e-12);
    EXPECT_NEAR(kes.shear.stress(e), 0.980665 * si.shear.stress(e), 1e-9);
    EXPECT_NEAR(kes.warp.stress(e), 0.980665 * si.warp.stress(e), 1e-12);
  }
  // N/cm is 100 N/m.
  const Material ncm = load_material_file(write(dir / "ncm.json", table_material("N/cm", 0.01)));
  EXPECT_NEAR(ncm.weft.stress(0.03), si.weft.stress(0.03), 1e-9);
}

TEST(MaterialUnits, DensityBendingViscosity) {
  const json si = {{"surface_density", 0.15},
                   {"bending_rigidity", {{"weft", 0.05 * 9.80665e-5}, {"warp", 0.08 * 9.80665e-5}}},
                   {"viscosity", 0.02 * 0.980665}};
  const json kes = {{"surface_density", {{"value", 150}, {"unit", "g/m2"}}},
                    {"bending_rigidity", {{"weft", 0.05}, {"warp", 0.08}, {"unit", "gf cm2/cm"}}},
                    {"viscosity", {{"value", 0.02}, {"unit", "gf s/cm"}}}};
  const Material a = parse_material(si, "si");
  const Material b = parse_material(kes, "kes");
  EXPECT_NEAR(b.surface_density_kg_m2, a.surface_density_kg_m2, 1e-15);
  EXPECT_NEAR(b.bending_rigidity_weft_Nm, a.bending_rigidity_weft_Nm, 1e-18);
  EXPECT_NEAR(b.bending_rigidity_warp_Nm, a.bending_rigidity_warp_Nm, 1e-18);
  EXPECT_NEAR(b.viscosity_Ns_m, a.viscosity_Ns_m, 1e-15);
  const Material c = parse_material(json{{"surface_density", {{"value", 15}, {"unit", "mg/cm2"}}}}, "c");
  EXPECT_NEAR(c.surface_density_kg_m2, 0.15, 1e-15);
  const Material d = parse_material(json{{"bending_rigidity", {{"value", 3.0}, {"unit", "uN m"}}}}, "d");
  EXPECT_NEAR(d.bending_rigidity_weft_Nm, 3e-6, 1e-20);
  EXPECT_NEAR(d.bending_rigidity_warp_Nm, 3e-6, 1e-20);
}

TEST(MaterialUnits, StrainInPercentDegreesAndEngineeringMeasure) {
  const json percent = {{"weft", {{"strain", {0, 1, 2, 4}}, {"stress", {0, 3, 8, 30}},
                                  {"strain_unit", "%"}}}};
  const json fraction = {{"weft", {{"strain", {0, 0.01, 0.02, 0.04}}, {"stress", {0, 3, 8, 30}}}}};
  const Material p = parse_material(percent, "p"), f = parse_material(fraction, "f");
  for (double e : {0.005, 0.015, 0.03, 0.05}) EXPECT_NEAR(p.weft.stress(e), f.weft.stress(e), 1e-12);

  const Material deg = parse_material(
      json{{"shear", {{"strain", {0, 2, 4}}, {"stress", {0, 1, 3}}, {"strain_unit", "deg"}}}}, "deg");
  EXPECT_NEAR(deg.shear.stress(std::sin(4.0 * M_PI / 180.0)), 3.0, 1e-12);
  EXPECT_NEAR(deg.shear.stress(-std::sin(2.0 * M_PI / 180.0)), -1.0, 1e-12);

  // Engineering strain eps and force per original width T become Green strain
  // e = eps + eps^2 / 2 and stress T / (1 + eps).
  const Material eng = parse_material(
      json{{"warp", {{"strain", {0, 2, 5}}, {"stress", {0, 10, 60}}, {"unit", "gf/cm"},
                     {"strain_unit", "%"}, {"strain_measure", "engineering"}}}}, "eng");
  const auto& x = eng.warp.strain_points();
  const auto& y = eng.warp.stress_points();
  ASSERT_EQ(x.size(), 3u);
  EXPECT_NEAR(x[2], 0.05 + 0.5 * 0.05 * 0.05, 1e-15);
  EXPECT_NEAR(y[2], 60 * 0.980665 / 1.05, 1e-12);
  EXPECT_NEAR(x[1], 0.02 + 0.5 * 0.02 * 0.02, 1e-15);
  EXPECT_NEAR(y[1], 10 * 0.980665 / 1.02, 1e-12);
}

TEST(MaterialFile, RejectedWithFileAndFieldInTheMessage) {
  const ScratchDir scratch("bad");
  const fs::path& dir = scratch.dir;
  json j = table_material("N/m", 1.0);

  json bad = j;
  bad["weft"]["strain"] = {0.0, 0.02, 0.01, 0.04, 0.06};
  std::string path = write(dir / "nonmonotone.json", bad);
  std::string msg = error_of([&] { load_material_file(path); });
  EXPECT_NE(msg.find(path), std::string::npos) << msg;
  EXPECT_NE(msg.find("field weft.strain"), std::string::npos) << msg;
  EXPECT_NE(msg.find("increasing"), std::string::npos) << msg;

  bad = j;
  bad["surface_density"] = -0.2;
  path = write(dir / "negative.json", bad);
  msg = error_of([&] { load_material_file(path); });
  EXPECT_NE(msg.find(path + ": field surface_density"), std::string::npos) << msg;
  EXPECT_NE(msg.find("positive"), std::string::npos) << msg;

  bad = j;
  bad["weft"]["unit"] = "lbf/in";
  path = write(dir / "unit.json", bad);
  msg = error_of([&] { load_material_file(path); });
  EXPECT_NE(msg.find(path + ": field weft.unit"), std::string::npos) << msg;
  EXPECT_NE(msg.find("lbf/in"), std::string::npos) << msg;
  EXPECT_NE(msg.find("gf/cm"), std::string::npos) << msg;  // lists what is accepted

  bad = j;
  bad["bending_rigidity"] = {{"weft", 1.0}, {"warp", 1.0}, {"unit", "N"}};
  path = write(dir / "bending_unit.json", bad);
  msg = error_of([&] { load_material_file(path); });
  EXPECT_NE(msg.find(path + ": field bending_rigidity.unit"), std::string::npos) << msg;
}

TEST(MaterialFile, RejectsKeysTypesAndTables) {
  const json j = table_material("N/m", 1.0);
  auto msg_for = [](json m) { return error_of([&] { parse_material(m, "scene.json: cloth.material"); }); };
  auto expect_msg = [](const std::string& msg, const std::string& part) {
    EXPECT_NE(msg.find("scene.json: cloth.material: field " + part), std::string::npos) << msg;
  };

  json bad = j;
  bad["weft"]["stres"] = {1, 2};
  expect_msg(msg_for(bad), "weft.stres");
  bad = j;
  bad["density"] = 0.1;
  expect_msg(msg_for(bad), "density");
  bad = j;
  bad["poisson_ratio"] = "0.2";
  expect_msg(msg_for(bad), "poisson_ratio");
  bad = j;
  bad["poisson_ratio"] = 1.5;
  expect_msg(msg_for(bad), "poisson_ratio");
  bad = j;
  bad["weft"]["stress"] = {0.0, 1.0};
  expect_msg(msg_for(bad), "weft");
  EXPECT_NE(msg_for(bad).find("5 points but stress has 2"), std::string::npos);
  bad = j;
  bad["weft"]["strain"] = json::array();
  expect_msg(msg_for(bad), "weft.strain");
  bad = j;
  bad["weft"]["stress"][2] = std::nan("");
  expect_msg(msg_for(bad), "weft.stress[2]");
  bad = j;
  bad["weft"]["stress"][3] = 1.0;  // falls after 10 N/m
  expect_msg(msg_for(bad), "weft.stress");
  bad = j;
  bad["weft"]["strain"][1] = "x";
  expect_msg(msg_for(bad), "weft.strain[1]");
  bad = j;
  bad["warp"] = -5.0;
  expect_msg(msg_for(bad), "warp");
  bad = j;
  bad["weft_material"] = 2;
  expect_msg(msg_for(bad), "weft_material");
  bad = j;
  bad["weft"]["strain_unit"] = "deg";  // degrees only for shear
  expect_msg(msg_for(bad), "weft.strain_unit");
  bad = j;
  bad["shear"]["strain"] = {0.0, 0.05, 0.1};
  bad["shear"]["stress"] = {1.0, 2.0, 3.0};  // mirrored table needs stress 0 at strain 0
  expect_msg(msg_for(bad), "shear.stress");
}

TEST(MaterialFile, NeedsVersionAndValidJson) {
  const ScratchDir scratch("version");
  const fs::path& dir = scratch.dir;
  const std::string no_version = write(dir / "noversion.json", json{{"surface_density", 0.1}});
  EXPECT_NE(error_of([&] { load_material_file(no_version); }).find("field weft_material"),
            std::string::npos);
  const std::string broken = write_text(dir / "broken.json", "{ \"weft_material\": 1, ");
  EXPECT_NE(error_of([&] { load_material_file(broken); }).find(broken + ":1: malformed JSON"),
            std::string::npos);
  EXPECT_NE(error_of([&] { load_material_file((dir / "missing.json").string()); }).find("cannot open"),
            std::string::npos);
}

TEST(MaterialFile, NeedsASource) {
  const ScratchDir scratch("source");
  const fs::path& dir = scratch.dir;
  const std::string why =
      " (a material file says where its numbers come from: the publication, table and sample of measured "
      "values, or that they are estimated)";
  json j = table_material("N/m", 1.0);
  j.erase("source");
  const std::string missing = write(dir / "missing.json", j);
  EXPECT_EQ(error_of([&] { load_material_file(missing); }), missing + ": field source: missing" + why);
  for (const char* blank : {"", "  \n"}) {
    j["source"] = blank;
    const std::string empty = write(dir / "empty.json", j);
    EXPECT_EQ(error_of([&] { load_material_file(empty); }), empty + ": field source: empty" + why);
  }
  j["source"] = 3;
  const std::string number = write(dir / "number.json", j);
  EXPECT_EQ(error_of([&] { load_material_file(number); }), number + ": field source: expected a string, got number");
  // A file that refers to another needs its own source too; an inline material needs none.
  j["source"] = "ok";
  write(dir / "base.json", j);
  const std::string wrapper = write(dir / "wrapper.json", json{{"weft_material", 1}, {"file", "base.json"}});
  EXPECT_EQ(error_of([&] { load_material_file(wrapper); }), wrapper + ": field source: missing" + why);
  EXPECT_EQ(error_of([&] { parse_material(json{{"surface_density", 0.2}}, "scene.json: cloth.material"); }), "");
}

TEST(MaterialFile, EveryShippedMaterialFileHasASourceAndLoads) {
  // Every JSON file under data/ that is a material file (it has "weft_material") loads, which
  // includes having a non-empty source.
  int files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(std::string(WEFT_SOURCE_DIR) + "/data")) {
    if (!entry.is_regular_file() || entry.path().extension() != ".json") continue;
    std::ifstream in(entry.path());
    const json j = json::parse(in, nullptr, /*allow_exceptions=*/false);
    if (!j.is_object() || !j.contains("weft_material")) continue;
    SCOPED_TRACE(entry.path().string());
    EXPECT_EQ(error_of([&] { load_material_file(entry.path().string()); }), "");
    ++files;
  }
  EXPECT_GE(files, static_cast<int>(material_preset_names().size()));
}

TEST(MaterialCurve, CompressionSoftenedLinearCurve) {
  // {"linear": k, "compression": f}: modulus f k under compression, k under tension, blended
  // over strains within 1e-4 of 0.
  const double k = 2000, f = 0.1, blend = 1e-4;
  const Material m = parse_material(
      json{{"weft", {{"linear", k}, {"compression", f}}}, {"warp", {{"linear", k / 0.980665}, {"unit", "gf/cm"}, {"compression", 1}}}},
      "m");
  EXPECT_TRUE(m.warp.is_linear());  // a factor of 1 is the plain linear curve
  EXPECT_NEAR(m.warp.modulus(), k, 1e-9);
  const StressCurve& c = m.weft;
  for (double e : {blend, 2e-4, 1e-3, 0.05, 0.3}) {
    EXPECT_NEAR(c.stress(e), k * e, 1e-9 * k * e) << e;
    EXPECT_NEAR(c.tangent(e), k, 1e-9 * k) << e;
    EXPECT_NEAR(c.stress(-e), -f * k * e, 1e-9 * k * e) << e;
    EXPECT_NEAR(c.tangent(-e), f * k, 1e-9 * k) << e;
  }
  EXPECT_EQ(c.stress(0.0), 0.0);
  EXPECT_EQ(c.energy(0.0), 0.0);
  // Monotone, C1, and energy, stress and tangent consistent (central differences) through the blend.
  double previous = c.stress(-3e-3);
  for (int i = -299; i <= 300; ++i) {
    const double e = 1e-5 * i + 3.7e-8, h = 1e-9;
    EXPECT_GE(c.stress(e), previous) << e;
    previous = c.stress(e);
    EXPECT_GT(c.tangent(e), 0.0) << e;
    EXPECT_NEAR((c.energy(e + h) - c.energy(e - h)) / (2 * h), c.stress(e), 1e-6 * k * (std::abs(e) + h)) << e;
    EXPECT_NEAR((c.stress(e + h) - c.stress(e - h)) / (2 * h), c.tangent(e), 1e-5 * k) << e;
  }
  // Errors: shear, and the factor outside (0, 1].
  auto message = [](const json& j) { return error_of([&] { parse_material(j, "m.json"); }); };
  EXPECT_EQ(message(json{{"shear", {{"linear", 50}, {"compression", 0.5}}}}),
            "m.json: field shear.compression: applies to weft and warp only (shear is symmetric)");
  EXPECT_EQ(message(json{{"weft", {{"linear", 500}, {"compression", 0}}}}),
            "m.json: field weft.compression: value 0 (fraction of the tensile modulus) is out of range (0, 1] "
            "(fraction of the tensile modulus)");
  EXPECT_EQ(message(json{{"warp", {{"linear", 500}, {"compression", 1.5}}}}),
            "m.json: field warp.compression: value 1.5 (fraction of the tensile modulus) is out of range (0, 1] "
            "(fraction of the tensile modulus)");
  EXPECT_NE(message(json{{"weft", {{"strain", {0, 0.1}}, {"stress", {0, 10}}, {"compression", 0.5}}}})
                .find("m.json: field weft.compression: unknown key"),
            std::string::npos);
}

TEST(MaterialFile, LoadAndUnloadBranchesAveraged) {
  const json j = {{"weft", {{"strain", {0.0, 0.02, 0.04}}, {"stress", {0.0, 20.0, 80.0}},
                            {"unload", {{"strain", {0.04, 0.03, 0.0}}, {"stress", {80.0, 20.0, 0.0}}}}}}};
  const Material m = parse_material(j, "m");
  const StressCurve load = StressCurve::tabulated({0.0, 0.02, 0.04}, {0.0, 20.0, 80.0});
  const StressCurve unload = StressCurve::tabulated({0.0, 0.03, 0.04}, {0.0, 20.0, 80.0});
  ASSERT_EQ(m.weft.strain_points().size(), 4u);  // union of {0, 0.02, 0.04} and {0, 0.03, 0.04}
  for (double e : m.weft.strain_points()) {
    EXPECT_NEAR(m.weft.stress(e), 0.5 * (load.stress(e) + unload.stress(e)), 1e-12) << e;
  }
}

TEST(MaterialReference, PresetFileAndOverrides) {
  const ScratchDir scratch("refs");
  const fs::path& dir = scratch.dir;
  fs::create_directories(dir / "sub");
  json j = table_material("N/m", 1.0);
  j["name"] = "mine";
  j["surface_density"] = 0.2;
  write(dir / "sub" / "mine.json", j);

  const Material by_file = parse_material(json{{"file", "sub/mine.json"}}, "scene", dir.string());
  EXPECT_EQ(by_file.name, "mine");
  EXPECT_DOUBLE_EQ(by_file.surface_density_kg_m2, 0.2);
  const Material absolute =
      parse_material(json{{"file", (dir / "sub" / "mine.json").string()}}, "scene", "/nonexistent");
  EXPECT_EQ(absolute.name, "mine");
  // A file may itself refer to another, relative to its own folder.
  write(dir / "sub" / "wrapper.json",
        json{{"weft_material", 1}, {"source", "mine.json, viscosity chosen"}, {"file", "mine.json"}, {"viscosity", 0.5}});
  const Material wrapped = parse_material(json{{"file", "sub/wrapper.json"}}, "scene", dir.string());
  EXPECT_EQ(wrapped.name, "mine");
  EXPECT_DOUBLE_EQ(wrapped.viscosity_Ns_m, 0.5);
  // A cycle is stopped.
  write(dir / "loop.json", json{{"weft_material", 1}, {"source", "itself"}, {"file", "loop.json"}});
  EXPECT_THROW(parse_material(json{{"file", "loop.json"}}, "scene", dir.string()), InputError);

  const Material denim = material_preset("denim");
  const Material by_string = parse_material(json("denim"), "scene");
  const Material by_key = parse_material(json{{"preset", "denim"}}, "scene");
  const Material overridden = parse_material(json{{"preset", "denim"}, {"viscosity", 0.25}}, "scene");
  for (const Material* m : {&by_string, &by_key, &overridden}) {
    EXPECT_EQ(m->name, "denim");
    EXPECT_DOUBLE_EQ(m->surface_density_kg_m2, denim.surface_density_kg_m2);
    EXPECT_DOUBLE_EQ(m->weft.stress(0.03), denim.weft.stress(0.03));
  }
  EXPECT_DOUBLE_EQ(overridden.viscosity_Ns_m, 0.25);

  const std::string msg = error_of([] { parse_material(json{{"preset", "velvet"}}, "scene.json: cloth.material"); });
  EXPECT_NE(msg.find("scene.json: cloth.material: field preset"), std::string::npos) << msg;
  EXPECT_NE(msg.find("velvet"), std::string::npos) << msg;
  for (const std::string& name : material_preset_names()) {
    EXPECT_NE(msg.find(name), std::string::npos) << msg;
  }
  EXPECT_NE(error_of([] { material_preset("velvet"); }).find("cotton"), std::string::npos);
  EXPECT_THROW(parse_material(json{{"preset", "denim"}, {"file", "x.json"}}, "scene"), InputError);
}

TEST(MaterialPreset, ShippedPresetsAreSane) {
  const std::vector<std::string> names = material_preset_names();
  for (const char* required : {"cotton", "denim", "wool", "silk", "polyester"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), required), names.end()) << required;
  }
  for (const std::string& name : names) {
    SCOPED_TRACE(name);
    const Material m = material_preset(name);
    // The estimated woven presets keep to docs/method.md section 5's ranges; the jersey of the
    // paper's swing test is a soft knit far below them (tests/fabric/test_jersey.cpp checks it).
    const bool woven = name != "jersey" && material_preset_kind(name) == "estimated";
    // The measured presets are linear (Luible's linear inputs); tests above check their numbers.
    const bool tabulated = material_preset_kind(name) == "estimated";
    EXPECT_EQ(m.name, name);
    EXPECT_FALSE(m.source.empty());
    EXPECT_GT(m.surface_density_kg_m2, 0.0);
    EXPECT_LT(m.surface_density_kg_m2, 1.0);
    EXPECT_GE(m.viscosity_Ns_m, 0.0);
    EXPECT_GE(m.poisson_ratio, 0.0);
    EXPECT_LT(m.poisson_ratio, 0.5);
    if (woven) {
      // The woven presets are estimates, and each file's source says so first.
      EXPECT_EQ(m.source.rfind("Estimated, not measured", 0), 0u) << m.source;
      // docs/method.md section 5 ranges for the fabric classes.
      for (double b : {m.bending_rigidity_weft_Nm, m.bending_rigidity_warp_Nm}) {
        EXPECT_GE(b, 1e-6);
        EXPECT_LE(b, 1e-4);
      }
      EXPECT_GE(m.shear.tangent(0.0), 20.0);
      EXPECT_LE(m.shear.tangent(0.0), 120.0);
    }
    for (const StressCurve* c : {&m.weft, &m.warp}) {
      if (!tabulated) {
        EXPECT_GT(c->tangent(0.0), 0.0);
        continue;
      }
      ASSERT_FALSE(c->is_linear());
      EXPECT_NEAR(c->stress(0.0), 0.0, 1e-9);  // stress-free at rest
      const double last = c->strain_points().back();
      if (woven) {
        EXPECT_GE(c->tangent(0.0), 100.0);
        EXPECT_LE(c->tangent(0.0), 1000.0);
        EXPECT_LE(last, 0.15);
      }
      EXPECT_GT(c->tangent(last), 5.0 * c->tangent(0.0));  // stiffens past a few percent
      for (int i = 0; i <= 1000; ++i) EXPECT_GT(c->tangent(last * i / 1000.0), 0.0);
    }
    // Energy and tangent agree with stress (central differences) across and past the tables,
    // sampled off the knots (the curves are C1, so the second derivative jumps there).
    for (const StressCurve* c : {&m.weft, &m.warp, &m.shear}) {
      for (int i = -50; i <= 200; ++i) {
        const double e = 0.001 * i + 3.7e-5, h = 1e-6;
        const auto& knots = c->strain_points();
        if (std::any_of(knots.begin(), knots.end(), [&](double x) { return std::abs(x - e) < 2 * h; })) {
          continue;
        }
        const double ds = (c->stress(e + h) - c->stress(e - h)) / (2 * h);
        const double dw = (c->energy(e + h) - c->energy(e - h)) / (2 * h);
        EXPECT_NEAR(ds, c->tangent(e), 1e-4 * (1 + std::abs(c->tangent(e)))) << e;
        EXPECT_NEAR(dw, c->stress(e), 1e-6 * (1 + std::abs(c->stress(e)))) << e;
      }
    }
    const double shear_last = m.shear.is_linear() ? 0.15 : m.shear.strain_points().back();
    EXPECT_NEAR(m.shear.stress(0.0), 0.0, 1e-12);
    for (int i = -1000; i <= 1000; ++i) EXPECT_GT(m.shear.tangent(shear_last * i / 1000.0), 0.0);
  }
  EXPECT_NEAR(material_preset("cotton").surface_density_kg_m2, 0.150, 0.01);
}

// ---------------------------------------------------------------- measured presets (Luible 2008)

/// The Luible (2008) samples with a preset, and the preset's name (docs/materials.md).
const std::vector<std::pair<std::string, std::string>> kLuibleSamples = {
    {"01", "luible-denim"},          {"02", "luible-cotton-shirting"}, {"05", "luible-wool-gabardine"},
    {"07", "luible-silk-mulberry"},  {"08", "luible-silk-bourette"},   {"09", "luible-silk-tussah"},
    {"12", "luible-stretch-denim"},  {"15", "luible-velvet"},          {"21", "luible-single-jersey"},
    {"32", "luible-garment-leather"}, {"34", "luible-wool-suiting"}};

/// The repository's copy of the published fabric table (data/fabrics/fabrics.json).
json fabric_table() {
  std::ifstream in(std::string(WEFT_SOURCE_DIR) + "/data/fabrics/fabrics.json");
  EXPECT_TRUE(in) << "data/fabrics/fabrics.json";
  return json::parse(in);
}

/// A quantity of the table in the unit it is expected in (the test fails on another unit).
double table_value(const json& q, const std::string& unit) {
  EXPECT_EQ(q.at("unit").get<std::string>(), unit) << q.dump();
  return q.at("value").get<double>();
}

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

TEST(MeasuredPreset, NumbersAreTheConversionOfTheShippedTable) {
  const json table = fabric_table();
  // The documented bending rule: B = k W with k the geometric mean of B / W (gf cm^2/cm per
  // mg/cm^2) over the four Matsudaira et al. (2015) fabrics of the same table.
  double log_sum = 0;
  int matsudaira = 0;
  for (const json& f : table) {
    if (f.at("name").get<std::string>().find("Matsudaira 2015") == std::string::npos) continue;
    log_sum += std::log(table_value(f.at("bending").at("B"), "gf\u00b7cm\u00b2/cm") /
                        table_value(f.at("weight_as_published"), "mg/cm\u00b2"));
    ++matsudaira;
  }
  ASSERT_EQ(matsudaira, 4);
  const double bend_per_weight = std::exp(log_sum / matsudaira);

  // Every Luible sample with tensile numbers has a preset.
  int luible_with_tensile = 0;
  for (const json& f : table) {
    if (f.at("name").get<std::string>().find("Luible 2008") != std::string::npos && f.at("tensile").is_object()) {
      ++luible_with_tensile;
    }
  }
  EXPECT_EQ(luible_with_tensile, static_cast<int>(kLuibleSamples.size()));

  for (const auto& [sample, name] : kLuibleSamples) {
    SCOPED_TRACE(name);
    const json* entry = nullptr;
    for (const json& f : table) {
      if (ends_with(f.at("source").at("table_or_figure").get<std::string>(), "sample no. " + sample)) entry = &f;
    }
    ASSERT_NE(entry, nullptr) << "sample no. " << sample;
    const json& f = *entry;
    const Material m = material_preset(name);
    // Luible's linear stiffnesses (N/m) are the slopes of linear curves in Green strain.
    const std::pair<const StressCurve*, double> curves[] = {
        {&m.weft, table_value(f.at("tensile").at("weft"), "N/m")},
        {&m.warp, table_value(f.at("tensile").at("warp"), "N/m")},
        {&m.shear, table_value(f.at("shear").at("G_tan"), "N/m")}};
    for (const auto& [c, k] : curves) {
      EXPECT_TRUE(c->is_linear());
      EXPECT_DOUBLE_EQ(c->tangent(0.0), k);
      EXPECT_DOUBLE_EQ(c->stress(0.01), 0.01 * k);
    }
    const double weight_g_m2 = table_value(f.at("weight_as_published"), "g/m\u00b2");
    EXPECT_DOUBLE_EQ(m.surface_density_kg_m2, weight_g_m2 * 1e-3);
    // Chosen: bending by the rule (W in mg/cm^2 = g/m^2 / 10; the file rounds B to 4 digits),
    // the same in both directions; no Poisson coupling.
    const double bending_Nm = bend_per_weight * weight_g_m2 / 10 * 9.80665e-5;
    EXPECT_NEAR(m.bending_rigidity_weft_Nm, bending_Nm, 1e-3 * bending_Nm);
    EXPECT_EQ(m.bending_rigidity_warp_Nm, m.bending_rigidity_weft_Nm);
    EXPECT_EQ(m.poisson_ratio, 0.0);
    EXPECT_EQ(material_preset_kind(name), "measured");
  }
}

TEST(MeasuredPreset, SourceCitesTheTableAndSampleAndSaysWhatIsChosen) {
  for (const auto& [sample, name] : kLuibleSamples) {
    SCOPED_TRACE(name);
    const std::string source = material_preset(name).source;
    ASSERT_FALSE(source.empty());
    EXPECT_EQ(source.rfind("Measured", 0), 0u) << source;
    for (const std::string& part : std::vector<std::string>{"Luible (2008)", "PhD thesis no. 678", "Annex G",
                                   "'Linear derived fabric input parameters'", "sample no. " + sample,
                                   "not yet checked against the thesis", "Chosen, not measured",
                                   "bending rigidity", "Matsudaira", "Poisson", "viscosity"}) {
      EXPECT_NE(source.find(part), std::string::npos) << part << " in: " << source;
    }
  }
}

// The material files of the drape comparison (docs/notes/drape-matsudaira.md): bending
// rigidity and weight are the Matsudaira et al. (2015) table's, the rest is chosen and said so.
TEST(MeasuredPreset, MatsudairaDrapeFilesHoldTheTablesBendingAndWeight) {
  const json table = fabric_table();
  const std::pair<std::string, std::string> files[] = {{"A", "matsudaira-cotton-broadcloth"},
                                                       {"B", "matsudaira-wool-tropical"},
                                                       {"C", "matsudaira-polyester-tropical"},
                                                       {"F", "matsudaira-polyester-faille"}};
  for (const auto& [letter, name] : files) {
    SCOPED_TRACE(name);
    const json* entry = nullptr;
    for (const json& f : table) {
      if (ends_with(f.at("name").get<std::string>(), "[Matsudaira 2015 fabric " + letter + "]")) entry = &f;
    }
    ASSERT_NE(entry, nullptr);
    const Material m =
        load_material_file(std::string(WEFT_SOURCE_DIR) + "/data/fabrics/matsudaira/" + name + ".json");
    const double B = table_value(entry->at("bending").at("B"), "gf\u00b7cm\u00b2/cm") * 9.80665e-5;
    EXPECT_NEAR(m.bending_rigidity_weft_Nm, B, 1e-12 * B);
    EXPECT_NEAR(m.bending_rigidity_warp_Nm, B, 1e-12 * B);
    EXPECT_NEAR(m.surface_density_kg_m2, table_value(entry->at("weight_as_published"), "mg/cm\u00b2") * 1e-2, 1e-15);
    // Chosen: linear weft and warp, 1% of it under compression; linear shear.
    for (const StressCurve* c : {&m.weft, &m.warp}) {
      const double k = c->stress(0.01) / 0.01;
      EXPECT_NEAR(c->tangent(0.02), k, 1e-9 * k);
      EXPECT_NEAR(c->stress(-0.01), -0.01 * k * 0.01, 1e-9 * k);
    }
    EXPECT_TRUE(m.shear.is_linear());
    for (const std::string& part : std::vector<std::string>{"Matsudaira", "Table 1", "fabric " + letter,
                                                            "not yet checked against the paper",
                                                            "Chosen, not measured: tensile",
                                                            "under compression weft and warp 0.01"}) {
      EXPECT_NE(m.source.find(part), std::string::npos) << part << " in: " << m.source;
    }
  }
}

TEST(MaterialPreset, ListingGroupsEveryPresetAsMeasuredOrEstimated) {
  // "estimated: a, b; measured: c, d"
  const std::string listing = material_preset_listing();
  std::map<std::string, std::string> kind_of;
  std::size_t begin = 0;
  while (begin < listing.size()) {
    std::size_t end = listing.find("; ", begin);
    if (end == std::string::npos) end = listing.size();
    const std::string group = listing.substr(begin, end - begin);
    const std::size_t colon = group.find(": ");
    ASSERT_NE(colon, std::string::npos) << listing;
    const std::string kind = group.substr(0, colon);
    EXPECT_TRUE(kind == "measured" || kind == "estimated") << listing;
    std::stringstream names(group.substr(colon + 2));
    for (std::string n; std::getline(names, n, ',');) {
      if (n.front() == ' ') n.erase(0, 1);
      EXPECT_EQ(kind_of.count(n), 0u) << n << " listed twice: " << listing;
      kind_of[n] = kind;
    }
    begin = end + 2;
  }
  const std::vector<std::string> names = material_preset_names();
  EXPECT_EQ(kind_of.size(), names.size()) << listing;
  for (const std::string& name : names) {
    SCOPED_TRACE(name);
    ASSERT_EQ(kind_of.count(name), 1u) << listing;
    EXPECT_EQ(kind_of[name], material_preset_kind(name));
    // Measured exactly when the source says so first.
    EXPECT_EQ(kind_of[name] == "measured", material_preset(name).source.rfind("Measured", 0) == 0);
  }
  for (const auto& [sample, name] : kLuibleSamples) EXPECT_EQ(kind_of[name], "measured") << name;
  for (const char* name : {"cotton", "denim", "wool", "silk", "polyester", "jersey"}) {
    EXPECT_EQ(kind_of[name], "estimated") << name;
  }
}

TEST(MaterialFile, DocumentedExampleParses) {
  // The JSON example in docs/materials.md is a valid material file.
  std::ifstream in(std::string(WEFT_SOURCE_DIR) + "/docs/materials.md");
  ASSERT_TRUE(in);
  const std::string doc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t begin = doc.find("```json\n");
  ASSERT_NE(begin, std::string::npos);
  const std::size_t end = doc.find("```", begin + 8);
  const ScratchDir scratch("doc_example");
  const fs::path& dir = scratch.dir;
  const std::string path = write_text(dir / "example.json", doc.substr(begin + 8, end - begin - 8));
  const Material m = load_material_file(path);
  EXPECT_EQ(m.name, "my_twill");
  EXPECT_GT(m.weft.tangent(0.0), 0.0);
  EXPECT_GT(m.bending_rigidity_warp_Nm, m.bending_rigidity_weft_Nm);
}

}  // namespace
}  // namespace weft
