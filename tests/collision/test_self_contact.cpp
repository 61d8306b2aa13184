// Cloth-cloth contact (docs/collisions.md, "Self-collision"): sheets meeting head-on end every
// step untangled, the impulses keep momentum and add no kinetic energy, a pair within the
// thickness stops approaching, and a scene with self-contact has no intersection in any frame.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "collision/intersections.hpp"
#include "collision/self_contact.hpp"
#include "sim/simulation_core.hpp"
#include "weft/threads.hpp"

using namespace weft;

namespace {

constexpr double kThickness = 0.003;

// Sheets of n x n vertices and side `size` in horizontal planes at the heights given, each a
// separate piece of one mesh (as a multi-piece cloth OBJ is).
struct Sheets {
  std::vector<std::array<int, 3>> triangles;
  VecX x;
  int per_sheet = 0;
};

Sheets sheets(int n, double size, const std::vector<double>& heights) {
  Sheets s;
  s.per_sheet = n * n;
  s.x.resize(3 * n * n * static_cast<Eigen::Index>(heights.size()));
  for (size_t k = 0; k < heights.size(); ++k) {
    const int base = static_cast<int>(k) * n * n;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        node(s.x, base + j * n + i) = Vec3(size * i / (n - 1) - 0.5 * size, heights[k], size * j / (n - 1) - 0.5 * size);
    for (int j = 0; j + 1 < n; ++j)
      for (int i = 0; i + 1 < n; ++i) {
        const int a = base + j * n + i, b = a + 1, c = a + n, d = c + 1;
        s.triangles.push_back({a, b, d});
        s.triangles.push_back({a, d, c});
      }
  }
  return s;
}

// The floor: the plane y = 0, the cloth's thickness, friction 0.5.
ColliderSpec floor_plane() {
  ColliderSpec floor;
  floor.shape = ColliderShape::kPlane;
  floor.name = "floor";
  floor.thickness = kThickness;
  floor.friction = 0.5;
  return floor;
}

// The sheets as a cloth mesh (pattern coordinates from x and z).
std::shared_ptr<const TriMesh> as_mesh(const Sheets& sheets) {
  auto mesh = std::make_shared<TriMesh>();
  mesh->positions.resize(sheets.x.size() / 3, 3);
  for (int i = 0; i < mesh->num_vertices(); ++i) {
    mesh->positions.row(i) = node(sheets.x, i).transpose();
    mesh->pattern.emplace_back(node(sheets.x, i).x(), node(sheets.x, i).z());
  }
  mesh->triangles = sheets.triangles;
  return mesh;
}

// A scene of that cloth (a linear material, self-collision at kThickness with this friction)
// over the floor, stepped by `method` at 5 ms.
Scene on_the_floor(const std::shared_ptr<const TriMesh>& mesh, const char* method, double friction) {
  Scene s;
  s.cloth.mesh = mesh;
  s.cloth.material.weft = StressCurve::linear(200);
  s.cloth.material.warp = StressCurve::linear(200);
  s.cloth.material.shear = StressCurve::linear(20);
  s.cloth.thickness = kThickness;
  s.cloth.friction = friction;
  s.cloth.self_collision = true;
  set_method(s, method, std::nullopt, "test");
  s.integrator.dt = 0.005;
  s.colliders.push_back(floor_plane());
  return s;
}

double kinetic(const VecX& mass, const VecX& v) {
  double e = 0;
  for (Eigen::Index i = 0; i < mass.size(); ++i) e += 0.5 * mass[i] * node(v, static_cast<int>(i)).squaredNorm();
  return e;
}

Vec3 momentum(const VecX& mass, const VecX& v) {
  Vec3 p = Vec3::Zero();
  for (Eigen::Index i = 0; i < mass.size(); ++i) p += mass[i] * node(v, static_cast<int>(i));
  return p;
}

// Velocities of two sheets flying at each other at `speed` each, with a random part of a
// tenth of it (the same numbers on every machine: the generator is specified by the standard
// and the numbers are made from its integers).
VecX head_on(const Sheets& s, double speed, unsigned seed) {
  std::mt19937 rng(seed);
  auto unit = [&] { return static_cast<double>(rng()) / 4294967295.0 * 2 - 1; };
  VecX v(s.x.size());
  for (int i = 0; i < static_cast<int>(s.x.size() / 3); ++i) {
    const double towards = i < s.per_sheet ? speed : -speed;
    node(v, i) = Vec3(0.1 * speed * unit(), towards + 0.1 * speed * unit(), 0.1 * speed * unit());
  }
  return v;
}

}  // namespace

TEST(SelfContact, SheetsMeetingHeadOnAt10MetresASecondNeverIntersect) {
  // Two 9 x 9 sheets 1 cm apart closing at 10 m/s (5 m/s each) with 5 ms steps: 5 cm per step,
  // straight through each other without the fail-safe. Free flight otherwise.
  for (unsigned seed : {1u, 2u, 3u}) {
    Sheets s = sheets(9, 0.2, {0.0, 0.01});
    const int n = static_cast<int>(s.x.size() / 3);
    const VecX mass = VecX::Constant(n, 1e-3);
    const std::vector<char> fixed(n, 0);
    SelfContacts self(s.triangles, s.x, mass, fixed, kThickness, 0.3);
    VecX x0 = s.x, v = head_on(s, 5.0, seed);
    const double dt = 0.005;
    ASSERT_EQ(self_intersections(x0.data(), s.triangles).count, 0u);
    long moved = 0;
    for (int step = 0; step < 10; ++step) {
      VecX x1 = x0 + dt * v;
      ContactReport report;
      self.finish_step(x0, x1, v, step * dt, dt, report);
      moved += report.fail_safe_moves;
      ASSERT_EQ(self_intersections(x1.data(), s.triangles).count, 0u) << "seed " << seed << ", step " << step;
      ASSERT_TRUE(report.ok || self.statistics().failed_steps > 0);
      x0 = x1;
    }
    EXPECT_GT(moved, 0) << "the sheets should have needed the fail-safe";
    EXPECT_GT(self.statistics().collision_impulses, 0);
  }
}

