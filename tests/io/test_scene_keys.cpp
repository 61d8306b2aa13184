// Scene keys that are accepted must have their documented effect (docs/scene-format.md):
// initial_velocity, placement, uv_scale, the best-fit-plane pattern of an OBJ without
// texture coordinates, the ranges of pins and the damping ratio at their edges, and the contact
// tunables (ContactKeys).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "collision/colliders.hpp"
#include "collision/self_contact.hpp"
#include "sim/model_data.hpp"
#include "sim/simulation_core.hpp"
#include "support/command.hpp"
#include "weft/error.hpp"

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
  // cloth.mesh.pattern.sewing_step_limit: absent the sewing's default, 0 none, else metres in (0, 1].
  g["cloth"]["mesh"]["pattern"].erase("allow_open_seams");
  EXPECT_FALSE(parse(g).cloth.garment->sewing_step_limit_m.has_value());
  g["cloth"]["mesh"]["pattern"]["sewing_step_limit"] = 0;
  EXPECT_EQ(parse(g).cloth.garment->sewing_step_limit_m, 0.0);
  g["cloth"]["mesh"]["pattern"]["sewing_step_limit"] = 0.05;
  EXPECT_EQ(parse(g).cloth.garment->sewing_step_limit_m, 0.05);
  g["cloth"]["mesh"]["pattern"]["sewing_step_limit"] = -0.01;
  EXPECT_NE(parse_error(g).find("sewing_step_limit"), std::string::npos) << parse_error(g);
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

// The contact tunables as scene keys (`contacts`, and the integrator's max_step_halvings and
// runaway_energy_factor): each read at the edges of its range and refused beyond with a message
// naming the key and the value, each reaching the handler or the check that reads it, and those
// that change the motion in the checkpoint fingerprint.
namespace {

// A sheet over a sphere, self-collision on: both contact handlers are built.
nlohmann::json contact_scene() {
  return nlohmann::json::parse(R"({
    "weft_scene": 1, "duration": 0.05, "frame_interval": 0.01,
    "integrator": {"method": "implicit-midpoint", "dt": 0.01},
    "cloth": {"mesh": {"grid": {"size": [0.4, 0.4], "vertices": [5, 5]}},
              "placement": {"rotation_deg": [-90, 0, 0], "translation": [-0.2, 0.35, 0.2]}},
    "colliders": [{"type": "sphere", "centre": [0, 0.1, 0], "radius": 0.2}]
  })");
}

struct Key {
  const char* group;  ///< "contacts" or "integrator"
  const char* name;
  nlohmann::json low, high;            ///< the range's edges (accepted; low too where closed)
  bool open_low;
  nlohmann::json below, above;         ///< just beyond them (refused)
  const char* range;                   ///< as the message writes it
  nlohmann::json changed;              ///< a value other than the default
  std::function<double(const Scene&)> field;
  bool motion;                         ///< changes the motion (so the fingerprint)
};

std::vector<Key> keys() {
  return {
      {"contacts", "hold_margin", 1, 3, false, 0.99, 3.01, "[1.0, 3.0]", 2.0,
       [](const Scene& s) { return s.contacts.hold_margin; }, true},
      {"contacts", "held_rest_speed", 0, 10, false, -0.01, 10.5, "[0.0, 10.0]", 0.3,
       [](const Scene& s) { return s.contacts.held_rest_speed; }, true},
      {"contacts", "self_passes", 0, 100, false, -1, 101, "[0, 100]", 2,
       [](const Scene& s) { return s.contacts.self_passes; }, true},
      {"contacts", "self_zone_rounds", 0, 100, false, -1, 101, "[0, 100]", 3,
       [](const Scene& s) { return s.contacts.self_zone_rounds; }, true},
      {"contacts", "self_repulsion_time", 0, 10, true, 0.0, 10.5, "(0.0, 10.0]", 0.2,
       [](const Scene& s) { return s.contacts.self_repulsion_time; }, true},
      {"contacts", "self_hold_reach", 1, 3, false, 0.99, 3.01, "[1.0, 3.0]", 1.5,
       [](const Scene& s) { return s.contacts.self_hold_reach; }, true},
      {"contacts", "self_hold_reach_speed", 0, 10, false, -0.01, 10.5, "[0.0, 10.0]", 0.1,
       [](const Scene& s) { return s.contacts.self_hold_reach_speed; }, true},
      {"contacts", "fail_safe_energy_factor", 0, 1e6, true, 0.0, 2e6, "(0.0, 1000000.0]", 10.0,
       [](const Scene& s) { return s.contacts.fail_safe_energy_factor; }, false},
      {"integrator", "max_step_halvings", 0, 10, false, -1, 11, "[0, 10]", 5,
       [](const Scene& s) { return s.integrator.max_step_halvings; }, true},
      {"integrator", "runaway_energy_factor", 1, 1e9, true, 1.0, 2e9, "(1.0, 1000000000.0]", 50.0,
       [](const Scene& s) { return s.integrator.runaway_energy_factor; }, false},
  };
}

}  // namespace

TEST(ContactKeys, EachIsReadAtTheEdgesOfItsRangeAndRefusedBeyondThemNamingTheKeyAndValue) {
  for (const Key& k : keys()) {
    SCOPED_TRACE(k.name);
    nlohmann::json j = contact_scene();
    j[k.group][k.name] = k.high;
    EXPECT_EQ(k.field(parse(j)), k.high.get<double>());
    if (!k.open_low) {
      j[k.group][k.name] = k.low;
      EXPECT_EQ(k.field(parse(j)), k.low.get<double>());
    }
    for (const nlohmann::json& bad : {k.below, k.above}) {
      j[k.group][k.name] = bad;
      const std::string expected = std::string("scene.json: key ") + k.group + "." + k.name + ": value " + bad.dump() +
                                   " is out of range " + k.range;
      EXPECT_NE(parse_error(j).find(expected), std::string::npos) << parse_error(j) << "\nexpected: " << expected;
    }
  }
  nlohmann::json j = contact_scene();
  j["contacts"]["hold_margins"] = 1.1;
  EXPECT_NE(parse_error(j).find("hold_margins"), std::string::npos) << parse_error(j);
}

