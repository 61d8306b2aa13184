// The panel mesher's geometric predicates (mesh/exact_predicates.hpp) against exact integer
// arithmetic: points on a grid of 2^-10 m around an offset, or doubles in [1, 2), are exact
// multiples of a power of two, and their determinants fit in 128-bit integers, so every sign
// has a reference. The cases are exactly degenerate (collinear, cocircular), one grid step
// away, or within rounding of degenerate, where a plain double evaluation cannot be trusted.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mesh/exact_predicates.hpp"

namespace weft {
namespace {

using Int = __int128;

struct GridPoint {
  long x, y;  // in grid steps
};

constexpr double kStep = 1.0 / 1024;

Vec2 to_vec(const GridPoint& p, const Vec2& offset) {
  return offset + Vec2(p.x * kStep, p.y * kStep);
}

int sign(Int v) { return v > 0 ? 1 : v < 0 ? -1 : 0; }

int orientation_reference(const GridPoint& a, const GridPoint& b, const GridPoint& c) {
  return sign(Int(a.x - c.x) * Int(b.y - c.y) - Int(a.y - c.y) * Int(b.x - c.x));
}

int incircle_reference(const GridPoint& a, const GridPoint& b, const GridPoint& c,
                       const GridPoint& d) {
  const Int adx = a.x - d.x, ady = a.y - d.y, bdx = b.x - d.x, bdy = b.y - d.y, cdx = c.x - d.x,
            cdy = c.y - d.y;
  return sign((adx * adx + ady * ady) * (bdx * cdy - cdx * bdy) +
              (bdx * bdx + bdy * bdy) * (cdx * ady - adx * cdy) +
              (cdx * cdx + cdy * cdy) * (adx * bdy - bdx * ady));
}

// The offset moves the points far from the origin (differences stay exact: the offset is a
// multiple of the grid step and the coordinates stay below 2^53 steps).
const std::array<Vec2, 3> kOffsets{Vec2(0, 0), Vec2(0.25, -0.375), Vec2(4096, -8192)};

TEST(PanelMesherPredicates, OrientationOfNearlyCollinearPoints) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<long> coordinate(-(1L << 20), 1L << 20), step(-1, 1),
      scale(-40, 40);
  int degenerate = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    // c on the line through a and b (a multiple of b - a from a), then nudged by at most one step.
    const GridPoint a{coordinate(rng), coordinate(rng)};
    const GridPoint d{coordinate(rng) / 4096, coordinate(rng) / 4096};
    const GridPoint b{a.x + d.x, a.y + d.y};
    const long k = scale(rng);
    const GridPoint c{a.x + k * d.x + step(rng), a.y + k * d.y + step(rng)};
    const int expected = orientation_reference(a, b, c);
    degenerate += expected == 0;
    for (const Vec2& offset : kOffsets) {
      const Vec2 pa = to_vec(a, offset), pb = to_vec(b, offset), pc = to_vec(c, offset);
      ASSERT_EQ(orientation_sign(pa, pb, pc), expected) << "trial " << trial;
      // Swapping two points flips the sign; a cyclic shift keeps it.
      ASSERT_EQ(orientation_sign(pb, pa, pc), -expected);
      ASSERT_EQ(orientation_sign(pb, pc, pa), expected);
    }
  }
  EXPECT_GT(degenerate, 100);  // the exactly collinear case is well represented
}

TEST(PanelMesherPredicates, OrientationAtTheRoundingLevel) {
  // Doubles in [1, 2) are multiples of 2^-52: scaled by 2^52 they are integers below 2^53,
  // whose orientation determinant fits in 128 bits. c = a + t (b - a), rounded, lies within
  // rounding of the line through a and b, where a plain double determinant has no reliable
  // sign.
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> unit(1.0, 2.0), fraction(0.0, 1.0);
  auto exact = [](double x) { return static_cast<Int>(std::ldexp(x, 52)); };
  int within_rounding = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const Vec2 a(unit(rng), unit(rng)), b(unit(rng), unit(rng));
    const Vec2 c = a + fraction(rng) * (b - a);
    if (c.x() < 1 || c.x() >= 2 || c.y() < 1 || c.y() >= 2) continue;
    const Int left = (exact(a.x()) - exact(c.x())) * (exact(b.y()) - exact(c.y()));
    const Int right = (exact(a.y()) - exact(c.y())) * (exact(b.x()) - exact(c.x()));
    const Int det = left - right;
    // Below one unit in the last place of the products a double evaluation rounds.
    const Int magnitude = (left < 0 ? -left : left) + (right < 0 ? -right : right);
    within_rounding += (det < 0 ? -det : det) < (magnitude >> 52);
    ASSERT_EQ(orientation_sign(a, b, c), sign(det)) << "trial " << trial;
  }
  EXPECT_GT(within_rounding, 100);  // cases a plain double evaluation cannot decide
}