TEST(SelfContact, ImpulsesKeepMomentumAndAddNoKineticEnergy) {
  for (double friction : {0.0, 0.5}) {
    Sheets s = sheets(7, 0.1, {0.0, 0.02});
    const int n = static_cast<int>(s.x.size() / 3);
    VecX mass(n);
    for (int i = 0; i < n; ++i) mass[i] = 1e-3 * (1 + 0.5 * (i % 3));  // unequal masses
    const std::vector<char> fixed(n, 0);
    SelfContacts self(s.triangles, s.x, mass, fixed, kThickness, friction);
    const VecX v0 = head_on(s, 4.0, 7);
    const double dt = 0.01;  // 4 cm each way: they meet within the step
    VecX x1 = s.x + dt * v0, v1 = v0;
    ContactReport report;
    self.finish_step(s.x, x1, v1, 0, dt, report);
    ASSERT_GT(report.fail_safe_moves, 0);
    const VecX u = (x1 - s.x) / dt;
    const Vec3 p0 = momentum(mass, v0);
    const double scale = mass.sum() * 4.0;
    EXPECT_LT((momentum(mass, u) - p0).norm(), 1e-12 * scale) << "friction " << friction;
    EXPECT_LT((momentum(mass, v1) - p0).norm(), 1e-12 * scale);
    // The sheets started farther apart than the thickness: nothing pushes, everything only
    // takes relative motion away (inelastic impulses, friction, rigid zones).
    EXPECT_LE(kinetic(mass, u), kinetic(mass, v0) * (1 + 1e-12)) << "friction " << friction;
    EXPECT_NEAR(report.work, kinetic(mass, v1) - kinetic(mass, v0), 1e-12 * kinetic(mass, v0));
    EXPECT_LE(report.work, 0.0);
    EXPECT_EQ(self_intersections(x1.data(), s.triangles).count, 0u);
  }
}

TEST(SelfContact, NodesHeldAgainstAColliderArePushedIntoItByAtMostTheirRoom) {
  // A large triangle held against a collider below it (normal +y), carried up by it at
  // 0.35 m/s, under a heavy small triangle 2.5 mm above (thickness 3 mm): the repulsion gives
  // the light held face most of the change, which would push it 1.4 mm back down in the step.
  // Told the collider's normal, the fail-safe moves it down by at most kHeldInwardRoom times
  // the thickness.
  std::vector<std::array<int, 3>> triangles = {{0, 1, 2}, {3, 4, 5}};
  VecX x0(18);
  node(x0, 0) = Vec3(-0.1, 0, -0.1);
  node(x0, 1) = Vec3(0.1, 0, -0.1);
  node(x0, 2) = Vec3(0, 0, 0.1);
  node(x0, 3) = Vec3(0, 0.0025, -0.03);
  node(x0, 4) = Vec3(0.01, 0.0025, -0.03);
  node(x0, 5) = Vec3(0, 0.0025, -0.02);
  VecX mass(6);
  mass << 1e-3, 1e-3, 1e-3, 1e-2, 1e-2, 1e-2;
  const std::vector<char> fixed(6, 0);
  const std::vector<char> held = {1, 1, 1, 0, 0, 0};
  const std::vector<Vec3> normals = {Vec3::UnitY(), Vec3::UnitY(), Vec3::UnitY(), Vec3::Zero(), Vec3::Zero(),
                                     Vec3::Zero()};
  const double dt = 0.005, rise = 0.35;
  auto run = [&](bool with_normals, VecX& x1) {
    SelfContacts self(triangles, x0, mass, fixed, kThickness, 0.0);
    self.set_held_nodes(&held, with_normals ? &normals : nullptr);
    VecX v = VecX::Zero(18);
    for (int i = 0; i < 3; ++i) node(v, i) = Vec3(0, rise, 0);
    x1 = x0 + dt * v;
    ContactReport report;
    self.finish_step(x0, x1, v, 0, dt, report);
    EXPECT_GT(report.fail_safe_moves, 0);
  };
  VecX free_x1, held_x1;
  run(false, free_x1);
  run(true, held_x1);
  const double room = kHeldInwardRoom * kThickness;
  for (int i = 0; i < 3; ++i) {
    SCOPED_TRACE(i);
    const double carried = node(x0, i).y() + dt * rise;  // where the collider put it
    EXPECT_LT(node(free_x1, i).y(), carried - 1e-3) << "without the normals the repulsion pushes it down";
    EXPECT_GE(node(held_x1, i).y(), carried - room - 1e-12);
    EXPECT_LT(node(held_x1, i).y(), carried) << "its room is used";
  }
  // The layer above is pushed up at least as much as without the normals.
  for (int i = 3; i < 6; ++i) EXPECT_GE(node(held_x1, i).y(), node(free_x1, i).y() - 1e-15);
  EXPECT_EQ(self_intersections(held_x1.data(), triangles).count, 0u);
}

TEST(SelfContact, APairWithinTheThicknessStopsApproachingAndIsPushedOut) {
  // A small triangle 2 mm above a large pinned one (thickness 3 mm), sinking at 0.1 m/s: 0.5 mm
  // in the step, not enough to reach it, but within the thickness it must stop approaching.
  std::vector<std::array<int, 3>> triangles = {{0, 1, 2}, {3, 4, 5}};
  VecX x0(18);
  node(x0, 0) = Vec3(-0.1, 0, -0.1);
  node(x0, 1) = Vec3(0.1, 0, -0.1);
  node(x0, 2) = Vec3(0, 0, 0.1);
  node(x0, 3) = Vec3(0, 0.002, 0);
  node(x0, 4) = Vec3(0.01, 0.002, 0);
  node(x0, 5) = Vec3(0, 0.002, 0.01);
  const VecX mass = VecX::Constant(6, 1e-3);
  const std::vector<char> fixed = {1, 1, 1, 0, 0, 0};
  SelfContacts self(triangles, x0, mass, fixed, kThickness, 0.3);
  VecX v = VecX::Zero(18);
  for (int i = 3; i < 6; ++i) node(v, i) = Vec3(0.05, -0.1, 0);
  const double dt = 0.005;
  VecX x1 = x0 + dt * v;
  for (int i = 0; i < 3; ++i) node(x1, i) = node(x0, i);
  ContactReport report;
  self.finish_step(x0, x1, v, 0, dt, report);
  for (int i = 3; i < 6; ++i) {
    SCOPED_TRACE(i);
    EXPECT_GT(node(x1, i).y(), node(x0, i).y()) << "pushed towards the thickness, not approaching";
    EXPECT_LE(node(x1, i).y(), kThickness) << "by a share of the missing thickness, not beyond it";
    // The velocity changed as the step's displacement did.
    // The velocity changed as the step's mean velocity did (here both start equal).
    EXPECT_NEAR((node(v, i) - (node(x1, i) - node(x0, i)) / dt).norm(), 0, 1e-9);
    // Friction took some sliding away, without reversing it.
    EXPECT_LT(node(v, i).x(), 0.05);
    EXPECT_GE(node(v, i).x(), 0.0);
  }
  for (int i = 0; i < 3; ++i) EXPECT_EQ(node(x1, i), node(x0, i)) << "pinned nodes do not move";
  EXPECT_GT(self.statistics().repulsions, 0);
}

