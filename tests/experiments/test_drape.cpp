// The drape test (weft/experiments/drape.hpp, docs/fabric-validation.md): its shadow area and node
// count on known shapes, and the drape of a very stiff, a very limp and a balanced fabric on a
// coarse specimen: the coefficient's order in bending rigidity and in weight, and a quarter turn
// of a balanced grain.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <nlohmann/json.hpp>

#include "weft/experiments/drape.hpp"
#include "weft/error.hpp"
#include "weft/material.hpp"

using namespace weft;

namespace {

Material inline_material(const nlohmann::json& j) { return parse_material(j, "test material"); }

DrapeOptions coarse() {
  DrapeOptions o;
  o.edge_length_m = 0.02;
  o.max_time_s = 6;
  o.self_collision = false;
  return o;
}

}  // namespace

TEST(DrapeShadow, AreaOfTheUnionOfTheProjectedTriangles) {
  // A flat specimen covers its own polygon once, whichever triangles overlap.
  DrapeOptions o;
  o.edge_length_m = 0.02;
  std::vector<int> support, edge;
  const TriMesh m = drape_specimen_mesh(o, support, edge);
  double polygon = 0;  // the outer boundary's polygon area (shoelace, in x and -z)
  for (size_t k = 0; k < edge.size(); ++k) {
    const int a = edge[k], b = edge[(k + 1) % edge.size()];
    polygon += 0.5 * (m.positions(a, 0) * -m.positions(b, 2) - m.positions(b, 0) * -m.positions(a, 2));
  }
  const double area = projected_area(m.positions, m.triangles, 2e-4);
  EXPECT_NEAR(area, polygon, 2e-3 * polygon);
  // The same triangles twice, and the mesh folded in half over itself, count once.
  TriMesh twice = m;
  twice.triangles.insert(twice.triangles.end(), m.triangles.begin(), m.triangles.end());
  EXPECT_DOUBLE_EQ(projected_area(twice.positions, twice.triangles, 2e-4), area);
  // Two copies side by side cover twice the area.
  TriMesh two = twice;
  two.positions.resize(2 * m.num_vertices(), 3);
  two.positions << m.positions, m.positions.rowwise() + Eigen::RowVector3d(1.0, 0.0, 0.0);
  for (size_t t = m.triangles.size(); t < two.triangles.size(); ++t)
    for (int& v : two.triangles[t]) v += m.num_vertices();
  EXPECT_NEAR(projected_area(two.positions, two.triangles, 2e-4), 2 * area, 1e-3 * area);
  // A vertical triangle casts no area.
  Points wall(3, 3);
  wall << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  EXPECT_EQ(projected_area(wall, {{0, 1, 2}}, 1e-3), 0.0);
  // The mesh: every support vertex within the disk, every edge vertex on the rim, in order.
  for (int i : support) EXPECT_LE(std::hypot(m.positions(i, 0), m.positions(i, 2)), 0.09 + 1e-12);
  for (size_t k = 0; k < edge.size(); ++k) {
    EXPECT_NEAR(std::hypot(m.positions(edge[k], 0), m.positions(edge[k], 2)), 0.15, 1e-12);
  }
}

TEST(DrapeNodes, CountsTheProminentMaximaOfAClosedProfile) {
  for (int folds : {3, 5, 8, 11}) {
    std::vector<double> r;
    for (int k = 0; k < 180; ++k) {
      const double a = 2 * M_PI * k / 180;
      // Uneven folds plus ripples far below the prominence.
      r.push_back(0.12 + 0.02 * std::cos(folds * a + 0.3) * (1 + 0.3 * std::sin(a)) + 1e-4 * std::sin(47 * a));
    }
    EXPECT_EQ(profile_nodes(r, 0.2 * 0.04).size(), static_cast<size_t>(folds)) << folds;
  }
  // A circle has none; a single bump has one; a plateau counts once.
  EXPECT_TRUE(profile_nodes(std::vector<double>(60, 0.15), 1e-3).empty());
  std::vector<double> bump(60, 0.1);
  bump[20] = 0.11;
  EXPECT_EQ(profile_nodes(bump, 1e-3), std::vector<int>{20});
  bump[21] = 0.11;
  EXPECT_EQ(profile_nodes(bump, 1e-3).size(), 1u);
}

