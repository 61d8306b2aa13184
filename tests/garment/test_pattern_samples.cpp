// Every sample pattern in data/patterns reads, gives simple counter-clockwise outlines, and
// stitch sides that share counts and points with the outlines.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "weft/garment/pattern.hpp"
#include "garment/sample_patterns.hpp"

namespace weft {
namespace {

/// Target segment length of these checks: the mesh size a garment scene uses by default.
constexpr double kTarget_m = 0.015;

std::vector<std::string> sample_files() { return test::sample_pattern_files(); }

double polyline_length(const std::vector<Vec2>& pts) {
  double sum = 0;
  for (size_t k = 1; k < pts.size(); ++k) sum += (pts[k] - pts[k - 1]).norm();
  return sum;
}

/// The points of an edge as its outline span lists them, turned back into the edge's direction.
std::vector<Vec2> span_points(const SampledOutline& outline, int edge) {
  const EdgeSpan& span = outline.edges[static_cast<size_t>(edge)];
  const size_t n = outline.points_m.size();
  std::vector<Vec2> pts;
  for (int k = 0; k <= span.segments; ++k) pts.push_back(outline.points_m[(static_cast<size_t>(span.first + k)) % n]);
  if (outline.reversed) std::reverse(pts.begin(), pts.end());
  return pts;
}

TEST(PatternSamples, AllTenFilesArePresent) { EXPECT_EQ(sample_files().size(), 10u); }  // nine copied, the derived coat

TEST(PatternSamples, OutlinesAreClosedCounterClockwiseAndSimple) {
  for (const std::string& file : sample_files()) {
    SCOPED_TRACE(file);
    const Pattern pattern = load_pattern(file);
    ASSERT_FALSE(pattern.panels.empty());
    const EdgeSegmentCounts counts = edge_segment_counts(pattern, kTarget_m);
    const std::vector<SampledOutline> outlines = pattern_outlines(pattern, counts);
    for (size_t p = 0; p < pattern.panels.size(); ++p) {
      const Panel& panel = pattern.panels[p];
      const SampledOutline& outline = outlines[p];
      SCOPED_TRACE(panel.name);
      EXPECT_GT(polygon_area_m2(outline.points_m), 0);
      EXPECT_EQ(polygon_self_intersection(outline.points_m)[0], -1);
      EXPECT_EQ(outline.reversed, panel.clockwise);
      // The edges' spans tile the closed polygon: each starts where the previous one (in the
      // outline's direction) ended, and the segments add up to the number of points.
      int total = 0;
      const int n_points = static_cast<int>(outline.points_m.size());
      const int n_edges = static_cast<int>(panel.edges.size());
      for (int e = 0; e < n_edges; ++e) {
        const EdgeSpan& span = outline.edges[static_cast<size_t>(e)];
        total += span.segments;
        const int next = outline.reversed ? (e + n_edges - 1) % n_edges : (e + 1) % n_edges;
        EXPECT_EQ((span.first + span.segments) % n_points, outline.edges[static_cast<size_t>(next)].first);
        // The span holds exactly the edge's samples, starting and ending at its corners.
        const std::vector<Vec2> pts = span_points(outline, e);
        EXPECT_EQ(pts, sample_curve(panel.edges[static_cast<size_t>(e)].curve, span.segments));
        EXPECT_EQ(pts.front(), panel.vertices_m[static_cast<size_t>(panel.edges[static_cast<size_t>(e)].start_vertex)]);
        EXPECT_EQ(pts.back(), panel.vertices_m[static_cast<size_t>(panel.edges[static_cast<size_t>(e)].end_vertex)]);
      }
      EXPECT_EQ(total, n_points);
      // No point is repeated (in particular not at the edge joins).
      std::vector<std::array<double, 2>> sorted;
      for (const Vec2& v : outline.points_m) sorted.push_back({v.x(), v.y()});
      std::sort(sorted.begin(), sorted.end());
      EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end());
    }
  }
}

bool inside_polygon(const std::vector<Vec2>& poly, const Vec2& p) {
  bool inside = false;
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Vec2 &a = poly[i], &b = poly[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) && p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
      inside = !inside;
  }
  return inside;
}

