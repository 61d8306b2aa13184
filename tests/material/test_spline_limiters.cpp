// The stress-strain spline stays between its data on every segment (docs/method.md 5: monotone
// piecewise cubics). A Hermite segment from y0 to y1 (step d = y1 - y0) with end slopes s0,
// s1 (per segment length) is monotone only if both are at most 3 d (Fritsch-Carlson): the
// interior slopes are limited by a weighted harmonic mean of the neighbouring secants, the
// end slopes to three times the end secant where the data turn. Tables where unlimited
// slopes would exceed that bound make the segment overshoot.
#include <gtest/gtest.h>

#include <algorithm>

#include "weft/material.hpp"

using namespace weft;

namespace {

/// Checks that on every segment of `c` the stress runs monotonically between the segment's
/// end values.
void expect_between_the_data(const StressCurve& c, const char* what) {
  const auto& x = c.strain_points();
  const auto& y = c.stress_points();
  for (size_t k = 0; k + 1 < x.size(); ++k) {
    const double lo = std::min(y[k], y[k + 1]), hi = std::max(y[k], y[k + 1]);
    const double sign = y[k + 1] > y[k] ? 1 : -1;
    double previous = y[k];
    for (int i = 1; i <= 400; ++i) {
      const double e = x[k] + (x[k + 1] - x[k]) * i / 400;
      const double s = c.stress(e);
      EXPECT_GE(s, lo - 1e-12 * hi) << what << ", segment " << k << ", strain " << e;
      EXPECT_LE(s, hi + 1e-12 * hi) << what << ", segment " << k << ", strain " << e;
      EXPECT_GE(sign * (s - previous), -1e-12 * hi) << what << ", segment " << k << ", strain " << e;
      previous = s;
    }
  }
}

}  // namespace

TEST(SplineLimiters, InteriorSlopesKeepSteepeningDataMonotone) {
  // Secants 100 then 900: their mean (500) is five times the first segment's secant, the
  // harmonic mean (180) under three times.
  expect_between_the_data(StressCurve::tabulated({0.0, 0.01, 0.02, 0.03}, {0.0, 1.0, 10.0, 11.0}), "steepening");
  expect_between_the_data(StressCurve::tabulated({0.0, 0.01, 0.02, 0.03}, {0.0, 1.0, 10.0, 25.0}), "stiffening");
}

TEST(SplineLimiters, EndSlopesKeepTheEndSegmentsMonotoneWhereTheDataTurn) {
  // The last segment rises by 1 after a fall of 5: the three-point end slope, (3 d0 - d1) / 2
  // = 4 per segment, is beyond 3 d0 = 3. The same mirrored at the first end.
  expect_between_the_data(StressCurve::tabulated({0.0, 0.01, 0.02, 0.03}, {0.0, 5.0, 0.0, 1.0}), "last end");
  expect_between_the_data(StressCurve::tabulated({0.0, 0.01, 0.02, 0.03}, {1.0, 0.0, 5.0, 0.0}), "first end");
}