TEST(DrapeTest, CoefficientTendsToOneForAStiffFabricAndToZeroForALimpOne) {
  const DrapeOptions o = coarse();
  const DrapeResult stiff = run_drape_test(
      inline_material({{"surface_density", 0.2}, {"weft", 2e4}, {"warp", 2e4}, {"shear", 5e3}, {"bending_rigidity", 1.0}}), o);
  const DrapeResult medium = run_drape_test(
      inline_material({{"surface_density", 0.2}, {"weft", 2e3}, {"warp", 2e3}, {"shear", 100}, {"bending_rigidity", 1e-4}}), o);
  const DrapeResult limp = run_drape_test(
      inline_material({{"surface_density", 0.2}, {"weft", 2e3}, {"warp", 2e3}, {"shear", 100}, {"bending_rigidity", 1e-8}}), o);
  for (const DrapeResult* r : {&stiff, &medium, &limp}) {
    EXPECT_EQ(r->status, "ok");
    EXPECT_TRUE(r->at_rest) << r->max_speed_m_s;
  }
  EXPECT_GT(stiff.drape_coefficient, 0.97);
  EXPECT_LE(stiff.drape_coefficient, 1.0 + 1e-3);
  EXPECT_EQ(stiff.nodes, 0);  // stays flat: no folds
  EXPECT_LT(limp.drape_coefficient, 0.2);
  EXPECT_GE(limp.drape_coefficient, 0.0);
  EXPECT_GT(medium.drape_coefficient, limp.drape_coefficient);
  EXPECT_LT(medium.drape_coefficient, stiff.drape_coefficient);
  EXPECT_GT(medium.nodes, 2);
}

TEST(DrapeTest, CoefficientRisesWithBendingRigidityAndFallsWithWeight) {
  // A 24 cm specimen on a 12 cm disk in 2 cm edges: coarse, but each step below changes the
  // bending length (B / W)^(1/3) by a factor of 1.6, far more than the mesh's noise.
  DrapeOptions o = coarse();
  o.specimen_diameter_m = 0.24;
  o.support_diameter_m = 0.12;
  auto drape = [&](double bending_Nm, double density_kg_m2) {
    const DrapeResult r = run_drape_test(inline_material({{"surface_density", density_kg_m2},
                                                          {"weft", 2e3},
                                                          {"warp", 2e3},
                                                          {"shear", 100},
                                                          {"bending_rigidity", bending_Nm}}),
                                         o);
    EXPECT_EQ(r.status, "ok");
    EXPECT_TRUE(r.at_rest) << r.max_speed_m_s;
    return r.drape_coefficient;
  };
  const double bending[3] = {4e-6, 1.6e-5, 6.4e-5};
  double previous = -1;
  for (double b : bending) {
    const double c = drape(b, 0.15);
    EXPECT_GT(c, previous) << "bending rigidity " << b << " N m";
    previous = c;
  }
  const double density[3] = {0.075, 0.3, 1.2};
  previous = 2;
  for (double w : density) {
    const double c = drape(1.6e-5, w);
    EXPECT_LT(c, previous) << "surface density " << w << " kg/m2";
    previous = c;
  }
}

TEST(DrapeTest, FoldCountOfABalancedFabricDoesNotChangeWhenTheGrainTurnsBy90Degrees) {
  // Weft and warp alike: turned by 90 degrees the material is the same, the mesh under it is not.
  const Material balanced = inline_material(
      {{"surface_density", 0.2}, {"weft", 2e3}, {"warp", 2e3}, {"shear", 100}, {"bending_rigidity", 3e-5}});
  DrapeOptions o = coarse();
  const DrapeResult along = run_drape_test(balanced, o);
  o.grain_deg = 90;
  const DrapeResult turned = run_drape_test(balanced, o);
  EXPECT_GT(along.nodes, 2);
  EXPECT_EQ(along.nodes, turned.nodes);
  EXPECT_NEAR(along.drape_coefficient, turned.drape_coefficient, 0.01);
}

