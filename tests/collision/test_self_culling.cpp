// Self-collision culling (collision/self_culling.hpp): regions passed over hold no pair, so the
// searches find the same pairs with culling on and off, on cloth that folds, rolls and
// crumples; a flat or gently curved sheet is passed over whole, and what must not be passed
// over (a fold, two pieces side by side closer than the reach, a sheet finer than the reach)
// is not; regions kept from an earlier search are taken after a rigid motion, not after a fold.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>

#include "collision/self_contact.hpp"
#include "collision/self_culling.hpp"
#include "sim/model_data.hpp"
#include "sim/simulation_core.hpp"
#include "support/cloth_step_problem.hpp"

using namespace weft;

namespace {

constexpr double kThickness = 0.003;
constexpr double kReach = kHoldReach * kThickness;

struct Cloth {
  std::vector<std::array<int, 3>> triangles;
  VecX x;      ///< positions
  VecX rest;   ///< the flat sheet it was shaped from
};

// An n x n grid of side `size` (pattern coordinates (s, t) in [0, size]^2), its vertices placed
// by shape(s, t); pieces > 1: that many grids side by side along s, `gap` apart.
Cloth grid(int n, double size, const std::function<Vec3(double, double)>& shape, int pieces = 1, double gap = 0) {
  Cloth c;
  c.x.resize(3 * n * n * pieces);
  c.rest.resize(3 * n * n * pieces);
  for (int p = 0; p < pieces; ++p) {
    const int base = p * n * n;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const double s = p * (size + gap) + size * i / (n - 1), t = size * j / (n - 1);
        node(c.x, base + j * n + i) = shape(s, t);
        node(c.rest, base + j * n + i) = Vec3(s, 0, t);
      }
    for (int j = 0; j + 1 < n; ++j)
      for (int i = 0; i + 1 < n; ++i) {
        const int a = base + j * n + i, b = a + 1, cc = a + n, d = cc + 1;
        c.triangles.push_back({a, d, b});
        c.triangles.push_back({a, cc, d});
      }
  }
  return c;
}

SelfContacts contacts_for(const Cloth& c) {
  const int n = static_cast<int>(c.x.size() / 3);
  return SelfContacts(c.triangles, c.rest, VecX::Constant(n, 1e-3), std::vector<char>(n, 0), kThickness, 0.3);
}

// Detection at the start and the fail-safe over a step with velocities v, with culling on and
// off: the contacts held and the step's end the same, bit for bit. Returns the culling's
// statistics of the run with it on.
SelfCullingStatistics same_with_and_without_culling(const Cloth& c, const VecX& v, double dt) {
  std::vector<NodeContact> held[2];
  VecX x1[2], v1[2];
  ContactReport reports[2];
  SelfContactStatistics stats[2];
  SelfCullingStatistics culled;
  for (int on = 0; on < 2; ++on) {
    SelfContacts self = contacts_for(c);
    self.set_culling(on == 1);
    self.detect(c.x, v, 0, dt, held[on]);
    x1[on] = c.x + dt * v;
    v1[on] = v;
    self.finish_step(c.x, x1[on], v1[on], 0, dt, reports[on]);
    stats[on] = self.statistics();
    if (on) culled = self.culling_statistics();
  }
  EXPECT_EQ(held[0].size(), held[1].size());
  for (size_t k = 0; k < std::min(held[0].size(), held[1].size()); ++k) {
    EXPECT_EQ(held[0][k].node, held[1][k].node);
    EXPECT_EQ(held[0][k].normal, held[1][k].normal);
    EXPECT_EQ(held[0][k].normal_displacement, held[1][k].normal_displacement);
    EXPECT_EQ(held[0][k].normal2, held[1][k].normal2);
  }
  EXPECT_TRUE(x1[0] == x1[1]);
  EXPECT_TRUE(v1[0] == v1[1]);
  EXPECT_EQ(reports[0].fail_safe_moves, reports[1].fail_safe_moves);
  EXPECT_EQ(stats[0].repulsions, stats[1].repulsions);
  EXPECT_EQ(stats[0].collision_impulses, stats[1].collision_impulses);
  EXPECT_EQ(stats[0].impact_zones, stats[1].impact_zones);
  return culled;
}

