// Closest points of a point and a triangle and of two segments, against dense sampling: no
// sampled point is nearer than the answer, and the nearest sample is as near as the sampling
// allows.
#include <gtest/gtest.h>

#include <random>

#include "collision/geometry.hpp"

namespace weft {
namespace {

Vec3 random_point(std::mt19937& rng, double scale = 1.0) {
  std::uniform_real_distribution<double> u(-scale, scale);
  return Vec3(u(rng), u(rng), u(rng));
}

TEST(ClosestPointTriangle, NoSampledPointOfTheTriangleIsNearer) {
  std::mt19937 rng(7);
  constexpr int kSamples = 80;
  for (int trial = 0; trial < 300; ++trial) {
    const Vec3 a = random_point(rng), b = random_point(rng), c = random_point(rng), p = random_point(rng, 1.5);
    const PointTriangleClosest r = closest_point_triangle(p, a, b, c);
    // The answer is a point of the triangle with the weights it reports.
    EXPECT_NEAR(r.weights.sum(), 1.0, 1e-12);
    EXPECT_GE(r.weights.minCoeff(), 0.0);
    EXPECT_LT((r.point - (r.weights[0] * a + r.weights[1] * b + r.weights[2] * c)).norm(), 1e-12);
    EXPECT_NEAR(r.distance, (p - r.point).norm(), 1e-14);
    double nearest_sample = 1e300;
    for (int i = 0; i <= kSamples; ++i)
      for (int j = 0; i + j <= kSamples; ++j) {
        const double u = double(i) / kSamples, v = double(j) / kSamples;
        const double d = (p - ((1 - u - v) * a + u * b + v * c)).norm();
        EXPECT_GE(d, r.distance - 1e-12);
        nearest_sample = std::min(nearest_sample, d);
      }
    // The grid's points lie within one cell (at most the longest edge / kSamples) of every
    // point of the triangle.
    const double cell = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()}) / kSamples;
    EXPECT_LE(nearest_sample - r.distance, cell);
  }
}

TEST(ClosestPointTriangle, ReportsTheFeature) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  auto feature = [&](const Vec3& p) { return closest_point_triangle(p, a, b, c).feature; };
  EXPECT_EQ(feature(Vec3(0.2, 0.2, 0.5)), (TriangleFeature{FeatureKind::kFace, 0}));
  EXPECT_EQ(feature(Vec3(0.5, -1, 0.3)), (TriangleFeature{FeatureKind::kEdge, 0}));
  EXPECT_EQ(feature(Vec3(1, 1, 0)), (TriangleFeature{FeatureKind::kEdge, 1}));
  EXPECT_EQ(feature(Vec3(-1, 0.5, 0)), (TriangleFeature{FeatureKind::kEdge, 2}));
  EXPECT_EQ(feature(Vec3(-1, -1, 1)), (TriangleFeature{FeatureKind::kVertex, 0}));
  EXPECT_EQ(feature(Vec3(2, -0.5, 0)), (TriangleFeature{FeatureKind::kVertex, 1}));
  EXPECT_EQ(feature(Vec3(-0.5, 2, -1)), (TriangleFeature{FeatureKind::kVertex, 2}));
  const PointTriangleClosest above = closest_point_triangle(Vec3(0.25, 0.5, -2), a, b, c);
  EXPECT_NEAR(above.distance, 2.0, 1e-15);
  EXPECT_NEAR(above.weights[1], 0.25, 1e-15);
  EXPECT_NEAR(above.weights[2], 0.5, 1e-15);
}

TEST(ClosestPointTriangle, ZeroAreaTriangleIsItsEdges) {
  // Collinear vertices: the nearest point lies on the segment they span.
  const Vec3 a(0, 0, 0), b(2, 0, 0), c(1, 0, 0);
  const PointTriangleClosest r = closest_point_triangle(Vec3(1.5, 1, 0), a, b, c);
  EXPECT_NEAR(r.distance, 1.0, 1e-15);
  EXPECT_NEAR(r.point.x(), 1.5, 1e-15);
  const PointTriangleClosest point = closest_point_triangle(Vec3(0, 3, 4), a, a, a);
  EXPECT_NEAR(point.distance, 5.0, 1e-15);
}