TEST(SelfContact, ALightNodeCarryingLittleOfAPairOfStillNodesIsNotLeveredByTheRepulsions) {
  // Edge 3-4 crosses the pinned edge 0-1, 2 mm above it, a twentieth of the way from node 3:
  // node 3 is pinned too, node 4 (carrying 5% of the crossing point) comes down at 0.1 m/s.
  // Restoring that pair's thickness by moving node 4 alone would take twenty times the change
  // (pair after pair, sweep after sweep); the repulsions leave it alone, and as continuous
  // detection finds no collision in the step, node 4 ends it as the solve left it.
  std::vector<std::array<int, 3>> triangles = {{0, 1, 2}, {3, 4, 5}};
  VecX x0(18);
  node(x0, 0) = Vec3(-0.05, 0, 0);
  node(x0, 1) = Vec3(0.05, 0, 0);
  node(x0, 2) = Vec3(0, 0, -0.05);
  node(x0, 3) = Vec3(0, 0.002, -0.001);
  node(x0, 4) = Vec3(0, 0.002, 0.019);
  node(x0, 5) = Vec3(0.05, 0.05, 0.01);
  const std::vector<char> fixed = {1, 1, 1, 1, 0, 1};
  SelfContacts self(triangles, x0, VecX::Constant(6, 1e-3), fixed, kThickness, 0.3);
  VecX v = VecX::Zero(18);
  node(v, 4) = Vec3(0, -0.1, 0);
  const double dt = 0.005;
  VecX x1 = x0 + dt * v;
  const VecX x1_solve = x1, v_solve = v;
  ContactReport report;
  self.finish_step(x0, x1, v, 0, dt, report);
  EXPECT_EQ(node(x1, 4), node(x1_solve, 4));
  EXPECT_EQ(node(v, 4), node(v_solve, 4));
  EXPECT_EQ(self.statistics().repulsions, 0);
  EXPECT_TRUE(report.ok);
}

TEST(SelfContact, NodesOutOfContactKeepTheirBits) {
  Sheets s = sheets(5, 0.1, {0.0, 0.5});
  const int n = static_cast<int>(s.x.size() / 3);
  const VecX mass = VecX::Constant(n, 1e-3);
  SelfContacts self(s.triangles, s.x, mass, std::vector<char>(n, 0), kThickness, 0.3);
  const VecX v0 = head_on(s, 0.3, 5);
  VecX x1 = s.x + 0.01 * v0, v1 = v0;
  const VecX x1_before = x1;
  ContactReport report;
  self.finish_step(s.x, x1, v1, 0, 0.01, report);
  EXPECT_EQ(report.fail_safe_moves, 0);
  EXPECT_EQ(report.work, 0.0);
  EXPECT_TRUE(x1 == x1_before);
  EXPECT_TRUE(v1 == v0);
}

TEST(SelfContact, ASheetDrapedOverASphereNeverIntersectsItself) {
  // A 0.6 m sheet at 17 x 17 falling on a sphere of radius 0.15 m: its corners fall past the
  // sphere and fold against each other and the sheet's sides.
  Scene s;
  s.cloth.grid = GridSpec{0.6, 0.6, 17, 17};
  s.cloth.rotation_deg = Vec3(-90, 0, 0);
  s.cloth.translation = Vec3(-0.3, 0.35, 0.3);
  s.cloth.material = material_preset("cotton");
  s.cloth.self_collision = true;
  set_method(s, "bdf2", std::nullopt, "test");
  s.integrator.dt = 0.005;
  s.frame_interval = 0.02;
  s.duration = 1.0;
  ColliderSpec ball;
  ball.shape = ColliderShape::kSphere;
  ball.name = "sphere";
  ball.centre = Vec3(0, 0.15, 0);
  ball.radius = 0.15;
  ball.thickness = kThickness;
  ball.friction = 0.3;
  s.colliders.push_back(ball);
  s.colliders.push_back(floor_plane());
  Simulation sim(s);
  ASSERT_NE(sim.core().self_contacts(), nullptr);
  int frames = 0;
  RunCallbacks callbacks;
  callbacks.on_frame = [&](int frame, const Simulation& sm) {
    ++frames;
    EXPECT_EQ(self_intersections(sm.core().state().x.data(), sm.core().model().mesh.triangles).count, 0u) << "frame " << frame;
  };
  const RunResult r = run_simulation(sim, callbacks);
  ASSERT_EQ(r.status, "ok") << r.message;
  EXPECT_EQ(frames, 51);
  EXPECT_GT(sim.core().self_contacts()->statistics().repulsions + sim.core().self_contacts()->statistics().collision_impulses, 0)
      << "the folds should have met";
}

TEST(SelfContact, StackedSheetsSceneLandsOnTheBoxWithNoSelfIntersectionInAnyFrame) {
  // scenes/stacked-sheets.json (five sheets of 21 x 21 in one OBJ) through the first 0.4 s:
  // the layers land on the box and on each other.
  Scene s = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/stacked-sheets.json");
  ASSERT_TRUE(s.cloth.self_collision);
  s.duration = 0.4;
  Simulation sim(s);
  RunCallbacks callbacks;
  callbacks.on_frame = [&](int frame, const Simulation& sm) {
    EXPECT_EQ(self_intersections(sm.core().state().x.data(), sm.core().model().mesh.triangles).count, 0u) << "frame " << frame;
  };
  const RunResult r = run_simulation(sim, callbacks);
  ASSERT_EQ(r.status, "ok") << r.message;
  EXPECT_GT(sim.core().self_contacts()->statistics().collision_impulses, 0) << "the layers should have met";
}