// The nodes held in the solve at the start of a step, found without culling.
size_t held_without_culling(const Cloth& c, const VecX& v) {
  SelfContacts off = contacts_for(c);
  off.set_culling(false);
  std::vector<NodeContact> held;
  off.detect(c.x, v, 0, 0.005, held);
  return held.size();
}

// A smooth random velocity field (m/s) of about `speed`.
VecX smooth_velocity(const Cloth& c, double speed, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  Vec3 a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng)), k(3 * u(rng), 3 * u(rng), 3 * u(rng));
  VecX v(c.x.size());
  for (int i = 0; i < v.size() / 3; ++i) {
    const Vec3 p = node(c.x, i);
    node(v, i) = speed * (a * std::sin(k.dot(p) * 4) + b * std::cos(k.dot(p) * 7 + 1));
  }
  return v;
}

// A culling over a cloth's tree, and the regions of its last search.
struct Searches {
  explicit Searches(const Cloth& c) : triangles(c.triangles), tree(c.triangles, c.rest.data()), culling(c.triangles, tree) {}
  const std::vector<char>& find(const VecX& xa, const VecX& xb, double r) {
    culling.find(triangles, tree, xa, xb, r, skip);
    return skip;
  }
  std::vector<std::array<int, 3>> triangles;
  AabbTree tree;
  SelfCulling culling;
  std::vector<char> skip;
};

}  // namespace

TEST(SelfCulling, AFlatSheetIsPassedOverWholeAndNothingIsFound) {
  // 33 x 33 over 0.5 m: edges of 15.6 mm, the smallest altitude 11 mm, far above the reach.
  const Cloth c = grid(33, 0.5, [](double s, double t) { return Vec3(s, 1, t); });
  SelfContacts self = contacts_for(c);
  std::vector<NodeContact> held;
  self.detect(c.x, VecX::Zero(c.x.size()), 0, 0.005, held);
  EXPECT_TRUE(held.empty());
  EXPECT_EQ(self.culling_statistics().triangles_culled, static_cast<long>(c.triangles.size()));
  EXPECT_EQ(self.culling_statistics().regions_culled, 1);  // the root
}

TEST(SelfCulling, ASheetFinerThanTheReachIsNotPassedOverAtTheReach) {
  // Edges of 2.5 mm: in the plane, a vertex is within the reach (3.75 mm) of faces it does not
  // touch. At the reach no region may be passed over; at the continuous detection's distance
  // (a tenth of the thickness) the whole sheet is.
  const Cloth c = grid(21, 0.05, [](double s, double t) { return Vec3(s, 1, t); });
  const AabbTree tree(c.triangles, c.rest.data());
  SelfCulling culling(c.triangles, tree);
  std::vector<char> skip;
  culling.find(c.triangles, tree, c.x, c.x, kReach, skip);
  EXPECT_EQ(std::count(skip.begin(), skip.end(), 1), 0);
  culling.find(c.triangles, tree, c.x, c.x, 0.1 * kThickness, skip);
  EXPECT_EQ(skip[0], 1);
  // and the pairs found are the same with culling on and off
  same_with_and_without_culling(c, VecX::Zero(c.x.size()), 0.005);
}

TEST(SelfCulling, AVertexNearTheFarEdgeOfItsStarIsNotPassedOver) {
  // A flat sheet of 2 cm cells (its contour coarse), one inner vertex moved to 2 mm from the far
  // edge of its star: within the reach of the face beyond that edge, which it does not touch.
  // Only the altitude test (cos(theta) times the smallest altitude below the reach) tells.
  const int n = 11;
  const double h = 0.02;
  Cloth c = grid(n, h * (n - 1), [](double s, double t) { return Vec3(s, 1, t); });
  node(c.x, 5 * n + 5) = Vec3(6 * h - 0.002, 1, 5.5 * h);
  const AabbTree tree(c.triangles, c.rest.data());
  SelfCulling culling(c.triangles, tree);
  std::vector<char> skip;
  culling.find(c.triangles, tree, c.x, c.x, kReach, skip);
  EXPECT_EQ(skip[0], 0);
  EXPECT_GT(held_without_culling(c, VecX::Zero(c.x.size())), 0u);
  same_with_and_without_culling(c, VecX::Zero(c.x.size()), 0.005);
}