// orient3d_sign (the intersection tests' sign, collision/geometry.cpp) on nearly coplanar
// points of the grid in space: d = a + j (b - a) + k (c - a), nudged by at most one step; the
// determinant's products reach 2^69 steps^3, past what doubles hold exactly.
TEST(PanelMesherPredicates, Orient3dOfNearlyCoplanarPoints) {
  struct P3 {
    long x, y, z;
  };
  std::mt19937 rng(11);
  std::uniform_int_distribution<long> coordinate(-(1L << 20), 1L << 20), step(-1, 1), scale(-40, 40);
  auto vec = [](const P3& p, const Vec3& offset) -> Vec3 { return offset + Vec3(p.x * kStep, p.y * kStep, p.z * kStep); };
  auto reference = [](const P3& a, const P3& b, const P3& c, const P3& d) {
    const Int ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z, vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z,
              wx = d.x - a.x, wy = d.y - a.y, wz = d.z - a.z;
    return sign(ux * (vy * wz - vz * wy) + uy * (vz * wx - vx * wz) + uz * (vx * wy - vy * wx));
  };
  const std::array<Vec3, 3> offsets{Vec3(0, 0, 0), Vec3(0.25, -0.375, 0.5), Vec3(4096, -8192, 1024)};
  int coplanar = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const P3 a{coordinate(rng), coordinate(rng), coordinate(rng)};
    const P3 b{a.x + coordinate(rng) / 4096, a.y + coordinate(rng) / 4096, a.z + coordinate(rng) / 4096};
    const P3 c{a.x + coordinate(rng) / 4096, a.y + coordinate(rng) / 4096, a.z + coordinate(rng) / 4096};
    const long j = scale(rng), k = scale(rng);
    const P3 d{a.x + j * (b.x - a.x) + k * (c.x - a.x) + step(rng), a.y + j * (b.y - a.y) + k * (c.y - a.y) + step(rng),
               a.z + j * (b.z - a.z) + k * (c.z - a.z) + step(rng)};
    const int expected = reference(a, b, c, d);
    coplanar += expected == 0;
    for (const Vec3& offset : offsets) {
      const Vec3 pa = vec(a, offset), pb = vec(b, offset), pc = vec(c, offset), pd = vec(d, offset);
      ASSERT_EQ(orient3d_sign(pa, pb, pc, pd), expected) << "trial " << trial;
      ASSERT_EQ(orient3d_sign(pb, pa, pc, pd), -expected);  // swapping two points flips it
      ASSERT_EQ(orient3d_sign(pd, pb, pc, pa), -expected);  // so does swapping a and d
      ASSERT_EQ(orient3d_sign(pb, pc, pa, pd), expected);   // a cyclic shift of a, b, c keeps it
    }
  }
  EXPECT_GT(coplanar, 50);  // the exactly coplanar case is well represented
}

TEST(PanelMesherPredicates, InCircleOfNearlyCocircularPoints) {
  // Points with integer coordinates on the circle x^2 + y^2 = 5^4 * 13^2 (many exist: 5 and 13
  // are sums of two squares), shifted to random centres and nudged by at most one step.
  const long r2 = 625L * 169;
  std::vector<GridPoint> circle;
  for (long x = -325; x <= 325; ++x)
    for (long y = -325; y <= 325; ++y)
      if (x * x + y * y == r2) circle.push_back({x, y});
  ASSERT_GT(circle.size(), 20u);
  std::mt19937 rng(9);
  std::uniform_int_distribution<size_t> pick(0, circle.size() - 1);
  std::uniform_int_distribution<long> centre(-(1L << 20), 1L << 20), nudge(-1, 1);
  int degenerate = 0, inside = 0, outside = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const GridPoint c0{centre(rng), centre(rng)};
    std::array<GridPoint, 4> p;
    for (auto& q : p) {
      const GridPoint& on = circle[pick(rng)];
      q = {c0.x + on.x, c0.y + on.y};
    }
    p[3].x += nudge(rng);
    p[3].y += nudge(rng);
    // Counter-clockwise a, b, c are what the predicate expects.
    const int turn = orientation_reference(p[0], p[1], p[2]);
    if (turn == 0) continue;
    if (turn < 0) std::swap(p[0], p[1]);
    const int expected = incircle_reference(p[0], p[1], p[2], p[3]);
    degenerate += expected == 0;
    inside += expected > 0;
    outside += expected < 0;
    for (const Vec2& offset : kOffsets)
      ASSERT_EQ(incircle_sign(to_vec(p[0], offset), to_vec(p[1], offset), to_vec(p[2], offset),
                              to_vec(p[3], offset)),
                expected)
          << "trial " << trial;
  }
  EXPECT_GT(degenerate, 100);
  EXPECT_GT(inside, 100);
  EXPECT_GT(outside, 100);
}

}  // namespace
}  // namespace weft
