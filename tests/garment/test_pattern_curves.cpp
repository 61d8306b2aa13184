// Pattern edge curves: lengths against closed forms and converged polylines, sampling at
// equal arc length.
#include <gtest/gtest.h>

#include <cmath>

#include "weft/garment/pattern.hpp"

namespace weft {
namespace {

EdgeCurve quadratic(const Vec2& p0, const Vec2& p1, const Vec2& p2) {
  EdgeCurve c;
  c.kind = CurveKind::kQuadratic;
  c.start = p0;
  c.control[0] = p1;
  c.end = p2;
  return c;
}

EdgeCurve cubic(const Vec2& p0, const Vec2& p1, const Vec2& p2, const Vec2& p3) {
  EdgeCurve c;
  c.kind = CurveKind::kCubic;
  c.start = p0;
  c.control = {p1, p2};
  c.end = p3;
  return c;
}

EdgeCurve arc(const Vec2& center, double radius_m, double start_angle_rad, double sweep_rad) {
  EdgeCurve c;
  c.kind = CurveKind::kArc;
  c.center = center;
  c.radius_m = radius_m;
  c.start_angle_rad = start_angle_rad;
  c.sweep_rad = sweep_rad;
  c.start = center + radius_m * Vec2(std::cos(start_angle_rad), std::sin(start_angle_rad));
  const double end_angle = start_angle_rad + sweep_rad;
  c.end = center + radius_m * Vec2(std::cos(end_angle), std::sin(end_angle));
  return c;
}

/// Length of a quadratic Bezier in closed form: B'(t) = 2 (A t + B), so the length is the
/// integral over [0, 1] of sqrt(a t^2 + b t + c) with a = 4|A|^2, b = 8 A.B, c = 4|B|^2.
double quadratic_length_closed_form(const Vec2& p0, const Vec2& p1, const Vec2& p2) {
  const Vec2 A = p0 - 2 * p1 + p2, B = p1 - p0;
  const double a = 4 * A.squaredNorm(), b = 8 * A.dot(B), c = 4 * B.squaredNorm();
  const auto antiderivative = [&](double t) {
    const double q = std::sqrt(a * t * t + b * t + c);
    return (2 * a * t + b) * q / (4 * a) +
           (4 * a * c - b * b) / (8 * a * std::sqrt(a)) * std::log(2 * std::sqrt(a) * q + 2 * a * t + b);
  };
  return antiderivative(1) - antiderivative(0);
}

/// Length of a curve as the Richardson extrapolation of two uniform polylines (n and 2n
/// segments): the polyline's error is c2 h^2 + c4 h^4 + ..., so (4 L_2n - L_n) / 3 leaves h^4.
double converged_polyline_length(const EdgeCurve& c, int n) {
  const auto polyline = [&](int segments) {
    double sum = 0;
    Vec2 prev = curve_point(c, 0);
    for (int k = 1; k <= segments; ++k) {
      const Vec2 p = curve_point(c, static_cast<double>(k) / segments);
      sum += (p - prev).norm();
      prev = p;
    }
    return sum;
  };
  return (4 * polyline(2 * n) - polyline(n)) / 3;
}

TEST(PatternCurves, ArcLengthIsRadiusTimesAngle) {
  for (double sweep : {0.3, -1.2, M_PI, -4.5, 6.0}) {
    const EdgeCurve c = arc(Vec2(0.2, -0.1), 0.37, 0.8, sweep);
    EXPECT_NEAR(curve_length_m(c), 0.37 * std::abs(sweep), 1e-15);
    // The samples lie on the circle at equal angles.
    const std::vector<Vec2> pts = sample_curve(c, 12);
    ASSERT_EQ(pts.size(), 13u);
    for (size_t k = 0; k < pts.size(); ++k) {
      EXPECT_NEAR((pts[k] - c.center).norm(), 0.37, 1e-14);
      if (k > 0) EXPECT_NEAR((pts[k] - pts[k - 1]).norm(), 2 * 0.37 * std::sin(std::abs(sweep) / 24), 1e-14);
    }
  }
}

TEST(PatternCurves, QuadraticLengthMatchesClosedForm) {
  const std::vector<std::array<Vec2, 3>> cases = {
      {Vec2(0, 0), Vec2(0.5, 0.4), Vec2(1, 0)},
      {Vec2(0.1, 0.2), Vec2(0.9, -0.3), Vec2(0.2, 0.05)},    // strongly bent back
      {Vec2(0, 0), Vec2(0.02, 0.5), Vec2(0.04, 0)},          // a thin hairpin
  };
  for (const auto& p : cases) {
    const double exact = quadratic_length_closed_form(p[0], p[1], p[2]);
    EXPECT_NEAR(curve_length_m(quadratic(p[0], p[1], p[2])), exact, 1e-12 * exact);
  }
}

TEST(PatternCurves, CubicLengthMatchesConvergedPolyline) {
  const std::vector<EdgeCurve> cases = {
      cubic(Vec2(0, 0), Vec2(0.2, 0.5), Vec2(0.7, -0.3), Vec2(1, 0.1)),  // an S
      cubic(Vec2(0, 0), Vec2(1, 1), Vec2(0, 1), Vec2(1, 0)),             // a loop crossing itself
      cubic(Vec2(0, 0), Vec2(1, 1), Vec2(-0.5, 1), Vec2(0.5, 0)),        // a cusp-like turn
  };
  for (const EdgeCurve& c : cases) {
    const double reference = converged_polyline_length(c, 1 << 17);
    EXPECT_NEAR(curve_length_m(c), reference, 1e-9 * reference);
  }
}

TEST(PatternCurves, StraightSamplesAreEvenAndExactAtTheEnds) {
  EdgeCurve c;
  c.start = Vec2(0.1, 0.3);
  c.end = Vec2(-0.4, 1.5);
  EXPECT_DOUBLE_EQ(curve_length_m(c), 1.3);
  EXPECT_EQ(segment_count(c, 0.2), 7);  // ceil(1.3 / 0.2)
  EXPECT_EQ(segment_count(c, 5.0), 1);
  const std::vector<Vec2> pts = sample_curve(c, 7);
  ASSERT_EQ(pts.size(), 8u);
  EXPECT_EQ(pts.front(), c.start);
  EXPECT_EQ(pts.back(), c.end);
  for (size_t k = 1; k < pts.size(); ++k) EXPECT_NEAR((pts[k] - pts[k - 1]).norm(), 1.3 / 7, 1e-15);
}

/// Largest curvature |B' x B''| / |B'|^3 over the curve, from central differences.
double largest_curvature(const EdgeCurve& c) {
  const double h = 1e-5;
  double largest = 0;
  for (int k = 1; k < 2000; ++k) {
    const double t = k / 2000.0;
    const Vec2 d1 = (curve_point(c, t + h) - curve_point(c, t - h)) / (2 * h);
    const Vec2 d2 = (curve_point(c, t + h) - 2 * curve_point(c, t) + curve_point(c, t - h)) / (h * h);
    largest = std::max(largest, std::abs(d1.x() * d2.y() - d1.y() * d2.x()) / std::pow(d1.norm(), 3));
  }
  return largest;
}

// Samples at equal arc length: segments of (nearly) equal chords, even where the curve's
// parameter speed varies by a large factor (equal parameter steps would fail this).
TEST(PatternCurves, BezierSamplesAreAtEqualArcLength) {
  const std::vector<EdgeCurve> cases = {
      cubic(Vec2(0, 0), Vec2(0.05, 0.02), Vec2(0.9, 1.2), Vec2(1, 0)),
      quadratic(Vec2(0, 0), Vec2(0.02, 0.1), Vec2(1, 0)),
  };
  for (const EdgeCurve& c : cases) {
    // The speed |B'| at the two ends differs by more than 5x: equal parameter steps are uneven.
    const Vec2 last_control = c.kind == CurveKind::kCubic ? c.control[1] : c.control[0];
    ASSERT_GT((c.end - last_control).norm() / (c.control[0] - c.start).norm(), 5.0);

    const double length = curve_length_m(c);
    const int n = 1000;
    const std::vector<Vec2> pts = sample_curve(c, n);
    ASSERT_EQ(pts.size(), static_cast<size_t>(n + 1));
    EXPECT_EQ(pts.front(), c.start);
    EXPECT_EQ(pts.back(), c.end);
    // A chord spanning arc length s where the curvature is at most k is between
    // s (1 - k^2 s^2 / 24) and s.
    const double s = length / n;
    const double k = largest_curvature(c);
    const double chord_deficit = k * k * s * s / 24 * s;
    double chord_sum = 0;
    for (int i = 0; i < n; ++i) {
      const double chord = (pts[i + 1] - pts[i]).norm();
      EXPECT_LE(chord, s * (1 + 1e-9)) << "segment " << i;
      EXPECT_GE(chord, s - 1.01 * chord_deficit - 1e-12 * s) << "segment " << i;
      chord_sum += chord;
    }
    EXPECT_NEAR(chord_sum, length, n * chord_deficit + 1e-12);
  }
}

}  // namespace
}  // namespace weft