TEST(SelfCulling, TwoPiecesSideBySideCloserThanTheReachAreNotPassedOverTogether) {
  // Two flat pieces 2 mm apart in one plane: every cone and altitude passes, the contour of a
  // region holding both does not; each piece alone is passed over, and the pairs across the
  // gap are found with culling too.
  const Cloth c = grid(17, 0.25, [](double s, double t) { return Vec3(s, 1, t); }, 2, 0.002);
  const AabbTree tree(c.triangles, c.rest.data());
  SelfCulling culling(c.triangles, tree);
  std::vector<char> skip;
  culling.find(c.triangles, tree, c.x, c.x, kReach, skip);
  EXPECT_EQ(skip[0], 0);
  EXPECT_GT(culling.statistics().contour_failures, 0);
  EXPECT_EQ(culling.statistics().triangles_culled, static_cast<long>(c.triangles.size()));
  // 10 mm apart, beyond the reach: the root passes.
  const Cloth apart = grid(17, 0.25, [](double s, double t) { return Vec3(s, 1, t); }, 2, 0.01);
  culling.find(apart.triangles, tree, apart.x, apart.x, kReach, skip);
  EXPECT_EQ(skip[0], 1);
  EXPECT_GT(held_without_culling(c, VecX::Zero(c.x.size())), 0u);  // the gap's edges hold each other
  same_with_and_without_culling(c, VecX::Zero(c.x.size()), 0.005);
}

TEST(SelfCulling, TwoPiecesClosingInOverTheStepAreNotPassedOverTogether) {
  // Two flat pieces 6 mm apart (beyond the reach) at the step's start, the second moving 4 mm
  // towards the first: 2 mm apart at its end. The contour is measured over the whole step, so
  // the region holding both is not passed over, and the pairs across the gap are found.
  const double dt = 0.005;
  const int n = 17;
  const Cloth c = grid(n, 0.25, [](double s, double t) { return Vec3(s, 1, t); }, 2, 0.006);
  VecX v = VecX::Zero(c.x.size());
  for (int i = n * n; i < 2 * n * n; ++i) node(v, i) = Vec3(-0.004 / dt, 0, 0);
  const VecX end = c.x + dt * v;
  EXPECT_EQ(Searches(c).find(c.x, c.x, kReach)[0], 1);  // at rest: passed over whole
  Searches moving(c);
  EXPECT_EQ(moving.find(c.x, end, kReach)[0], 0);
  EXPECT_GT(moving.culling.statistics().contour_failures, 0);
  // each piece alone is still passed over
  EXPECT_EQ(moving.culling.statistics().triangles_culled, static_cast<long>(c.triangles.size()));
  same_with_and_without_culling(c, v, dt);
}