TEST(SelfContact, TheSameBitsOnOneThreadAndOnTwo) {
  // Detection runs its candidate pairs in chunks on every thread allowed; the pairs found, and
  // so the contacts, impulses and positions, must not depend on how many. Two 25 x 25 sheets
  // 2 mm apart (within the thickness: many proximities) closing at 2 m/s: thousands of
  // candidate pairs, many chunks.
  Sheets s = sheets(25, 0.3, {0.0, 0.002});
  const int n = static_cast<int>(s.x.size() / 3);
  const VecX mass = VecX::Constant(n, 1e-3);
  const std::vector<char> fixed(n, 0);
  struct Outcome {
    VecX x, v;
    std::vector<NodeContact> contacts;
    long impulses = 0;
  };
  auto run = [&](int threads) {
    set_thread_count(threads);
    SelfContacts self(s.triangles, s.x, mass, fixed, kThickness, 0.3);
    Outcome o;
    o.x = s.x;
    o.v = head_on(s, 1.0, 7);
    const double dt = 0.005;
    for (int step = 0; step < 5; ++step) {
      o.contacts.clear();
      self.detect(o.x, o.v, step * dt, dt, o.contacts);
      VecX x1 = o.x + dt * o.v;
      ContactReport report;
      self.finish_step(o.x, x1, o.v, step * dt, dt, report);
      o.x = x1;
    }
    o.impulses = self.statistics().repulsions + self.statistics().collision_impulses;
    return o;
  };
  const Outcome one = run(1), two = run(2);
  set_thread_count(0);
  ASSERT_GT(one.impulses, 100) << "the case must exercise the detection";
  EXPECT_EQ(one.impulses, two.impulses);
  EXPECT_TRUE(one.x == two.x) << "positions differ";
  EXPECT_TRUE(one.v == two.v) << "velocities differ";
  ASSERT_EQ(one.contacts.size(), two.contacts.size());
  ASSERT_GT(one.contacts.size(), 0u);
  for (size_t k = 0; k < one.contacts.size(); ++k) {
    EXPECT_EQ(one.contacts[k].node, two.contacts[k].node);
    EXPECT_TRUE(one.contacts[k].normal == two.contacts[k].normal);
  }
}

TEST(SelfContact, FinishingAStepAfterDetectingAtItsStartIsTheSameAsFinishingItAlone) {
  // detect and finish_step search the same start positions; the second search reuses the
  // first's pairs. Pairs whose closest points coincide take their normal's side from the
  // velocity of the moment (the start's in detect, the step's mean in finish_step), so a
  // reuse that kept the first normals would differ here: two sheets lying on each other
  // (touching pairs everywhere) and a third 2 mm above; they close at the start and part over
  // the step.
  Sheets s = sheets(15, 0.2, {0.0, 0.0, 0.002});
  const int n = static_cast<int>(s.x.size() / 3);
  const VecX mass = VecX::Constant(n, 1e-3);
  const std::vector<char> fixed(n, 0);
  const double dt = 0.005;
  const VecX v_start = head_on(s, 0.5, 11);
  const VecX v_mean = -head_on(s, 0.5, 12);  // the sheets part over the step
  struct Outcome {
    VecX x, v;
    SelfContactStatistics stats;
  };
  auto finish = [&](bool detect_first) {
    SelfContacts self(s.triangles, s.x, mass, fixed, kThickness, 0.3);
    if (detect_first) {
      std::vector<NodeContact> contacts;
      self.detect(s.x, v_start, 0, dt, contacts);
      EXPECT_GT(contacts.size(), 0u);
    }
    Outcome o;
    o.x = s.x + dt * v_mean;
    o.v = v_mean;
    ContactReport report;
    self.finish_step(s.x, o.x, o.v, 0, dt, report);
    o.stats = self.statistics();
    return o;
  };
  const Outcome alone = finish(false), after = finish(true);
  ASSERT_GT(alone.stats.repulsions, 100) << "the case must exercise the repulsions";
  EXPECT_EQ(alone.stats.repulsions, after.stats.repulsions);
  EXPECT_EQ(alone.stats.collision_impulses, after.stats.collision_impulses);
  EXPECT_TRUE(alone.x == after.x) << "positions differ";
  EXPECT_TRUE(alone.v == after.v) << "velocities differ";
}

namespace {

// Two triangles whose edges cross 1.4 mm apart (thickness 3 mm), each edge's ends and the
// other triangle's vertices all farther than the thickness from the other triangle: the lower
// one lies in the plane y = 0 with its edge (0, 1) along x through the origin, at x = `shift`
// +- 0.05; the upper one stands in the plane x = 0 with its edge (3, 4) on the line y = 0.002 - z,
// whose closest point to the x axis is halfway along it, (0, 0.001, 0.001): the pair's normal
// is (0, 1, 1) / sqrt(2), its gap 0.001 sqrt(2).
VecX crossing_edges(double shift) {
  VecX x(18);
  node(x, 0) = Vec3(shift - 0.05, 0, 0);
  node(x, 1) = Vec3(shift + 0.05, 0, 0);
  node(x, 2) = Vec3(0, 0, -0.05);
  node(x, 3) = Vec3(0, 0.032, -0.03);
  node(x, 4) = Vec3(0, -0.028, 0.03);
  node(x, 5) = Vec3(0, 0.062, 0.03);
  return x;
}

}  // namespace