TEST(DrapeTest, ImperfectionStartsTheOverhangOffFlatAndDependsOnlyOnTheSeed) {
  // A run too short to move: the result is the start.
  DrapeOptions o = coarse();
  o.max_time_s = o.dt_s;
  o.frame_interval_s = o.dt_s;
  o.imperfection_m = 0.01;
  const Material m = material_preset("cotton");
  const DrapeResult a = run_drape_test(m, o), b = run_drape_test(m, o);
  o.imperfection_seed = 2;
  const DrapeResult c = run_drape_test(m, o);
  double highest = 0, edge_highest = 0;
  for (int i = 0; i < a.mesh.num_vertices(); ++i) {
    const double rho = std::hypot(a.mesh.positions(i, 0), a.mesh.positions(i, 2));
    const double lift = std::abs(a.mesh.positions(i, 1));
    highest = std::max(highest, lift);
    if (rho < 0.09 - 1e-9) EXPECT_LT(lift, 1e-6) << "the clamped disk stays flat";
    if (rho > 0.14) edge_highest = std::max(edge_highest, lift);
  }
  EXPECT_LE(highest, 0.01 + 2e-4);       // the wave's bound, plus one step of falling
  EXPECT_GT(edge_highest, 0.3 * 0.01);   // and the edge does leave the plane
  EXPECT_EQ(a.mesh.positions, b.mesh.positions);
  EXPECT_NE(a.mesh.positions, c.mesh.positions);
  o.imperfection_m = 0.05;  // more than half the 6 cm overhang
  try {
    run_drape_test(m, o);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "--imperfection 0.05: expected a height (m) from 0 to half the overhang (0.03 m)");
  }
}

TEST(DrapeTest, RejectsBadOptionsNamingThem) {
  DrapeOptions o = coarse();
  o.support_diameter_m = 0.4;
  try {
    run_drape_test(material_preset("cotton"), o);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--support-diameter 0.4"), std::string::npos) << e.what();
  }
  o = coarse();
  o.edge_length_m = 0.05;
  EXPECT_THROW(run_drape_test(material_preset("cotton"), o), InputError);
}

TEST(DrapeCommand, WritesResultsAndPicturesAndRejectsBadOptionsWritingNothing) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("weft_drape_cmd_" + std::to_string(::getpid()));
  const fs::path err_file = fs::temp_directory_path() / ("weft_drape_err_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  auto run = [&](const std::string& args) {
    const std::string cmd = std::string("'") + WEFT_EXE + "' experiment drape " + args + " --out '" + dir.string() +
                            "' -q > /dev/null 2> '" + err_file.string() + "'";
    const int status = std::system(cmd.c_str());
    std::ifstream in(err_file);
    std::stringstream s;
    s << in.rdbuf();
    return std::pair{WIFEXITED(status) ? WEXITSTATUS(status) : -1, s.str()};
  };
  auto [code, err] = run("--material nosuchfabric");
  EXPECT_EQ(code, 2);
  EXPECT_NE(err.find("--material 'nosuchfabric'"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir));
  std::tie(code, err) = run("--edge-length 0.05");
  EXPECT_EQ(code, 2);
  EXPECT_NE(err.find("--edge-length 0.05"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir));

  // A material file without a source is refused, naming the file.
  const fs::path no_source = fs::temp_directory_path() / ("weft_drape_nosource_" + std::to_string(::getpid()) + ".json");
  std::ofstream(no_source) << R"({"weft_material": 1, "surface_density": 0.2})";
  std::tie(code, err) = run("--material '" + no_source.string() + "'");
  EXPECT_EQ(code, 2);
  EXPECT_NE(err.find("--material '" + no_source.string() + "': " + no_source.string() +
                     ": field source: missing (a material file says where its numbers come from"),
            std::string::npos)
      << err;
  EXPECT_FALSE(fs::exists(dir));
  fs::remove(no_source);

  std::tie(code, err) = run("--material silk --edge-length 0.025 --max-time 0.5");
  EXPECT_EQ(code, 0) << err;
  std::ifstream in(dir / "results.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j.at("material").at("name"), "silk");
  EXPECT_GT(j.at("drape_coefficient").get<double>(), 0.0);
  EXPECT_LT(j.at("drape_coefficient").get<double>(), 1.0);
  EXPECT_EQ(j.at("node_angles_deg").size(), j.at("nodes").get<size_t>());
  for (const char* name : {"results.md", "edge.csv", "top.png", "side.png"}) EXPECT_TRUE(fs::exists(dir / name)) << name;
  fs::remove_all(dir);
  fs::remove(err_file);
}