TEST(SelfCulling, KeptRegionsAreTakenAfterARigidMotionAndAreThoseFoundAnew) {
  // A gently curved sheet, then the same turned by 40 degrees and shifted by 30 cm, with a
  // ripple of 0.1 mm: the kept regions are taken (the positions are within 0.1 mm of a rigid
  // motion of the first) and they are the regions a culling without kept regions finds there.
  const Cloth c = grid(33, 0.5, [](double s, double t) { return Vec3(s, 1 + 0.2 * s * s, t); });
  Searches kept(c), fresh(c);
  fresh.culling.set_keeping(false);
  ASSERT_EQ(kept.find(c.x, c.x, kReach)[0], 1);
  const Mat3 turn = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  VecX moved(c.x.size());
  for (int i = 0; i < moved.size() / 3; ++i)
    node(moved, i) = turn * node(c.x, i) + Vec3(0.3, -0.1, 0.2) + Vec3(0, 1e-4 * std::sin(40.0 * i), 0);
  EXPECT_EQ(kept.find(moved, moved, kReach), fresh.find(moved, moved, kReach));
  EXPECT_EQ(kept.culling.statistics().reused, 1);
  EXPECT_EQ(fresh.culling.statistics().reused, 0);
  // Moving over a step from there to a little further along the same motion: taken again.
  VecX further(c.x.size());
  for (int i = 0; i < moved.size() / 3; ++i) node(further, i) = node(moved, i) + Vec3(0.002, 0.001, 0);
  EXPECT_EQ(kept.find(moved, further, 0.1 * kThickness)[0], 1);
  EXPECT_EQ(kept.culling.statistics().reused, 2);
}

TEST(SelfCulling, KeptRegionsAreNotTakenOnceTheClothFolded) {
  // A flat sheet whose regions were kept, then folded flat onto itself 2 mm apart (within the
  // reach): its vertices are far from any rigid motion of the flat sheet, so the regions are
  // found anew, the root is not passed over, and the searches find the pairs across the fold.
  const Cloth flat = grid(33, 0.5, [](double s, double t) { return Vec3(s, 1, t); });
  Searches searches(flat);
  ASSERT_EQ(searches.find(flat.x, flat.x, kReach)[0], 1);
  const Cloth folded = grid(33, 0.5, [](double s, double t) {
    return s <= 0.25 ? Vec3(s, 1, t) : Vec3(0.5 - s, 1.002, t);  // a sharp hinge at s = 0.25
  });
  EXPECT_EQ(searches.find(folded.x, folded.x, kReach)[0], 0);
  EXPECT_EQ(searches.culling.statistics().reused, 0);
  EXPECT_GT(held_without_culling(folded, VecX::Zero(folded.x.size())), 100u);
}

TEST(SelfCulling, AFoldedSheetFindsTheSameContacts) {
  // A sheet folded over a hinge of radius 1.4 mm: its two layers 2.8 mm apart (within the thickness),
  // moving towards each other at 0.5 m/s.
  const double radius = 0.0014, half = 0.25;
  auto fold = [&](double s, double t) {
    if (s < half) return Vec3(s, 1, t);
    const double arc = s - half, angle = arc / radius;
    if (angle < std::numbers::pi) return Vec3(half + radius * std::sin(angle), 1 + radius * (1 - std::cos(angle)), t);
    return Vec3(half - (arc - std::numbers::pi * radius), 1 + 2 * radius, t);
  };
  const Cloth c = grid(41, 0.5 + std::numbers::pi * radius, fold);
  VecX v = VecX::Zero(c.x.size());
  for (int i = 0; i < v.size() / 3; ++i) v[3 * i + 1] = node(c.x, i).y() > 1 + 0.003 ? -0.5 : 0.5;
  const SelfCullingStatistics culled = same_with_and_without_culling(c, v, 0.005);
  EXPECT_GT(culled.regions_culled, 0);  // the flat parts of each layer
  EXPECT_GT(held_without_culling(c, v), 100u);
}

TEST(SelfCulling, ARolledSheetFindsTheSameContacts) {
  // A sheet rolled into a tube of two and a half turns, its layers 3.5 mm apart, turning and
  // squeezed as it moves.
  const double r0 = 0.02, pitch = 0.0035;
  auto roll = [&](double s, double t) {
    // arc length s along the spiral r = r0 + pitch * angle / (2 pi), approximately
    double angle = 0;
    for (int k = 0; k < 60; ++k) angle = s / (r0 + pitch * angle / (4 * std::numbers::pi));
    const double r = r0 + pitch * angle / (2 * std::numbers::pi);
    return Vec3(r * std::cos(angle), 1 + r * std::sin(angle), t);
  };
  const Cloth c = grid(61, 0.4, roll);
  VecX v = smooth_velocity(c, 0.4, 7);
  for (int i = 0; i < v.size() / 3; ++i) v.segment<3>(3 * i) -= 2.0 * Vec3(node(c.x, i).x(), node(c.x, i).y() - 1, 0);
  same_with_and_without_culling(c, v, 0.005);
  EXPECT_GT(held_without_culling(c, v), 100u);
}