TEST(SelfContact, CrossingEdgesWithinTheThicknessAreHeldInTheSolveFromBothSides) {
  // Edge-edge pairs have no vertex of one primitive over the other's face: unless the solve
  // holds their ends, it drives such edges together and the fail-safe pushes them apart again
  // at every step (folded cloth at rest then jitters).
  const std::vector<std::array<int, 3>> triangles = {{0, 1, 2}, {3, 4, 5}};
  const VecX mass = VecX::Constant(6, 1e-3);
  const double dt = 0.005;
  const VecX x = crossing_edges(0);
  SelfContacts self(triangles, x, mass, std::vector<char>(6, 0), kThickness, 0.3);
  // The upper edge comes down at 0.1 m/s.
  VecX v = VecX::Zero(18);
  for (int i = 3; i < 6; ++i) node(v, i) = Vec3(0, -0.1, 0);
  std::vector<NodeContact> out;
  self.detect(x, v, 0, dt, out);
  ASSERT_EQ(out.size(), 4u) << "both ends of both edges (each carries half of its edge's closest point)";
  for (const NodeContact& c : out) {
    SCOPED_TRACE(c.node);
    ASSERT_TRUE(c.node == 0 || c.node == 1 || c.node == 3 || c.node == 4);
    const bool lower = c.node < 3;
    // The normal points from the other edge to the node's.
    EXPECT_NEAR(c.normal.dot(Vec3(0, 1, 1) / std::sqrt(2.0) * (lower ? -1 : 1)), 1, 1e-12);
    // Neither side approaches the other: the lower edge does not follow the upper one coming
    // at it, and the upper one, held against the resting lower edge, is pushed back out towards
    // the thickness (over kRepulsionTime).
    EXPECT_NEAR(c.surface_velocity.dot(c.normal), 0, 1e-12);
    EXPECT_NEAR(c.normal_displacement, dt * (kThickness - 0.001 * std::sqrt(2.0)) / kRepulsionTime, 1e-12);
    EXPECT_DOUBLE_EQ(c.friction, 0.3);
  }
}

TEST(SelfContact, AVertexInACreaseIsHeldAgainstBothSidesButNotBetweenParallelLayersOrAgainstAHeldLayer) {
  // Faces 0 (in y = 0, x >= 0) and 1 (in x = 0, y >= 0) meet in a crease along z. Vertex 6, of
  // a face leaning away from both, is 1 mm above face 0 and 2 mm beside face 1 (2.24 mm from
  // the crease's edge): held against face 0, its nearest pair, and, as face 1's normal is at
  // 90 degrees to face 0's, against face 1 too, each restoring its missing thickness over
  // kRepulsionTime. Between face 0 and a parallel face 1.5 mm above it the second pair's normal
  // is the first's reversed: no second hold (a node is not held at two distances along one
  // direction). Nor when a collider holds face 1 (its nodes held before the cloth's handler):
  // a layer the walking body drives is not held against from a second side.
  enum Case { kCrease, kParallel, kHeldLayer };
  const double dt = 0.005;
  for (const Case which : {kCrease, kParallel, kHeldLayer}) {
    SCOPED_TRACE(which);
    VecX x(27);
    node(x, 0) = Vec3(0, 0, -0.2), node(x, 1) = Vec3(0.3, 0, 0), node(x, 2) = Vec3(0, 0, 0.2);
    node(x, 3) = Vec3(0, 0.3, 0);
    node(x, 4) = Vec3(-0.1, 0.0025, -0.2), node(x, 5) = Vec3(-0.1, 0.0025, 0.2);
    node(x, 6) = Vec3(which == kParallel ? 0.01 : 0.002, 0.001, 0);
    node(x, 7) = Vec3(0.2, 0.3, 0), node(x, 8) = Vec3(0.2, 0.3, 0.1);
    std::vector<std::array<int, 3>> triangles = {{0, 1, 2}, {0, 2, 3}, {6, 7, 8}};
    if (which == kParallel) {
      node(x, 3) = Vec3(0.3, 0.0025, 0);
      triangles[1] = {3, 4, 5};
    }
    SelfContacts self(triangles, x, VecX::Constant(9, 1e-3), std::vector<char>(9, 0), kThickness, 0.3);
    std::vector<NodeContact> out;
    if (which == kHeldLayer)
      for (int i : {0, 2, 3}) {
        out.emplace_back();
        out.back().node = i;
        out.back().normal = Vec3::UnitX();
      }
    self.detect(x, VecX::Zero(27), 0, dt, out);
    const auto held = std::find_if(out.begin(), out.end(), [](const NodeContact& c) { return c.node == 6; });
    ASSERT_NE(held, out.end());
    EXPECT_NEAR(held->normal.dot(Vec3::UnitY()), 1, 1e-12);
    EXPECT_NEAR(held->normal_displacement, dt * (kThickness - 0.001) / kRepulsionTime, 1e-12);
    if (which != kCrease) {
      EXPECT_FALSE(held->has_normal2());
    } else {
      ASSERT_TRUE(held->has_normal2());
      EXPECT_NEAR(held->normal2.dot(Vec3::UnitX()), 1, 1e-12);
      EXPECT_NEAR(held->normal_displacement2, dt * (kThickness - 0.002) / kRepulsionTime, 1e-12);
    }
  }
}

TEST(SelfContact, AVertexRestingJustOutsideTheThicknessIsHeldWhereItIsAndLeftAloneByTheRepulsions) {
  // Vertex 3 (of a face far above) over the middle of face 0 in y = 0, at heights from half the
  // thickness to beyond kHoldReach of it. Inside the thickness it is held and pushed out over
  // kRepulsionTime, with friction, and the repulsions push it too. From the thickness to
  // kHoldReach times it, at rest, it is held where it is (no displacement: the solve does not
  // press it into the layer), with friction out to kFrictionReach times the thickness and none
  // beyond, and the repulsions leave it alone; so too when a still collider holds the face's
  // nodes at rest, but not when it moves faster than kHoldReachSpeed or the face the collider
  // holds moves faster than kHeldRestSpeed. Farther out it is not held.
  const double dt = 0.005, friction = 0.3;
  enum Case { kAtRest, kMoving, kFaceHeld, kFaceHeldMoving };
  for (const Case which : {kAtRest, kMoving, kFaceHeld, kFaceHeldMoving})
    for (const double ratio : {0.5, 1.05, 1.2, 1.3}) {
      SCOPED_TRACE(testing::Message() << "case " << which << ", height " << ratio << " thicknesses");
      VecX x(18), v = VecX::Zero(18);
      node(x, 0) = Vec3(-0.1, 0, -0.1), node(x, 1) = Vec3(0.1, 0, -0.1), node(x, 2) = Vec3(0, 0, 0.1);
      node(x, 3) = Vec3(0, ratio * kThickness, 0);
      node(x, 4) = Vec3(0, 0.3, 0), node(x, 5) = Vec3(0.1, 0.3, 0.1);
      if (which == kMoving) node(v, 3) = Vec3(2 * kHoldReachSpeed, 0, 0);  // sliding over the face
      if (which == kFaceHeldMoving)  // carried along by its collider, slower than kHoldReachSpeed
        for (int i : {0, 1, 2}) node(v, i) = Vec3(2 * kHeldRestSpeed, 0, 0);
      const std::vector<std::array<int, 3>> triangles = {{0, 1, 2}, {3, 4, 5}};
      SelfContacts self(triangles, x, VecX::Constant(6, 1e-3), std::vector<char>(6, 0), kThickness, friction);
      std::vector<NodeContact> out;
      if (which == kFaceHeld || which == kFaceHeldMoving)
        for (int i : {0, 1, 2}) {
          out.emplace_back();
          out.back().node = i;
          out.back().normal = Vec3::UnitY();
          out.back().still_surface = true;  // a floor
        }
      self.detect(x, v, 0, dt, out);
      const auto held = std::find_if(out.begin(), out.end(), [](const NodeContact& c) { return c.node == 3; });
      const bool beyond = ratio >= 1;
      if (ratio > kHoldReach || (beyond && (which == kMoving || which == kFaceHeldMoving))) {
        EXPECT_EQ(held, out.end());
      } else {
        ASSERT_NE(held, out.end());
        EXPECT_NEAR(held->normal.dot(Vec3::UnitY()), 1, 1e-12);
        const double restore = beyond ? 0.0 : dt * (1 - ratio) * kThickness / kRepulsionTime;
        EXPECT_NEAR(held->normal_displacement, restore, 1e-15);
        EXPECT_EQ(held->friction, ratio < kFrictionReach ? friction : 0.0);
      }
      if (which != kAtRest) continue;
      // The fail-safe after a step that moved nothing: only the pair within the thickness is
      // pushed apart.
      VecX x1 = x, v1 = VecX::Zero(18);
      ContactReport report;
      self.finish_step(x, x1, v1, 0, dt, report);
      if (!beyond) {
        EXPECT_GT(node(v1, 3).y(), 0);
      } else {
        EXPECT_EQ(x1, x);
        EXPECT_EQ(v1, VecX::Zero(18));
      }
    }
}

