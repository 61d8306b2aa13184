// Continuous collision detection against brute force: thousands of random vertex-face and
// edge-edge trajectories, a share of them degenerate (parallel edges, motion in one plane,
// zero-length edges, no relative motion), and crafted cases with known answers.
//
// Brute force samples the exact distance (closest_point_triangle, closest_points_segments) at
// 4,000 times over the step. Two properties are checked on every trajectory:
//   - no miss: if a sample is within the thickness, the detection reports a time no later;
//   - no false alarm beyond the thickness: at the time reported the distance is within it
//     (to a relative 1e-8, the rounding of the root finding).
#include <gtest/gtest.h>

#include <random>

#include "collision/geometry.hpp"

namespace weft {
namespace {

constexpr int kSamples = 4000;

Vec3 lerp(const Vec3& x0, const Vec3& x1, double t) { return x0 + t * (x1 - x0); }

Vec3 uniform_point(std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  return Vec3(u(rng), u(rng), u(rng));
}

double random_thickness(std::mt19937& rng) {
  static const double choices[] = {0.0005, 0.003, 0.01, 0.04, 0.1};
  return choices[std::uniform_int_distribution<int>(0, 4)(rng)];
}

struct Outcome {
  int hits = 0, trials = 0;
};

// Compares a detection's answer with the sampled distance d(t) for one trajectory.
template <class Distance>
void check_against_samples(const std::optional<double>& hit, const Distance& distance, double thickness,
                           double motion, Outcome& outcome, const std::string& what) {
  ++outcome.trials;
  double first = -1;
  for (int i = 0; i <= kSamples; ++i) {
    const double t = double(i) / kSamples;
    if (distance(t) < thickness * (1 - 1e-7)) {
      first = t;
      break;
    }
  }
  if (first >= 0) {
    ASSERT_TRUE(hit.has_value()) << what << ": missed; within the thickness at t = " << first;
    EXPECT_LE(*hit, first + 1e-9) << what;
  }
  if (hit) {
    ++outcome.hits;
    ASSERT_GE(*hit, 0.0) << what;
    ASSERT_LE(*hit, 1.0) << what;
    EXPECT_LE(distance(*hit), thickness + 1e-8 * (thickness + motion)) << what << " at t = " << *hit;
  }
}

TEST(VertexFaceCcd, AgreesWithBruteForceOnRandomTrajectories) {
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> unit(0, 1), sym(-1, 1);
  Outcome outcome;
  for (int trial = 0; trial < 3000; ++trial) {
    Vec3 a0 = uniform_point(rng, 0.5), b0 = uniform_point(rng, 0.5), c0 = uniform_point(rng, 0.5);
    Vec3 a1 = a0 + uniform_point(rng, 0.2), b1 = b0 + uniform_point(rng, 0.2), c1 = c0 + uniform_point(rng, 0.2);
    // The vertex starts near the triangle and ends near it, often on the other side.
    const Vec3 n0 = (b0 - a0).cross(c0 - a0).normalized(), n1 = (b1 - a1).cross(c1 - a1).normalized();
    const double u0 = unit(rng), v0 = unit(rng) * (1 - u0), u1 = unit(rng), v1 = unit(rng) * (1 - u1);
    Vec3 p0 = a0 + 1.3 * u0 * (b0 - a0) + 1.3 * v0 * (c0 - a0) + 0.3 * sym(rng) * n0;
    Vec3 p1 = a1 + 1.3 * u1 * (b1 - a1) + 1.3 * v1 * (c1 - a1) + 0.3 * sym(rng) * n1;
    const int kind = trial % 10;
    if (kind == 0) {  // everything moves in the plane z = 0: the vertex slides in the triangle's plane
      for (Vec3* x : {&a0, &a1, &b0, &b1, &c0, &c1, &p0, &p1}) x->z() = 0;
    } else if (kind == 1) {  // a rigid translation of all four: no relative motion
      const Vec3 shift = uniform_point(rng, 0.3);
      a1 = a0 + shift, b1 = b0 + shift, c1 = c0 + shift, p1 = p0 + shift;
    } else if (kind == 2) {  // nothing moves
      a1 = a0, b1 = b0, c1 = c0, p1 = p0;
    } else if (kind == 3) {  // a triangle collapsed to a segment
      c0 = 0.5 * (a0 + b0), c1 = 0.5 * (a1 + b1);
    } else if (kind == 4) {  // the vertex aimed at an edge's midpoint at mid-step
      const Vec3 mid = 0.5 * (lerp(a0, a1, 0.5) + lerp(b0, b1, 0.5));
      p1 = p0 + 2 * (mid - p0);
    }
    const double h = random_thickness(rng);
    const auto hit = vertex_face_ccd(p0, p1, a0, a1, b0, b1, c0, c1, h);
    auto distance = [&](double t) {
      return closest_point_triangle(lerp(p0, p1, t), lerp(a0, a1, t), lerp(b0, b1, t), lerp(c0, c1, t)).distance;
    };
    const double motion = std::max({(a1 - a0).norm(), (b1 - b0).norm(), (c1 - c0).norm()}) + (p1 - p0).norm();
    check_against_samples(hit, distance, h, motion, outcome, "vertex-face trial " + std::to_string(trial));
    if (HasFatalFailure()) return;
  }
  // The trajectories are a mix of contacts and misses, so both properties were exercised.
  EXPECT_GT(outcome.hits, outcome.trials / 5);
  EXPECT_LT(outcome.hits, outcome.trials * 4 / 5);
}

TEST(EdgeEdgeCcd, AgreesWithBruteForceOnRandomTrajectories) {
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> sym(-1, 1);
  Outcome outcome;
  for (int trial = 0; trial < 3000; ++trial) {
    Vec3 p0 = uniform_point(rng, 0.5), p1 = uniform_point(rng, 0.5);
    Vec3 p0e = p0 + uniform_point(rng, 0.2), p1e = p1 + uniform_point(rng, 0.2);
    // The second edge passes by the first's middle: it starts `offset` from it and ends about
    // as far on the other side.
    const Vec3 middle = 0.5 * (p0 + p1) + uniform_point(rng, 0.15), half = uniform_point(rng, 0.4);
    const Vec3 offset = uniform_point(rng, 0.3);
    Vec3 q0 = middle - half + offset, q1 = middle + half + offset;
    Vec3 q0e = middle - half - offset + uniform_point(rng, 0.1), q1e = middle + half - offset + uniform_point(rng, 0.1);
    const int kind = trial % 10;
    if (kind == 0) {  // parallel edges, staying parallel
      q1 = q0 + sym(rng) * (p1 - p0);
      q1e = q0e + sym(rng) * (p1e - p0e);
    } else if (kind == 1) {  // all motion in the plane z = 0
      for (Vec3* x : {&p0, &p1, &q0, &q1, &p0e, &p1e, &q0e, &q1e}) x->z() = 0;
    } else if (kind == 2) {  // collinear edges sliding along their common line
      const Vec3 dir = (p1 - p0).normalized();
      q0 = p0 + 1.5 * dir, q1 = p0 + 2.2 * dir;
      p0e = p0, p1e = p1;
      q0e = q0 - sym(rng) * 2 * dir, q1e = q1 - (q0 - q0e);
    } else if (kind == 3) {  // a zero-length edge (a point) against an edge
      q1 = q0, q1e = q0e;
    } else if (kind == 4) {  // a rigid translation: no relative motion
      const Vec3 shift = uniform_point(rng, 0.3);
      p0e = p0 + shift, p1e = p1 + shift, q0e = q0 + shift, q1e = q1 + shift;
    } else if (kind == 5) {  // nothing moves
      p0e = p0, p1e = p1, q0e = q0, q1e = q1;
    }
    const double h = random_thickness(rng);
    const auto hit = edge_edge_ccd(p0, p0e, p1, p1e, q0, q0e, q1, q1e, h);
    auto distance = [&](double t) {
      return closest_points_segments(lerp(p0, p0e, t), lerp(p1, p1e, t), lerp(q0, q0e, t), lerp(q1, q1e, t)).distance;
    };
    const double motion = (p0e - p0).norm() + (p1e - p1).norm() + (q0e - q0).norm() + (q1e - q1).norm();
    check_against_samples(hit, distance, h, motion, outcome, "edge-edge trial " + std::to_string(trial));
    if (HasFatalFailure()) return;
  }
  EXPECT_GT(outcome.hits, outcome.trials / 5);
  EXPECT_LT(outcome.hits, outcome.trials * 4 / 5);
}

// A static triangle in z = 0: a(0,0,0), b(1,0,0), c(0,1,0).
const Vec3 kA(0, 0, 0), kB(1, 0, 0), kC(0, 1, 0);

std::optional<double> vertex_against_static(const Vec3& p0, const Vec3& p1, double h) {
  return vertex_face_ccd(p0, p1, kA, kA, kB, kB, kC, kC, h);
}

TEST(VertexFaceCcd, VertexThroughTheFace) {
  // From z = 1 to z = -1 through (0.2, 0.2): within h = 0.01 once z = 0.01, at t = 0.495.
  const auto hit = vertex_against_static(Vec3(0.2, 0.2, 1), Vec3(0.2, 0.2, -1), 0.01);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(*hit, 0.495, 1e-12);
  // Thickness 0: the crossing itself.
  const auto exact = vertex_against_static(Vec3(0.2, 0.2, 1), Vec3(0.2, 0.2, -1), 0.0);
  ASSERT_TRUE(exact);
  EXPECT_NEAR(*exact, 0.5, 1e-12);
  // At 5 m/s for a 5 ms step (2.5 cm), through a 1 mm thickness: no tunnelling.
  const auto fast = vertex_against_static(Vec3(0.3, 0.3, 0.0125), Vec3(0.3, 0.3, -0.0125), 0.001);
  ASSERT_TRUE(fast);
  EXPECT_NEAR(*fast, (0.0125 - 0.001) / 0.025, 1e-12);
}

TEST(VertexFaceCcd, VertexSlidingInThePlane) {
  // In the plane z = 0 at y = 0.2, x from 2 to -1: within h of edge bc (x + y = 1) once
  // x = 0.8 + h sqrt(2).
  const double h = 0.01;
  const auto hit = vertex_against_static(Vec3(2, 0.2, 0), Vec3(-1, 0.2, 0), h);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(*hit, (2 - (0.8 + h * std::sqrt(2.0))) / 3, 1e-12);
  // Sliding parallel to edge ab at 2h below it never comes within h.
  EXPECT_FALSE(vertex_against_static(Vec3(-1, -2 * h, 0), Vec3(2, -2 * h, 0), h));
  // ... and at h/2 below it does, from where x reaches -h sqrt(3)/2 (the sphere round a).
  const auto graze = vertex_against_static(Vec3(-1, -h / 2, 0), Vec3(2, -h / 2, 0), h);
  ASSERT_TRUE(graze);
  EXPECT_NEAR(*graze, (1 - h * std::sqrt(0.75)) / 3, 1e-12);
}

TEST(VertexFaceCcd, VertexCrossingAnEdge) {
  // The vertex passes through the midpoint of edge ab at t = 0.5, its distance to the edge
  // sqrt(2) |t - 0.5|.
  const Vec3 p0(0.5, -0.5, 0.5), p1(0.5, 0.5, -0.5);
  const auto exact = vertex_against_static(p0, p1, 0.0);
  ASSERT_TRUE(exact);
  EXPECT_NEAR(*exact, 0.5, 1e-9);
  const double h = 0.001;
  const auto hit = vertex_against_static(p0, p1, h);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(*hit, 0.5 - h / std::sqrt(2.0), 1e-12);
  // Through a vertex: at t = 0.5 the vertex passes through a = (0, 0, 0).
  const auto corner = vertex_against_static(Vec3(-1, -1, 1), Vec3(1, 1, -1), 0.0);
  ASSERT_TRUE(corner);
  EXPECT_NEAR(*corner, 0.5, 1e-9);
}

TEST(VertexFaceCcd, NoMotionAndCommonMotion) {
  const Vec3 p(0.2, 0.2, 0.005);
  EXPECT_EQ(vertex_against_static(p, p, 0.01), 0.0);
  EXPECT_FALSE(vertex_against_static(p, p, 0.004));
  // Moving together, at 5 mm apart all along.
  const Vec3 s(0.3, -0.1, 0.7);
  EXPECT_FALSE(vertex_face_ccd(p, p + s, kA, kA + s, kB, kB + s, kC, kC + s, 0.004));
  EXPECT_EQ(vertex_face_ccd(p, p + s, kA, kA + s, kB, kB + s, kC, kC + s, 0.006), 0.0);
}

TEST(VertexFaceCcd, TriangleMovingOntoAVertex) {
  // The triangle rises from z = -1 to z = 1 under a static vertex at z = 0.5: within h
  // once z = 0.5 - h.
  const Vec3 up(0, 0, 2), down(0, 0, -1);
  const Vec3 p(0.25, 0.25, 0.5);
  const auto hit =
      vertex_face_ccd(p, p, kA + down, kA + down + up, kB + down, kB + down + up, kC + down, kC + down + up, 0.02);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(*hit, (1.5 - 0.02) / 2, 1e-12);
}

TEST(EdgeEdgeCcd, CrossingEdges) {
  // Along x at z = 0, along y from z = 1 to z = -1: within h once z = h.
  const Vec3 p0(-1, 0, 0), p1(1, 0, 0);
  const double h = 0.005;
  const auto hit = edge_edge_ccd(p0, p0, p1, p1, Vec3(0.3, -1, 1), Vec3(0.3, -1, -1), Vec3(0.3, 1, 1),
                                 Vec3(0.3, 1, -1), h);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(*hit, (1 - h) / 2, 1e-12);
  // Passing beyond the end of the first edge (at x = 1.5): never within h.
  EXPECT_FALSE(edge_edge_ccd(p0, p0, p1, p1, Vec3(1.5, -1, 1), Vec3(1.5, -1, -1), Vec3(1.5, 1, 1),
                             Vec3(1.5, 1, -1), h));
}

TEST(EdgeEdgeCcd, ParallelEdges) {
  // Parallel edges approaching side by side: within h once the gap is h.
  const Vec3 p0(0, 0, 0), p1(1, 0, 0);
  const double h = 0.01;
  const auto hit = edge_edge_ccd(p0, p0, p1, p1, Vec3(0.2, 1, 0), Vec3(0.2, -1, 0), Vec3(0.8, 1, 0),
                                 Vec3(0.8, -1, 0), h);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(*hit, (1 - h) / 2, 1e-12);
  // Collinear, the second sliding along the line towards the first: within h once its near
  // end is at x = 1 + h.
  const auto slide = edge_edge_ccd(p0, p0, p1, p1, Vec3(2, 0, 0), Vec3(-0.5, 0, 0), Vec3(3, 0, 0),
                                   Vec3(0.5, 0, 0), h);
  ASSERT_TRUE(slide);
  EXPECT_NEAR(*slide, (2 - (1 + h)) / 2.5, 1e-12);
  // Parallel, passing at 2h: no contact; at h/2: contact.
  EXPECT_FALSE(edge_edge_ccd(p0, p0, p1, p1, Vec3(-3, 2 * h, 0), Vec3(3, 2 * h, 0), Vec3(-2, 2 * h, 0),
                             Vec3(4, 2 * h, 0), h));
  EXPECT_TRUE(edge_edge_ccd(p0, p0, p1, p1, Vec3(-3, h / 2, 0), Vec3(3, h / 2, 0), Vec3(-2, h / 2, 0),
                            Vec3(4, h / 2, 0), h));
}

TEST(EdgeEdgeCcd, ZeroLengthEdgeAndNoMotion) {
  const Vec3 p0(0, 0, 0), p1(1, 0, 0);
  // A point (zero-length edge) falling onto the edge's middle from y = 1 to y = -1.
  const auto hit = edge_edge_ccd(p0, p0, p1, p1, Vec3(0.5, 1, 0), Vec3(0.5, -1, 0), Vec3(0.5, 1, 0),
                                 Vec3(0.5, -1, 0), 0.01);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(*hit, 0.495, 1e-12);
  const Vec3 q0(0.5, 0.003, 0.1), q1(0.5, 0.003, -0.1);
  EXPECT_EQ(edge_edge_ccd(p0, p0, p1, p1, q0, q0, q1, q1, 0.01), 0.0);
  EXPECT_FALSE(edge_edge_ccd(p0, p0, p1, p1, q0, q0, q1, q1, 0.002));
}

}  // namespace
}  // namespace weft