TEST(ContactKeys, TheDefaultsAreTheSettingsDefaultsAndWrittenOutGiveTheSameFingerprint) {
  const Scene plain = parse(contact_scene());
  const ContactSettings d;
  EXPECT_EQ(plain.contacts.hold_margin, d.hold_margin);
  EXPECT_EQ(plain.contacts.self_passes, d.self_passes);
  nlohmann::json j = contact_scene();
  j["contacts"] = {{"hold_margin", d.hold_margin},
                   {"held_rest_speed", d.held_rest_speed},
                   {"self_passes", d.self_passes},
                   {"self_zone_rounds", d.self_zone_rounds},
                   {"self_repulsion_time", d.self_repulsion_time},
                   {"self_hold_reach", d.self_hold_reach},
                   {"self_hold_reach_speed", d.self_hold_reach_speed},
                   {"fail_safe_energy_factor", d.fail_safe_energy_factor}};
  j["integrator"]["max_step_halvings"] = IntegratorSettings{}.max_step_halvings;
  j["integrator"]["runaway_energy_factor"] = IntegratorSettings{}.runaway_energy_factor;
  EXPECT_EQ(Simulation(parse(j)).fingerprint(), Simulation(plain).fingerprint());
}

TEST(ContactKeys, EachReachesTheCodeThatReadsItAndThoseThatChangeTheMotionTheFingerprint) {
  const Simulation plain(parse(contact_scene()));
  for (const Key& k : keys()) {
    SCOPED_TRACE(k.name);
    nlohmann::json j = contact_scene();
    j[k.group][k.name] = k.changed;
    const Simulation sim(parse(j));
    const double value = k.changed.get<double>();
    const SimulationData& data = sim.core().simulation_data();
    ASSERT_NE(data.contacts, nullptr);
    ASSERT_NE(data.self_contacts, nullptr);
    const ContactSettings& colliders = data.contacts->tunables();
    const ContactSettings& self = data.self_contacts->tunables();
    const std::string name = k.name;
    // Read back from the handler, the integrator or the scene the run's checks read.
    if (name == "hold_margin") EXPECT_EQ(colliders.hold_margin, value);
    if (name == "held_rest_speed") EXPECT_EQ(self.held_rest_speed, value);
    if (name == "self_passes") EXPECT_EQ(self.self_passes, value);
    if (name == "self_zone_rounds") EXPECT_EQ(self.self_zone_rounds, value);
    if (name == "self_repulsion_time") EXPECT_EQ(self.self_repulsion_time, value);
    if (name == "self_hold_reach") EXPECT_EQ(self.self_hold_reach, value);
    if (name == "self_hold_reach_speed") EXPECT_EQ(self.self_hold_reach_speed, value);
    if (name == "fail_safe_energy_factor") EXPECT_EQ(sim.scene().contacts.fail_safe_energy_factor, value);
    if (name == "max_step_halvings") EXPECT_EQ(sim.core().integrator().settings().max_step_halvings, value);
    if (name == "runaway_energy_factor") EXPECT_EQ(sim.scene().integrator.runaway_energy_factor, value);
    // A checkpoint made with one value resumes under another only where the motion is the same.
    if (k.motion) {
      EXPECT_NE(sim.fingerprint(), plain.fingerprint());
    } else {
      EXPECT_EQ(sim.fingerprint(), plain.fingerprint());
    }
  }
}

TEST(ContactKeys, ALongerRepulsionTimePushesLayersApartMoreSlowly) {
  // Two parallel triangles 1 mm apart, within the 3 mm thickness: the upper one's nodes are
  // held against the lower face and pushed out over the repulsion time, so the push per step
  // (each step the missing thickness times dt over it) is inversely proportional to it.
  const std::vector<std::array<int, 3>> triangles = {{0, 1, 2}, {3, 4, 5}};
  VecX x(18);
  const double up = 0.001;
  const Vec3 corners[3] = {Vec3(0, 0, 0), Vec3(0.1, 0, 0), Vec3(0, 0, -0.1)};
  for (int k = 0; k < 3; ++k) {
    node(x, k) = corners[k];
    node(x, 3 + k) = corners[k] * 0.3 + Vec3(0.01, up, -0.01);
  }
  const VecX mass = VecX::Constant(6, 1e-3);
  const double dt = 0.005, thickness = 0.003;
  const auto push = [&](double repulsion_time) {
    SelfContacts self(triangles, x, mass, std::vector<char>(6, 0), thickness, 0.3);
    ContactSettings t;
    t.self_repulsion_time = repulsion_time;
    self.set_tunables(t);
    std::vector<NodeContact> out;
    self.detect(x, VecX::Zero(18), 0, dt, out);
    double largest = 0;
    for (const NodeContact& c : out) largest = std::max(largest, std::abs(c.normal_displacement));
    return largest;
  };
  const double quick = push(0.05), slow = push(0.2);
  ASSERT_GT(quick, 0) << "the layers are held and pushed apart";
  EXPECT_NEAR(slow, quick * 0.05 / 0.2, 1e-12 * quick);
}