TEST(SelfContact, AnEdgeEndCarryingLittleOfTheClosestPointIsNotHeld) {
  // The lower edge moved along x so that the upper one crosses it a tenth of the way from node
  // 0 (weights 0.9 and 0.1): node 1 is left free, below kEdgeHoldWeight.
  const std::vector<std::array<int, 3>> triangles = {{0, 1, 2}, {3, 4, 5}};
  const VecX mass = VecX::Constant(6, 1e-3);
  const VecX x = crossing_edges(0.04);
  SelfContacts self(triangles, x, mass, std::vector<char>(6, 0), kThickness, 0.3);
  std::vector<NodeContact> out;
  self.detect(x, VecX::Zero(18), 0, 0.005, out);
  std::vector<int> held;
  for (const NodeContact& c : out) held.push_back(c.node);
  std::sort(held.begin(), held.end());
  EXPECT_EQ(held, (std::vector<int>{0, 3, 4}));
}

TEST(SelfContact, EdgesOfAPairWithANodeAColliderHoldsAreLeftToTheFailSafe) {
  // Node 0 already held by a collider (a contact in `out` before the cloth's): the crossing
  // edges' other ends get no hold in the solve either.
  const std::vector<std::array<int, 3>> triangles = {{0, 1, 2}, {3, 4, 5}};
  const VecX mass = VecX::Constant(6, 1e-3);
  const VecX x = crossing_edges(0);
  SelfContacts self(triangles, x, mass, std::vector<char>(6, 0), kThickness, 0.3);
  std::vector<NodeContact> out(1);
  out[0].node = 0;
  self.detect(x, VecX::Zero(18), 0, 0.005, out);
  EXPECT_EQ(out.size(), 1u);
}

TEST(SelfContact, AFreeLayerIsHeldAgainstALayerAColliderHoldsAtRest) {
  // The lower edge's two ends held by a collider at rest: the crossing upper edge's ends (each
  // carrying about half of its closest point) are held against it along the pair's normal,
  // away from the lower edge. Not when the held edge moves faster than kHeldRestSpeed, nor when
  // the collider moves (a body, or a collider with a rigid motion: NodeContact::still_surface
  // not set), nor when the collider holds a node of each edge.
  const std::vector<std::array<int, 3>> triangles = {{0, 1, 2}, {3, 4, 5}};
  const VecX mass = VecX::Constant(6, 1e-3);
  const VecX x = crossing_edges(0);
  SelfContacts self(triangles, x, mass, std::vector<char>(6, 0), kThickness, 0.3);
  auto holds = [&](const std::vector<int>& collider_held, double speed, bool still_surface = true) {
    std::vector<NodeContact> out;
    for (int i : collider_held) {
      out.emplace_back();
      out.back().node = i;
      out.back().still_surface = still_surface;
    }
    VecX v = VecX::Zero(18);
    for (int i : collider_held) node(v, i) = Vec3(speed, 0, 0);
    self.detect(x, v, 0, 0.005, out);
    std::vector<int> held;
    for (size_t k = collider_held.size(); k < out.size(); ++k) {
      held.push_back(out[k].node);
      // From the lower edge's closest point (the origin) to the upper's, about (0, 1, 1) mm.
      EXPECT_NEAR(out[k].normal.dot(Vec3(0, 1, 1).normalized()), 1, 1e-6) << "node " << out[k].node;
    }
    std::sort(held.begin(), held.end());
    return held;
  };
  EXPECT_EQ(holds({0, 1}, 0), (std::vector<int>{3, 4}));
  EXPECT_EQ(holds({0, 1}, 0.5 * kHeldRestSpeed), (std::vector<int>{3, 4}));
  EXPECT_TRUE(holds({0, 1}, 2 * kHeldRestSpeed).empty());
  EXPECT_TRUE(holds({0, 1}, 0, false).empty());
  EXPECT_TRUE(holds({0, 3}, 0).empty());

  // A vertex a collider holds at rest under a free face (over the face's point with weights
  // 1/4, 1/4, 1/2): the face's nodes are held against it, along the normal from the vertex to
  // the face, out to kHoldReach thicknesses; not when the vertex moves.
  for (const double ratio : {0.5, 1.2, 1.3}) {
    SCOPED_TRACE(testing::Message() << "height " << ratio << " thicknesses");
    VecX y(18);
    node(y, 0) = Vec3(-0.1, 0, -0.1), node(y, 1) = Vec3(0.1, 0, -0.1), node(y, 2) = Vec3(0, 0, 0.1);
    node(y, 3) = Vec3(0, -ratio * kThickness, 0);
    node(y, 4) = Vec3(0, -0.3, 0), node(y, 5) = Vec3(0.1, -0.3, 0.1);
    SelfContacts under(triangles, y, mass, std::vector<char>(6, 0), kThickness, 0.3);
    for (const double speed : {0.0, 2 * kHeldRestSpeed}) {
      std::vector<NodeContact> out(1);
      out[0].node = 3;
      out[0].still_surface = true;
      VecX v = VecX::Zero(18);
      node(v, 3) = Vec3(speed, 0, 0);
      under.detect(y, v, 0, 0.005, out);
      std::vector<int> held;
      for (size_t k = 1; k < out.size(); ++k) {
        held.push_back(out[k].node);
        EXPECT_NEAR(out[k].normal.y(), 1, 1e-12) << "node " << out[k].node;
      }
      std::sort(held.begin(), held.end());
      if (speed > 0 || ratio > kHoldReach)
        EXPECT_TRUE(held.empty()) << "speed " << speed;
      else
        EXPECT_EQ(held, (std::vector<int>{0, 1, 2}));
    }
  }
}

