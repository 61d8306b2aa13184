// The jersey of the paper's swing test (data/materials/jersey.json, docs/materials.md): its
// curves pass through its own table, shear is half of tensile, the curves are monotone with
// the documented slopes at zero, and the tensile experiment on the assembled cloth model
// reproduces the table.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "weft/fabric_experiments.hpp"
#include "weft/material.hpp"

using namespace weft;

namespace {

const std::string kJerseyFile = std::string(WEFT_SOURCE_DIR) + "/data/materials/jersey.json";

nlohmann::json jersey_json() {
  std::ifstream in(kJerseyFile);
  return nlohmann::json::parse(in);
}

std::vector<double> column(const nlohmann::json& j, const char* curve, const char* key) {
  return j.at(curve).at(key).get<std::vector<double>>();
}

}  // namespace

TEST(JerseyMaterial, FileIsThePresetAndItsCurvesPassThroughItsTable) {
  const Material m = load_material_file(kJerseyFile);
  EXPECT_EQ(m.name, material_preset("jersey").name);
  EXPECT_DOUBLE_EQ(m.surface_density_kg_m2, 0.1);  // 100 g/m^2, the paper's
  const nlohmann::json j = jersey_json();
  // The file's tables are in N/m against Green strain as a fraction: no conversion.
  ASSERT_EQ(j.at("weft").at("unit"), "N/m");
  for (const char* name : {"weft", "warp", "shear"}) {
    SCOPED_TRACE(name);
    const StressCurve& c = name[0] == 'w' ? (name[1] == 'e' ? m.weft : m.warp) : m.shear;
    const std::vector<double> strain = column(j, name, "strain"), stress = column(j, name, "stress");
    ASSERT_EQ(strain.size(), stress.size());
    for (size_t k = 0; k < strain.size(); ++k)
      EXPECT_NEAR(c.stress(strain[k]), stress[k], 1e-12 * (1 + stress[k])) << strain[k];
  }
  // Shear is half of tensile (the paper's "shear is taken half as tensile"), at every strain of
  // the table and between them, and mirrored to negative shear.
  for (int i = 0; i <= 600; ++i) {
    const double e = 0.001 * i;
    EXPECT_NEAR(m.shear.stress(e), 0.5 * m.weft.stress(e), 1e-12 * (1 + m.weft.stress(e))) << e;
    EXPECT_NEAR(m.shear.stress(-e), -m.shear.stress(e), 1e-12 * (1 + m.shear.stress(e))) << e;
    EXPECT_DOUBLE_EQ(m.warp.stress(e), m.weft.stress(e)) << e;
  }
  // The paper's figure 7: about 90 N/m at 40% strain.
  EXPECT_NEAR(m.weft.stress(0.4), 90.0, 1e-9);
}

TEST(JerseyMaterial, CurvesAreMonotoneWithTheDocumentedSlopesAtZero) {
  const Material m = load_material_file(kJerseyFile);
  // docs/materials.md and the file's notes: 2 N/m weft and warp, 1 N/m shear at zero strain.
  EXPECT_NEAR(m.weft.tangent(0.0), 2.0, 1e-9);
  EXPECT_NEAR(m.warp.tangent(0.0), 2.0, 1e-9);
  EXPECT_NEAR(m.shear.tangent(0.0), 1.0, 1e-9);
  // Monotone over compression, the table and past it, with the tangent the stress's derivative.
  for (const StressCurve* c : {&m.weft, &m.warp, &m.shear}) {
    double previous = c->stress(-0.2);
    for (int i = -199; i <= 600; ++i) {
      const double e = 0.001 * i + 3.7e-5, h = 1e-6;  // off the knots (the curve is C1)
      EXPECT_GT(c->tangent(e), 0.0) << e;
      const double s = c->stress(e);
      EXPECT_GT(s, previous) << e;
      previous = s;
      EXPECT_NEAR((c->stress(e + h) - c->stress(e - h)) / (2 * h), c->tangent(e), 1e-4 * (1 + c->tangent(e)))
          << e;
    }
  }
  // A stiffening curve: the tangent at 40% strain is far above the one at zero.
  EXPECT_GT(m.weft.tangent(0.4), 100 * m.weft.tangent(0.0));
}

TEST(JerseyMaterial, TensileExperimentReproducesTheTable) {
  const Material m = load_material_file(kJerseyFile);
  ASSERT_EQ(m.poisson_ratio, 0.0);  // so the uniaxial response along a yarn is the curve itself
  const nlohmann::json j = jersey_json();
  const std::vector<double> strain = column(j, "weft", "strain"), stress = column(j, "weft", "stress");
  TensileOptions o;
  o.cells_along = 24;
  o.cells_across = 6;
  // Clamp strains at every 0.05 of the table from 0.05 to 0.4.
  o.max_strain = strain.back();
  o.increments = static_cast<int>(std::lround(strain.back() / 0.05));
  for (const std::string direction : {"weft", "warp"}) {
    SCOPED_TRACE(direction);
    const TensileResult r = run_tensile_test(m, direction, o);
    ASSERT_EQ(r.points.size(), static_cast<size_t>(o.increments));
    for (const TensilePoint& p : r.points) {
      ASSERT_TRUE(p.converged) << p.clamp_strain;
      // The table's stress at this clamp strain, from the file itself.
      size_t k = 0;
      while (k < strain.size() && std::abs(strain[k] - p.clamp_strain) > 1e-9) ++k;
      ASSERT_LT(k, strain.size()) << "clamp strain " << p.clamp_strain << " is not in the table";
      // The strip is uniform without Poisson coupling: the gauge sees the clamp strain, and the
      // measured stress is the table's within 1% (floored at 1% of the largest, near zero).
      EXPECT_NEAR(p.gauge_strain, p.clamp_strain, 1e-3 * p.clamp_strain);
      EXPECT_NEAR(p.measured_stress, stress[k], 0.01 * std::max(stress[k], 0.01 * stress.back()))
          << "strain " << strain[k];
    }
  }
}
