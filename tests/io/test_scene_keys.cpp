// Scene keys that are accepted must have their documented effect (docs/scene-format.md):
// initial_velocity, placement, uv_scale, the best-fit-plane pattern of an OBJ without
// texture coordinates, and the ranges of pins and the damping ratio at their edges.
#include <gtest/gtest.h>

#include <cmath>

#include "support/command.hpp"
#include "weft/error.hpp"
#include "sim/simulation_core.hpp"

using namespace weft;

namespace {

nlohmann::json base_scene() {
  return nlohmann::json::parse(R"({
    "weft_scene": 1, "duration": 0.05, "frame_interval": 0.01,
    "integrator": {"method": "implicit-midpoint", "dt": 0.01},
    "cloth": {"mesh": {"grid": {"size": [1.0, 0.5], "vertices": [5, 3]}}}
  })");
}

Scene parse(const nlohmann::json& j, const std::string& base_dir = ".") { return parse_scene(j, "scene.json", base_dir); }

/// The message of the InputError that parsing `j` throws ("" if it does not throw).
std::string parse_error(const nlohmann::json& j) {
  try {
    parse(j);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

class SceneKeys : public weft::test::CommandTest {};

}  // namespace

TEST_F(SceneKeys, InitialVelocityGivesTheFreeVerticesThatVelocityAndTheClothThatMomentum) {
  nlohmann::json j = base_scene();
  j["gravity"] = {0, 0, 0};
  j["cloth"]["initial_velocity"] = {0.3, -0.2, 1.5};
  const Vec3 v0(0.3, -0.2, 1.5);
  {
    j["cloth"]["pins"] = {{"vertices", {0}}};
    Simulation sim(parse(j));
    EXPECT_EQ(node(sim.core().state().v, 0), Vec3::Zero()) << "a pinned vertex does not move";
    for (int i = 1; i < sim.core().model().num_vertices(); ++i) EXPECT_EQ(node(sim.core().state().v, i), v0) << "vertex " << i;
  }
  j["cloth"].erase("pins");
  Simulation sim(parse(j));
  const double mass = sim.core().model().mass.sum();
  EXPECT_NEAR(mass, 0.5 * sim.scene().cloth.material.surface_density_kg_m2, 1e-12);
  const auto momentum = [&] {
    Vec3 p = Vec3::Zero();
    for (int i = 0; i < sim.core().model().num_vertices(); ++i) p += sim.core().model().mass[i] * node(sim.core().state().v, i);
    return p;
  };
  EXPECT_LT((momentum() - mass * v0).norm(), 1e-12 * mass * v0.norm());
  // Without gravity or pins nothing acts on the cloth from outside: it keeps that momentum.
  sim.advance_to(0.05);
  EXPECT_LT((momentum() - mass * v0).norm(), 1e-9 * mass * v0.norm());
  EXPECT_NEAR(sim.energies().kinetic, 0.5 * mass * v0.squaredNorm(), 1e-9 * mass * v0.squaredNorm());
}

TEST_F(SceneKeys, PlacementRotatesThenTranslatesByExactlyTheGivenAmounts) {
  nlohmann::json j = base_scene();
  const TriMesh flat = build_cloth_mesh(parse(j).cloth);
  j["cloth"]["placement"] = {{"translation", {0.25, -1.5, 3.0}}};
  const TriMesh moved = build_cloth_mesh(parse(j).cloth);
  // Rotating the z = 0 grid by 90 degrees about x takes (x, y, 0) to (x, 0, y).
  j["cloth"]["placement"]["rotation_deg"] = {90, 0, 0};
  const TriMesh turned = build_cloth_mesh(parse(j).cloth);
  ASSERT_EQ(flat.num_vertices(), 15);
  for (int i = 0; i < flat.num_vertices(); ++i) {
    const Vec3 p = flat.positions.row(i).transpose();
    const Vec3 t(0.25, -1.5, 3.0);
    EXPECT_LT((Vec3(moved.positions.row(i).transpose()) - (p + t)).norm(), 1e-12) << "vertex " << i;
    EXPECT_LT((Vec3(turned.positions.row(i).transpose()) - (Vec3(p.x(), 0, p.y()) + t)).norm(), 1e-12) << "vertex " << i;
    // Placement moves the cloth, not its rest shape.
    EXPECT_EQ(moved.pattern[i], flat.pattern[i]);
    EXPECT_EQ(turned.pattern[i], flat.pattern[i]);
  }
}

TEST_F(SceneKeys, UvScaleIsMetresPerTextureUnitOfTheRestPattern) {
  // A 0.4 m square in two triangles, texture coordinates 0..1.
  write("square.obj",
        "v 0 0 0\nv 0.4 0 0\nv 0.4 0.4 0\nv 0 0.4 0\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
        "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n");
  nlohmann::json j = base_scene();
  j["cloth"]["mesh"] = {{"obj", "square.obj"}};
  double strained = 0, unstrained = 0;
  for (double scale : {1.0, 0.4, 2.5}) {
    if (scale != 1.0) j["cloth"]["mesh"]["uv_scale"] = scale;
    Simulation sim(parse(j, folder_.string()));
    const ClothModel& m = sim.core().model();
    const Vec2 uv[4] = {Vec2(0, 0), Vec2(1, 0), Vec2(1, 1), Vec2(0, 1)};
    for (int i = 0; i < 4; ++i) EXPECT_LT((m.mesh.pattern[i] - scale * uv[i]).norm(), 1e-15) << "scale " << scale;
    // The rest area, hence the mass, follows the pattern; the cloth is unstrained only when
    // the pattern is the shape (0.4 m per unit).
    EXPECT_NEAR(m.mass.sum(), scale * scale * m.materials.front().surface_density_kg_m2, 1e-12) << "scale " << scale;
    (scale == 0.4 ? unstrained : strained) = std::max(scale == 0.4 ? unstrained : strained, sim.energies().elastic);
  }
  // Not zero: the OBJ reader keeps single-precision coordinates.
  EXPECT_LT(unstrained, 1e-9 * strained);
}

TEST_F(SceneKeys, AnObjWithoutTextureCoordinatesGetsItsShapeAsThePattern) {
  // A flat, irregular 3 x 3 vertex piece in a tilted plane: projected on its best-fit plane,
  // the pattern keeps every distance: the piece is its own rest shape.
  const Vec3 e1 = Vec3(1, 0.2, 0.5).normalized();
  const Vec3 e2 = e1.cross(Vec3(0.1, 1, -0.3)).normalized();
  const double u[3] = {0, 0.13, 0.31}, v[3] = {0, 0.17, 0.29};
  std::string obj;
  std::vector<Vec3> points;
  for (int b = 0; b < 3; ++b)
    for (int a = 0; a < 3; ++a) {
      const Vec3 p = Vec3(0.2, 1.0, -0.4) + (u[a] + 0.02 * b) * e1 + v[b] * e2;
      points.push_back(p);
      char line[120];
      std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", p.x(), p.y(), p.z());
      obj += line;
    }
  for (int b = 0; b < 2; ++b)
    for (int a = 0; a < 2; ++a) {
      const int k = 3 * b + a + 1;
      obj += "f " + std::to_string(k) + " " + std::to_string(k + 1) + " " + std::to_string(k + 4) + "\n";
      obj += "f " + std::to_string(k) + " " + std::to_string(k + 4) + " " + std::to_string(k + 3) + "\n";
    }
  write("tilted.obj", obj);
  nlohmann::json j = base_scene();
  j["cloth"]["mesh"] = {{"obj", "tilted.obj"}};
  const TriMesh mesh = build_cloth_mesh(parse(j, folder_.string()).cloth);
  ASSERT_EQ(mesh.num_vertices(), 9);
  // The OBJ reader keeps single-precision coordinates: a plane to about 1e-8 m.
  for (int a = 0; a < 9; ++a) {
    EXPECT_LT((Vec3(mesh.positions.row(a).transpose()) - points[a]).norm(), 1e-6);
    for (int b = a + 1; b < 9; ++b) {
      const double d = (mesh.positions.row(a) - mesh.positions.row(b)).norm();
      EXPECT_NEAR((mesh.pattern[a] - mesh.pattern[b]).norm(), d, 1e-6 * d) << a << "-" << b;
    }
  }
}

TEST_F(SceneKeys, GridPinsReachEveryNodeAndNoFurther) {
  nlohmann::json j = base_scene();  // 5 x 3 vertices; vertex (i, j) is j * 5 + i
  j["cloth"]["pins"] = {{"grid", {{4, 2}, {-5, -3}, {-1, 0}}}};
  const Scene s = parse(j);
  const std::vector<int> pins = resolve_pins(s.cloth, build_cloth_mesh(s.cloth));
  EXPECT_EQ(pins, (std::vector<int>{14, 0, 4}));
  for (const char* node : {"[5, 0]", "[0, 3]", "[-6, 0]", "[0, -4]"}) {
    j["cloth"]["pins"] = {{"grid", {nlohmann::json::parse(node)}}};
    const std::string message = parse_error(j);
    EXPECT_NE(message.find("cloth.pins.grid"), std::string::npos) << node << ": " << message;
    EXPECT_NE(message.find("outside the 5 x 3 grid"), std::string::npos) << node << ": " << message;
  }
}

TEST_F(SceneKeys, VertexPinsReachTheLastVertexAndNoFurther) {
  nlohmann::json j = base_scene();
  j["cloth"]["pins"] = {{"vertices", {14}}};
  Scene s = parse(j);
  EXPECT_EQ(resolve_pins(s.cloth, build_cloth_mesh(s.cloth)), std::vector<int>{14});
  j["cloth"]["pins"] = {{"vertices", {15}}};
  s = parse(j);
  try {
    resolve_pins(s.cloth, build_cloth_mesh(s.cloth));
    ADD_FAILURE() << "vertex 15 of 15 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("vertex 15 does not exist (the mesh has 15 vertices)"), std::string::npos)
        << e.what();
  }
}

TEST_F(SceneKeys, DampingRatioIsAcceptedUpToTenAndNoFurther) {
  nlohmann::json j = base_scene();
  j["damping"] = {{"ratio", 10}};
  EXPECT_EQ(parse(j).effective_damping_ratio(), 10.0);
  j["damping"]["ratio"] = 10.5;
  const std::string message = parse_error(j);
  EXPECT_NE(message.find("key damping.ratio: value 10.5 is out of range [0.0, 10.0]"), std::string::npos) << message;
  // An override (weft run --damping) is checked against the same range.
  j["damping"]["ratio"] = 0.05;
  Scene s = parse(j);
  s.damping_ratio = 10.5;
  EXPECT_THROW(validate_timing(s, "override"), InputError);
  s.damping_ratio = 10.0;
  EXPECT_NO_THROW(validate_timing(s, "override"));
}

TEST_F(SceneKeys, IntegratorKeysReachTheIntegrator) {
  nlohmann::json j = base_scene();
  j["description"] = "keys";
  j["gravity"] = {1.0, -3.0, 0.5};
  j["integrator"] = {{"method", "bdf2-alpha"}, {"alpha", 0.7},           {"dt", 0.005},
                     {"tolerance", 1e-7},      {"max_iterations", 321}, {"preconditioner", "block-jacobi"}};
  Simulation sim(parse(j));
  const IntegratorSettings& st = sim.core().integrator().settings();
  EXPECT_EQ(sim.scene().description, "keys");
  EXPECT_EQ(sim.core().model().gravity, Vec3(1.0, -3.0, 0.5));
  EXPECT_EQ(st.method, Method::kBdf2);
  EXPECT_EQ(st.alpha, 0.7);
  EXPECT_EQ(st.dt, 0.005);
  EXPECT_EQ(st.cg_tolerance, 1e-7);
  EXPECT_EQ(st.cg_max_iterations, 321);
  EXPECT_EQ(sim.core().integrator().preconditioner(), Preconditioner::kBlockJacobi);
  // RK45's tolerance is its local error tolerance, not the linear solve's (it has none).
  j["integrator"] = {{"method", "rk45"}, {"dt", 0.01}, {"tolerance", 1e-5}};
  const Scene rk45 = parse(j);
  EXPECT_EQ(rk45.integrator.method, Method::kRk45);
  EXPECT_EQ(rk45.integrator.error_tolerance, 1e-5);
  EXPECT_EQ(rk45.integrator.cg_tolerance, IntegratorSettings().cg_tolerance);
}

TEST_F(SceneKeys, ClothKeysChooseTheGridPatternAndTheBendingElement) {
  nlohmann::json j = base_scene();  // 5 x 3 vertices over 1 m x 0.5 m: cells 0.25 m wide
  j["patterns"] = nlohmann::json::array();
  j["cloth"]["mesh"]["grid"]["pattern"] = "shifted-rows";
  const TriMesh shifted = build_cloth_mesh(parse(j).cloth);
  EXPECT_EQ(shifted.pattern[5], Vec2(0.125, 0.25)) << "odd rows start half a cell along u";
  EXPECT_EQ(shifted.pattern[10], Vec2(0.0, 0.5));
  j["cloth"]["mesh"]["grid"]["pattern"] = "alternating-diagonals";
  EXPECT_EQ(build_cloth_mesh(parse(j).cloth).pattern[5], Vec2(0.0, 0.25));
  // The hinge element is one stencil of four vertices per interior edge; the plate element
  // fits a quadratic per edge over a wider patch.
  const auto stencils = [&](const char* model) {
    j["cloth"]["bending_model"] = model;
    Simulation sim(parse(j));
    return sim.core().model().bending;
  };
  const auto hinges = stencils("hinge"), plates = stencils("plate");
  // 4 x 2 cells, two triangles each: 30 edges (12 along u, 10 along v, 8 diagonals), 12 of
  // them on the boundary.
  ASSERT_EQ(hinges.size(), 18u);
  for (const auto& s : hinges) EXPECT_EQ(s.vertices.size(), 4u);
  ASSERT_FALSE(plates.empty());
  size_t widest = 0;
  for (const auto& s : plates) widest = std::max(widest, s.vertices.size());
  EXPECT_GT(widest, 4u);
}

TEST_F(SceneKeys, BooleanKeysOfTheNewtonRuleAndOpenSeamsTakeTrueOrFalseOnly) {
  // integrator.automatic_newton: true (the default) and false reach the integrator; anything
  // else is refused naming the key.
  nlohmann::json j = base_scene();
  j["integrator"] = {{"method", "backward-euler"}, {"dt", 0.01}};
  EXPECT_TRUE(Simulation(parse(j)).core().integrator().settings().backward_euler_newton);
  j["integrator"]["automatic_newton"] = false;
  EXPECT_FALSE(Simulation(parse(j)).core().integrator().settings().backward_euler_newton);
  j["integrator"]["automatic_newton"] = true;
  EXPECT_TRUE(Simulation(parse(j)).core().integrator().settings().backward_euler_newton);
  j["integrator"]["automatic_newton"] = "yes";
  EXPECT_NE(parse_error(j).find("automatic_newton"), std::string::npos) << parse_error(j);
  // cloth.mesh.pattern.allow_open_seams likewise (read, not sewn: parsing does not sew).
  nlohmann::json g = base_scene();
  const std::string patterns = std::string(WEFT_SOURCE_DIR) + "/data/patterns/garmentcode";
  g["cloth"]["mesh"] = {{"pattern", {{"file", patterns + "/shirt_mean_specification.json"}}}};
  g["colliders"] = nlohmann::json::array({{{"type", "body"}, {"bind_pose_hold", 0.1}}});
  const Scene closed = parse(g);
  ASSERT_TRUE(closed.cloth.garment.has_value());
  EXPECT_FALSE(closed.cloth.garment->allow_open_seams);
  g["cloth"]["mesh"]["pattern"]["allow_open_seams"] = true;
  EXPECT_TRUE(parse(g).cloth.garment->allow_open_seams);
  g["cloth"]["mesh"]["pattern"]["allow_open_seams"] = 1;
  EXPECT_NE(parse_error(g).find("allow_open_seams"), std::string::npos) << parse_error(g);
}

TEST_F(SceneKeys, ContactSolveIsActiveSetOrBoundsAndReachesTheIntegratorAndTheFingerprint) {
  nlohmann::json j = base_scene();
  j["integrator"] = {{"method", "implicit-midpoint"}, {"dt", 0.01}};
  const Simulation active(parse(j));
  EXPECT_EQ(active.core().integrator().settings().contact_solve, ContactSolve::kActiveSet);
  j["integrator"]["contact_solve"] = "bounds";
  const Simulation bounds(parse(j));
  EXPECT_EQ(bounds.core().integrator().settings().contact_solve, ContactSolve::kBounds);
  // A checkpoint of one does not resume the other: the motion differs.
  EXPECT_NE(active.fingerprint(), bounds.fingerprint());
  j["integrator"]["contact_solve"] = "active-set";
  EXPECT_EQ(Simulation(parse(j)).fingerprint(), active.fingerprint());
  j["integrator"]["contact_solve"] = "mprgp";
  EXPECT_NE(parse_error(j).find("key integrator.contact_solve: unknown contact solve 'mprgp' (expected active-set or bounds)"),
            std::string::npos)
      << parse_error(j);
}