TEST(SelfContact, TwoSheetsDroppedOnABoxComeToRestWithoutTheFailSafesWork) {
  // Two 0.6 m squares of cotton (11 x 11 vertices), the upper turned 9 degrees, dropped 5 cm
  // onto a box with 4 cm rounded edges: the box holds the lower sheet; the upper lies on it, its
  // vertices and edges just within and just beyond the thickness, its flaps on the lower's over
  // the rounded edges. Held only against layers that no collider holds, the upper sheet fell
  // into the lower in every step for the repulsions to push back out, for ever: from 1.5 s to
  // 3 s, long after landing, the fail-safes put 10 J (BDF-2), 61 J (backward Euler) and 2.1 J
  // (the midpoint) into the pair, against the 0.067 J of potential energy its drop releases.
  // Held against the lower sheet where the box holds it at rest, they put in less than that (a
  // sixth of it at most over turns of 8 to 11 degrees and a drop 1 mm higher).
  const int n = 11;
  const double size = 0.6;
  Sheets two = sheets(n, size, {0.45, 0.47});
  const Mat3 turn = rotation_from_degrees(Vec3(0, 9, 0));
  for (int i = n * n; i < 2 * n * n; ++i) {
    const Vec3 p = node(two.x, i);
    node(two.x, i) = turn * Vec3(p.x(), 0, p.z()) + Vec3(0, p.y(), 0);
  }
  Scene s;
  s.cloth.mesh = as_mesh(two);
  s.cloth.material = material_preset("cotton");
  s.cloth.thickness = kThickness;
  s.cloth.friction = 0.3;
  s.cloth.self_collision = true;
  s.integrator.dt = 0.005;
  s.duration = 3.0;
  s.frame_interval = 0.02;
  ColliderSpec box;
  box.shape = ColliderShape::kBox;
  box.name = "box";
  box.centre = Vec3(0, 0.2, 0);
  box.half_extents = Vec3(0.25, 0.2, 0.25);
  box.edge_radius = 0.04;
  box.thickness = kThickness;
  box.friction = 0.4;
  s.colliders.push_back(box);
  s.colliders.push_back(floor_plane());
  for (const char* method : {"bdf2", "backward-euler", "implicit-midpoint"}) {
    set_method(s, method, std::nullopt, "test");
    Simulation sim(s);
    const double gravity0 = sim.core().energies().gravity;
    sim.advance_to(1.5);
    const double landed = sim.core().state().fail_safe_work;
    const RunResult r = run_simulation(sim, {});
    ASSERT_EQ(r.status, "ok") << method << ": " << r.message;
    const double released = gravity0 - sim.core().energies().gravity;
    ASSERT_GT(released, 0.03) << method << ": the sheets landed on the box";
    EXPECT_LT(sim.core().state().fail_safe_work - landed, released) << method;
  }
}

TEST(SelfContact, AVertexAColliderHoldsOverALayerItHoldsTooIsHeldAgainstTheLayer) {
  // Two sheets 2 mm apart over a floor that holds all their nodes (contacts in `out` along +y):
  // the upper sheet's vertices are held against the lower sheet's faces instead, along +y and
  // at the cloth's friction; the lower sheet keeps the floor's holds.
  Sheets s = sheets(3, 0.02, {0.003, 0.005});
  const int n = static_cast<int>(s.x.size() / 3);
  const VecX mass = VecX::Constant(n, 1e-3);
  SelfContacts self(s.triangles, s.x, mass, std::vector<char>(n, 0), kThickness, 0.3);
  std::vector<NodeContact> out(n);
  for (int i = 0; i < n; ++i) {
    out[i].node = i;
    out[i].normal = Vec3::UnitY();
    out[i].friction = 0.7;
  }
  self.detect(s.x, VecX::Zero(s.x.size()), 0, 0.005, out);
  ASSERT_EQ(static_cast<int>(out.size()), n);  // replaced, not added
  for (int i = 0; i < n; ++i) {
    const bool upper = i >= s.per_sheet;
    EXPECT_EQ(out[i].node, i);
    EXPECT_NEAR(out[i].normal.y(), 1.0, 1e-12) << "node " << i;
    EXPECT_EQ(out[i].friction, upper ? 0.3 : 0.7) << "node " << i;
  }
  // Held by a collider along -y (a ceiling above them), the roles swap: the upper sheet is the
  // layer between, the lower sheet's vertices are held against it and the upper keep the
  // collider's holds.
  for (NodeContact& c : out) {
    c.normal = -Vec3::UnitY();
    c.friction = 0.7;
  }
  self.detect(s.x, VecX::Zero(s.x.size()), 0, 0.005, out);
  ASSERT_EQ(static_cast<int>(out.size()), n);
  for (int i = 0; i < n; ++i) {
    EXPECT_NEAR(out[i].normal.y(), -1.0, 1e-12) << "node " << i;
    EXPECT_EQ(out[i].friction, i < s.per_sheet ? 0.3 : 0.7) << "node " << i;
  }
}