// Random segments, a third of them parallel and some of zero length.
void random_segments(std::mt19937& rng, int trial, Vec3& p0, Vec3& p1, Vec3& q0, Vec3& q1) {
  p0 = random_point(rng);
  p1 = random_point(rng);
  q0 = random_point(rng);
  q1 = random_point(rng);
  std::uniform_real_distribution<double> u(-2, 2);
  switch (trial % 6) {
    case 0:  // parallel
      q1 = q0 + u(rng) * (p1 - p0);
      break;
    case 1:  // collinear, overlapping or not
      q0 = p0 + u(rng) * (p1 - p0);
      q1 = p0 + u(rng) * (p1 - p0);
      break;
    case 2:  // one segment a point
      q1 = q0;
      break;
    case 3:  // both points
      p1 = p0;
      q1 = q0;
      break;
    default:
      break;
  }
}

TEST(ClosestPointsSegments, NoSampledPairIsNearer) {
  std::mt19937 rng(11);
  constexpr int kSamples = 120;
  for (int trial = 0; trial < 600; ++trial) {
    Vec3 p0, p1, q0, q1;
    random_segments(rng, trial, p0, p1, q0, q1);
    const SegmentSegmentClosest r = closest_points_segments(p0, p1, q0, q1);
    ASSERT_GE(r.s, 0.0);
    ASSERT_LE(r.s, 1.0);
    ASSERT_GE(r.t, 0.0);
    ASSERT_LE(r.t, 1.0);
    EXPECT_LT((r.point_p - (p0 + r.s * (p1 - p0))).norm(), 1e-14);
    EXPECT_LT((r.point_q - (q0 + r.t * (q1 - q0))).norm(), 1e-14);
    EXPECT_NEAR(r.distance, (r.point_p - r.point_q).norm(), 1e-14);
    double nearest_sample = 1e300;
    for (int i = 0; i <= kSamples; ++i)
      for (int j = 0; j <= kSamples; ++j) {
        const double d = ((p0 + (p1 - p0) * i / kSamples) - (q0 + (q1 - q0) * j / kSamples)).norm();
        EXPECT_GE(d, r.distance - 1e-12) << "trial " << trial;
        nearest_sample = std::min(nearest_sample, d);
      }
    const double cell = ((p1 - p0).norm() + (q1 - q0).norm()) / kSamples;
    EXPECT_LE(nearest_sample - r.distance, cell) << "trial " << trial;
  }
}

TEST(ClosestPointsSegments, ParallelAndCrossingCases) {
  // Parallel, overlapping in x from 0.5 to 1: distance 1 (the gap in y).
  const auto par = closest_points_segments(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5, 1, 0), Vec3(2, 1, 0));
  EXPECT_NEAR(par.distance, 1.0, 1e-15);
  // Parallel, not overlapping: the nearest endpoints.
  const auto apart = closest_points_segments(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(4, 4, 0), Vec3(5, 4, 0));
  EXPECT_NEAR(apart.distance, 5.0, 1e-15);
  EXPECT_EQ(apart.s, 1.0);
  EXPECT_EQ(apart.t, 0.0);
  // Skew, the common perpendicular inside both: distance 2 between (0.5,0,0) and (0.5,0,2).
  const auto skew = closest_points_segments(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5, -1, 2), Vec3(0.5, 1, 2));
  EXPECT_NEAR(skew.distance, 2.0, 1e-15);
  EXPECT_NEAR(skew.s, 0.5, 1e-15);
  EXPECT_NEAR(skew.t, 0.5, 1e-15);
}

}  // namespace
}  // namespace weft