TEST(SelfCulling, ACrumpledSheetFindsTheSameContacts) {
  // Random smooth bumps of every direction and size, folded back over itself, with random
  // motion: three seeds.
  for (unsigned seed : {1u, 2u, 3u}) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1);
    std::array<Vec3, 6> waves;
    for (Vec3& w : waves) w = Vec3(u(rng), u(rng), u(rng));
    auto crumple = [&](double s, double t) {
      Vec3 p(s, 1, t);
      for (int k = 0; k < 6; ++k) {
        const double f = 6 + 5 * k;
        p += (0.03 / (k + 1)) * waves[k] * std::sin(f * (waves[k].x() * s + waves[k].z() * t) + k);
      }
      // folded back over itself beyond s = 0.3 (the layers 3 to 6 mm apart)
      if (s > 0.3) p = Vec3(0.6 - p.x(), 2 * 1.004 - p.y() + 0.01 * (s - 0.3), p.z());
      return p;
    };
    const Cloth c = grid(45, 0.5, crumple);
    const VecX v = smooth_velocity(c, 0.8, seed + 10);
    SCOPED_TRACE(seed);
    same_with_and_without_culling(c, v, 0.005);
    EXPECT_GT(held_without_culling(c, v), 0u);
  }
}

TEST(SelfCulling, AHangingSheetRunsToTheSameBitsWithAndWithoutCulling) {
  // The free-sheet benchmark's cloth (1 m, 33 x 33, hanging from two corners, folding as it
  // swings), 0.4 s: the same state bit for bit, and culling passed over most of it.
  VecX x[2];
  long culled = 0, offered = 0, reused = 0;
  for (int on = 0; on < 2; ++on) {
    Simulation sim(test::cloth_step_scene(33));
    SelfContacts* self = sim.core().simulation_data().self_contacts.get();
    ASSERT_NE(self, nullptr);
    self->set_culling(on == 1);
    sim.advance_to(0.4);
    x[on] = sim.core().state().x;
    if (on) {
      culled = self->culling_statistics().triangles_culled;
      offered = self->culling_statistics().calls * static_cast<long>(sim.core().model().mesh.triangles.size());
      reused = self->culling_statistics().reused;
    }
  }
  EXPECT_TRUE(x[0] == x[1]);
  EXPECT_GT(culled, offered / 2);
  EXPECT_GT(reused, 0);  // kept regions were taken along the way
}

TEST(SelfCulling, ContactScenesRunToTheSameBitsWithAndWithoutCulling) {
  // The twisted sheet wrung into a rope (dense self-contact, the fail-safe at work) for 1 s and
  // the five stacked sheets landing on the box for 0.6 s: the same state bit for bit.
  for (const auto& [file, seconds] : {std::pair{"twisted-sheet.json", 1.0}, std::pair{"stacked-sheets.json", 0.6}}) {
    SCOPED_TRACE(file);
    const Scene scene = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/" + file);
    VecX x[2], v[2];
    long culled = 0, reused = 0;
    for (int on = 0; on < 2; ++on) {
      Simulation sim(scene);
      SelfContacts* self = sim.core().simulation_data().self_contacts.get();
      ASSERT_NE(self, nullptr);
      self->set_culling(on == 1);
      sim.advance_to(seconds);
      x[on] = sim.core().state().x;
      v[on] = sim.core().state().v;
      if (on) {
        culled = self->culling_statistics().triangles_culled;
        reused = self->culling_statistics().reused;
      }
    }
    EXPECT_TRUE(x[0] == x[1]);
    EXPECT_TRUE(v[0] == v[1]);
    EXPECT_GT(culled, 0);
    EXPECT_GT(reused, 0);
  }
}