TEST(SelfContact, ASheetThrownOnASheetLyingOnTheFloorStopsOnIt) {
  // Both sheets thrown down at 1 m/s, the lower one 3 mm over the floor (its thickness), the
  // upper one 12 mm above that: the lower stops on the floor at once, the upper ends its
  // landing step inside the lower one's thickness. Held there by the floor, the solve pulled it
  // down to the floor's thickness, through the lower sheet, and the fail-safe pushed it out
  // again with the difference as velocity: it rebounded 2 to 4 mm above its resting place.
  // Held against the lower sheet, it is lifted back to the thickness and no higher.
  Sheets two = sheets(9, 0.2, {0.003, 0.015});
  const std::shared_ptr<const TriMesh> mesh = as_mesh(two);
  for (const char* method : {"bdf2", "backward-euler", "implicit-midpoint"}) {
    Scene s = on_the_floor(mesh, method, 0.3);
    s.cloth.initial_velocity = Vec3(0, -1, 0);
    s.frame_interval = 0.005;
    s.duration = 0.2;
    Simulation sim(s);
    double highest = 0, lowest = 1;
    for (int k = 1; k <= 40; ++k) {
      sim.advance_to(k * s.integrator.dt);
      double upper = 0;
      for (int i = two.per_sheet; i < sim.vertex_count(); ++i) upper += sim.positions()[3 * i + 1];
      upper /= two.per_sheet;
      if (k >= 3) highest = std::max(highest, upper);  // landed in the third step
      lowest = std::min(lowest, upper);
    }
    EXPECT_LT(lowest, 2 * kThickness) << method << ": the upper sheet should have landed within the lower's thickness";
    EXPECT_LT(highest, 2 * kThickness * 1.02) << method;
  }
}

TEST(SelfContact, ASheetOnASheetOnAnInclineSticksBelowTheFrictionAngleAndSlidesAbove) {
  // Two sheets lying on a floor under gravity tilted by 30 degrees; the floor's friction (0.9)
  // holds the lower one. The upper one, on the lower at the cloth's thickness, sticks where the
  // cloth's friction is above tan 30 = 0.577 and otherwise slides with the Coulomb
  // acceleration g (sin 30 - friction cos 30): 3.21 m/s^2 at friction 0.2, against 2.36 at 0.3
  // and 4.06 at 0.1, so a tenth off tells one friction from its neighbours. (Measured after
  // the first 50 ms, in which the upper sheet settles onto the lower.)
  const double g = 9.81, theta = 30 * M_PI / 180;
  Sheets two = sheets(9, 0.2, {kThickness, 2 * kThickness});
  const std::shared_ptr<const TriMesh> mesh = as_mesh(two);
  for (const char* method : {"bdf2", "backward-euler", "implicit-midpoint"})
    for (const double friction : {0.2, 0.7}) {
      Scene s = on_the_floor(mesh, method, friction);
      s.gravity = Vec3(g * std::sin(theta), -g * std::cos(theta), 0);
      s.frame_interval = 0.05;
      s.duration = 0.15;
      s.colliders.back().friction = 0.9;
      Simulation sim(s);
      auto upper = [&](const VecX& a) {
        double sum = 0;
        for (int i = two.per_sheet; i < sim.vertex_count(); ++i) sum += a[3 * i];
        return sum / two.per_sheet;
      };
      sim.advance_to(0.05);
      const double v0 = upper(sim.velocities()), x0 = upper(sim.positions());
      sim.advance_to(0.15);
      const double coulomb = g * (std::sin(theta) - friction * std::cos(theta));
      if (coulomb > 0) {
        EXPECT_NEAR((upper(sim.velocities()) - v0) / 0.1, coulomb, 0.1 * coulomb) << method << ", friction " << friction;
      } else {
        // Sliding at friction 0.5 (0.66 m/s^2) would take it 3.3 mm in the 0.1 s; the
        // midpoint, which damps nothing, lets the layers slip by fractions of a millimetre.
        EXPECT_LT(std::abs(upper(sim.positions()) - x0), 1e-3) << method << ", friction " << friction;
      }
      for (int i = 0; i < two.per_sheet; ++i)
        EXPECT_LT(std::abs(sim.velocities()[3 * i]), 1e-6) << method << ": the lower sheet should stay, node " << i;
    }
}

TEST(SelfContact, ASheetLyingOnASheetOnTheFloorComesToRest) {
  // A smaller sheet at rest on a larger one, offset so that each layer's vertices lie under or
  // over the other's faces, on the floor. The floor holds the lower sheet still; the solve
  // holds the upper sheet's vertices on the lower's faces. The fail-safe's repulsions of the
  // lower sheet's vertices against the upper sheet's faces shared their push with those
  // resting vertices and threw them off the layer, to fall back and be thrown again: the
  // upper sheet jittered for ever (up to 0.8, 0.9 and 2.1 microjoules of kinetic energy in its
  // second half-second under BDF-2, backward Euler and the midpoint, 7 to 19 times the bound
  // below). Now it comes to rest: over its second half-second its kinetic energy stays below
  // a thousandth of its weight times the thickness.
  const int n = 9;
  Sheets lower = sheets(n, 0.2, {kThickness});
  Sheets upper = sheets(n, 0.16, {2 * kThickness});
  Sheets two = lower;
  two.x.conservativeResize(lower.x.size() + upper.x.size());
  for (int i = 0; i < n * n; ++i) node(two.x, n * n + i) = node(upper.x, i) + Vec3(0.009, 0, 0.0055);
  for (auto t : upper.triangles) two.triangles.push_back({t[0] + n * n, t[1] + n * n, t[2] + n * n});
  const std::shared_ptr<const TriMesh> mesh = as_mesh(two);
  for (const char* method : {"bdf2", "backward-euler", "implicit-midpoint"}) {
    Scene s = on_the_floor(mesh, method, 0.7);
    s.frame_interval = 0.005;
    s.duration = 1.0;
    Simulation sim(s);
    double upper_mass = 0;
    for (int i = n * n; i < sim.vertex_count(); ++i) upper_mass += sim.masses()[i];
    double most = 0;
    for (int k = 1; k <= 200; ++k) {
      sim.advance_to(k * s.integrator.dt);
      if (k <= 100) continue;
      double kinetic = 0;
      for (int i = n * n; i < sim.vertex_count(); ++i)
        kinetic += 0.5 * sim.masses()[i] * node(sim.velocities(), i).squaredNorm();
      most = std::max(most, kinetic);
    }
    EXPECT_LT(most, 1e-3 * upper_mass * 9.81 * kThickness) << method;
  }
}