// The samples' circular arcs are the necklines of the hoody and the jumpsuit: a neckline is
// scooped out of its panel, so each arc's middle lies inside the polygon of the panel's
// corners. With the arc's "right" flag read the other way round they would all bulge out.
TEST(PatternSamples, NecklineArcsCurveIntoTheirPanels) {
  int arcs = 0;
  for (const std::string& file : sample_files()) {
    const Pattern pattern = load_pattern(file);
    for (const Panel& panel : pattern.panels) {
      std::vector<Vec2> corners;
      for (const PanelEdge& e : panel.edges) corners.push_back(panel.vertices_m[static_cast<size_t>(e.start_vertex)]);
      for (size_t e = 0; e < panel.edges.size(); ++e) {
        if (panel.edges[e].curve.kind != CurveKind::kArc) continue;
        ++arcs;
        EXPECT_TRUE(inside_polygon(corners, curve_point(panel.edges[e].curve, 0.5))) << file << " " << panel.name << " edge " << e;
      }
    }
  }
  EXPECT_EQ(arcs, 8);
}

TEST(PatternSamples, StitchSidesShareCountsPointsAndLengths) {
  int intended_equal = 0;
  for (const std::string& file : sample_files()) {
    SCOPED_TRACE(file);
    const Pattern pattern = load_pattern(file);
    const EdgeSegmentCounts counts = edge_segment_counts(pattern, kTarget_m);
    const std::vector<SampledOutline> outlines = pattern_outlines(pattern, counts);
    for (size_t i = 0; i < pattern.stitches.size(); ++i) {
      const Stitch& s = pattern.stitches[i];
      SCOPED_TRACE("stitch " + std::to_string(i));
      const StitchPoints pts = sample_stitch(pattern, s, counts);
      const size_t pa = static_cast<size_t>(s.a.panel), pb = static_cast<size_t>(s.b.panel);
      const size_t ea = static_cast<size_t>(s.a.edge), eb = static_cast<size_t>(s.b.edge);
      ASSERT_EQ(counts[pa][ea], counts[pb][eb]);
      ASSERT_EQ(pts.a.size(), pts.b.size());
      // The very points of the outlines.
      EXPECT_EQ(pts.a, span_points(outlines[pa], s.a.edge));
      std::vector<Vec2> b_in_edge_order = pts.b;
      if (!s.same_direction) std::reverse(b_in_edge_order.begin(), b_in_edge_order.end());
      EXPECT_EQ(b_in_edge_order, span_points(outlines[pb], s.b.edge));

      // Both sides at equal arc length: every chord is the side's length / n, less the
      // chord's shortfall on a curve (under 1% on these gentle curves at 1.5 cm).
      const double la = curve_length_m(pattern.panels[pa].edges[ea].curve);
      const double lb = curve_length_m(pattern.panels[pb].edges[eb].curve);
      const double n = static_cast<double>(pts.a.size() - 1);
      for (size_t k = 0; k + 1 < pts.a.size(); ++k) {
        const double ca = (pts.a[k + 1] - pts.a[k]).norm(), cb = (pts.b[k + 1] - pts.b[k]).norm();
        EXPECT_LE(ca, la / n * (1 + 1e-9));
        EXPECT_GE(ca, la / n * 0.99);
        EXPECT_LE(cb, lb / n * (1 + 1e-9));
        EXPECT_GE(cb, lb / n * 0.99);
      }
      // The sampled sides keep the pattern's ratio of lengths to within the sampling
      // tolerance (the chords' shortfall on curves): equal where the pattern means them equal.
      const double ratio = la / lb;
      EXPECT_NEAR(polyline_length(pts.a) / polyline_length(pts.b), ratio, 2e-3 * ratio);
      if (std::abs(ratio - 1) <= 1e-3) {
        ++intended_equal;
      } else {
        // The pattern eases or gathers one side into the other: report its own ratio.
        std::printf("  %s: stitch %zu (%s edge %d, %s edge %d): lengths %.4f / %.4f m, ratio %.4f\n",
                    pattern.name.c_str(), i, pattern.panels[pa].name.c_str(), s.a.edge,
                    pattern.panels[pb].name.c_str(), s.b.edge, la, lb, ratio);
      }
    }
  }
  EXPECT_GT(intended_equal, 100);
}

}  // namespace
}  // namespace weft
