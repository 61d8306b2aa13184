// Edge curves of sewing patterns: points, exact lengths, sampling at equal arc length, panel
// outlines and stitch sides built from the same samples (docs/patterns.md, "Curves and
// sampling").
#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "weft/garment/pattern.hpp"

namespace weft {

namespace {

/// Derivative dB/dt of a Bezier edge.
Vec2 bezier_derivative(const EdgeCurve& c, double t) {
  const double u = 1 - t;
  if (c.kind == CurveKind::kQuadratic) return 2 * u * (c.control[0] - c.start) + 2 * t * (c.end - c.control[0]);
  return 3 * u * u * (c.control[0] - c.start) + 6 * u * t * (c.control[1] - c.control[0]) +
         3 * t * t * (c.end - c.control[1]);
}

double speed(const EdgeCurve& c, double t) { return bezier_derivative(c, t).norm(); }

// 10-point Gauss-Legendre rule on [-1, 1]: nodes +-x_i and weights w_i (exact for degree 19).
constexpr double kGaussX[5] = {0.1488743389816312, 0.4333953941292472, 0.6794095682990244, 0.8650633666889845,
                               0.9739065285171717};
constexpr double kGaussW[5] = {0.2955242247147529, 0.2692667193099963, 0.2190863625159820, 0.1494513491505806,
                               0.0666713443086881};

double gauss_speed(const EdgeCurve& c, double a, double b) {
  const double mid = 0.5 * (a + b), half = 0.5 * (b - a);
  double sum = 0;
  for (int i = 0; i < 5; ++i) sum += kGaussW[i] * (speed(c, mid - half * kGaussX[i]) + speed(c, mid + half * kGaussX[i]));
  return sum * half;
}

/// The integral of |B'| over [a, b] to within `tolerance`, halving where the one-interval and
/// two-interval rules disagree (the speed has a kink where B' vanishes: a cusp).
double adaptive_length(const EdgeCurve& c, double a, double b, double whole, double tolerance, int depth) {
  const double mid = 0.5 * (a + b);
  const double left = gauss_speed(c, a, mid), right = gauss_speed(c, mid, b);
  if (depth >= 40 || std::abs(left + right - whole) <= tolerance) return left + right;
  return adaptive_length(c, a, mid, left, 0.5 * tolerance, depth + 1) +
         adaptive_length(c, mid, b, right, 0.5 * tolerance, depth + 1);
}

/// The control polygon's length: an upper bound on the curve's, used to scale tolerances.
double control_polygon_length(const EdgeCurve& c) {
  if (c.kind == CurveKind::kQuadratic) return (c.control[0] - c.start).norm() + (c.end - c.control[0]).norm();
  return (c.control[0] - c.start).norm() + (c.control[1] - c.control[0]).norm() + (c.end - c.control[1]).norm();
}

constexpr double kRelativeLengthTolerance = 1e-13;

double bezier_length(const EdgeCurve& c, double a, double b) {
  const double tolerance = kRelativeLengthTolerance * control_polygon_length(c);
  return adaptive_length(c, a, b, gauss_speed(c, a, b), tolerance, 0);
}

/// Parameters of the points at arc lengths k L / n along a Bezier, k = 1..n-1: each found by
/// Newton's method on s(t) - k L / n, kept inside a bracket that bisection shrinks when a
/// Newton step leaves it.
std::vector<double> bezier_equal_length_parameters(const EdgeCurve& c, int segments) {
  const double total = bezier_length(c, 0, 1);
  const double tolerance = 1e-12 * total;
  std::vector<double> ts;
  double t_prev = 0, s_prev = 0;
  for (int k = 1; k < segments; ++k) {
    const double target = total * k / segments;
    double lo = t_prev, hi = 1;
    const double v0 = speed(c, t_prev);
    double t = v0 > 0 ? std::clamp(t_prev + (target - s_prev) / v0, lo, hi) : 0.5 * (lo + hi);
    double s = s_prev + bezier_length(c, t_prev, t);
    for (int iter = 0; iter < 100 && std::abs(s - target) > tolerance && hi - lo > 1e-15; ++iter) {
      if (s < target)
        lo = t;
      else
        hi = t;
      const double v = speed(c, t);
      double next = v > 0 ? t - (s - target) / v : 0.5 * (lo + hi);
      if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
      t = next;
      s = s_prev + bezier_length(c, t_prev, t);
    }
    ts.push_back(t);
    t_prev = t;
    s_prev = s;
  }
  return ts;
}

/// The points of `curve` sampled at `segments`, appended to `out` in the edge's direction, or
/// backwards when `backwards`, leaving out the last point appended (the next edge's first).
void append_without_last(std::vector<Vec2>& out, const EdgeCurve& curve, int segments, bool backwards) {
  std::vector<Vec2> pts = sample_curve(curve, segments);
  if (backwards) std::reverse(pts.begin(), pts.end());
  out.insert(out.end(), pts.begin(), pts.end() - 1);
}

double orient(const Vec2& a, const Vec2& b, const Vec2& c) {
  return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
}

/// p lies within the bounding box of segment ab (for collinear points: on the segment).
bool within_box(const Vec2& a, const Vec2& b, const Vec2& p) {
  return p.x() >= std::min(a.x(), b.x()) && p.x() <= std::max(a.x(), b.x()) && p.y() >= std::min(a.y(), b.y()) &&
         p.y() <= std::max(a.y(), b.y());
}

/// Closed segments ab and cd cross or touch.
bool segments_meet(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  const double o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a), o4 = orient(c, d, b);
  if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0))) return true;
  return (o1 == 0 && within_box(a, b, c)) || (o2 == 0 && within_box(a, b, d)) || (o3 == 0 && within_box(c, d, a)) ||
         (o4 == 0 && within_box(c, d, b));
}

/// Neighbouring segments ab and bc overlap beyond b: c turns straight back along ab.
bool neighbours_fold_back(const Vec2& a, const Vec2& b, const Vec2& c) {
  return orient(a, b, c) == 0 && (a - b).dot(c - b) > 0;
}

const PanelEdge& side_edge(const Pattern& pattern, const StitchSide& side) {
  return pattern.panels[static_cast<size_t>(side.panel)].edges[static_cast<size_t>(side.edge)];
}

StitchPoints sample_stitch_with(const Pattern& pattern, const Stitch& stitch, int segments) {
  StitchPoints out;
  out.a = sample_curve(side_edge(pattern, stitch.a).curve, segments);
  out.b = sample_curve(side_edge(pattern, stitch.b).curve, segments);
  if (!stitch.same_direction) std::reverse(out.b.begin(), out.b.end());
  return out;
}

}  // namespace

Vec2 curve_point(const EdgeCurve& c, double t) {
  const double u = 1 - t;
  switch (c.kind) {
    case CurveKind::kStraight:
      return u * c.start + t * c.end;
    case CurveKind::kQuadratic:
      return u * u * c.start + 2 * u * t * c.control[0] + t * t * c.end;
    case CurveKind::kCubic:
      return u * u * u * c.start + 3 * u * u * t * c.control[0] + 3 * u * t * t * c.control[1] + t * t * t * c.end;
    case CurveKind::kArc: {
      const double angle = c.start_angle_rad + t * c.sweep_rad;
      return c.center + c.radius_m * Vec2(std::cos(angle), std::sin(angle));
    }
  }
  return c.start;
}

double curve_length_m(const EdgeCurve& c) {
  switch (c.kind) {
    case CurveKind::kStraight:
      return (c.end - c.start).norm();
    case CurveKind::kArc:
      return c.radius_m * std::abs(c.sweep_rad);
    case CurveKind::kQuadratic:
    case CurveKind::kCubic:
      return bezier_length(c, 0, 1);
  }
  return 0;
}

int segment_count(const EdgeCurve& curve, double target_length_m) {
  if (!(target_length_m > 0)) throw std::invalid_argument("segment_count: the target length must be positive");
  const double n = std::ceil(curve_length_m(curve) / target_length_m);
  return std::max(1, static_cast<int>(std::min(n, 1e9)));
}

std::vector<Vec2> sample_curve(const EdgeCurve& c, int segments) {
  std::vector<Vec2> pts;
  pts.reserve(static_cast<size_t>(segments) + 1);
  pts.push_back(c.start);
  if (c.kind == CurveKind::kQuadratic || c.kind == CurveKind::kCubic) {
    for (double t : bezier_equal_length_parameters(c, segments)) pts.push_back(curve_point(c, t));
  } else {
    // Straight edges and arcs: arc length is proportional to the parameter.
    for (int k = 1; k < segments; ++k) pts.push_back(curve_point(c, static_cast<double>(k) / segments));
  }
  pts.push_back(c.end);
  return pts;
}

EdgeSegmentCounts edge_segment_counts(const Pattern& pattern, double target_length_m) {
  // Edges joined through stitches form groups (union-find over all edges); each group takes
  // its largest count.
  std::vector<size_t> offset(pattern.panels.size() + 1, 0);
  for (size_t p = 0; p < pattern.panels.size(); ++p) offset[p + 1] = offset[p] + pattern.panels[p].edges.size();
  std::vector<size_t> parent(offset.back());
  std::iota(parent.begin(), parent.end(), size_t{0});
  auto root = [&](size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  auto id = [&](const StitchSide& s) { return offset[static_cast<size_t>(s.panel)] + static_cast<size_t>(s.edge); };
  for (const Stitch& s : pattern.stitches) parent[root(id(s.a))] = root(id(s.b));

  std::vector<int> group_count(parent.size(), 1);
  EdgeSegmentCounts counts(pattern.panels.size());
  for (size_t p = 0; p < pattern.panels.size(); ++p) {
    for (const PanelEdge& e : pattern.panels[p].edges) {
      const int n = segment_count(e.curve, target_length_m);
      counts[p].push_back(n);
      int& g = group_count[root(offset[p] + counts[p].size() - 1)];
      g = std::max(g, n);
    }
  }
  for (size_t p = 0; p < pattern.panels.size(); ++p)
    for (size_t e = 0; e < counts[p].size(); ++e) counts[p][e] = group_count[root(offset[p] + e)];
  return counts;
}

SampledOutline panel_outline(const Panel& panel, const std::vector<int>& segments) {
  SampledOutline out;
  out.reversed = panel.clockwise;
  const size_t n_edges = panel.edges.size();
  out.edges.resize(n_edges);
  for (size_t k = 0; k < n_edges; ++k) {
    // A clockwise panel is walked from its last edge back to its first.
    const size_t e = panel.clockwise ? n_edges - 1 - k : k;
    out.edges[e].first = static_cast<int>(out.points_m.size());
    out.edges[e].segments = segments[e];
    append_without_last(out.points_m, panel.edges[e].curve, segments[e], panel.clockwise);
  }
  return out;
}

std::vector<SampledOutline> pattern_outlines(const Pattern& pattern, const EdgeSegmentCounts& counts) {
  std::vector<SampledOutline> out;
  for (size_t p = 0; p < pattern.panels.size(); ++p) out.push_back(panel_outline(pattern.panels[p], counts[p]));
  return out;
}

double polygon_area_m2(const std::vector<Vec2>& polygon) {
  double twice = 0;
  for (size_t i = 0; i < polygon.size(); ++i) {
    const Vec2& a = polygon[i];
    const Vec2& b = polygon[(i + 1) % polygon.size()];
    twice += a.x() * b.y() - b.x() * a.y();
  }
  return 0.5 * twice;
}

std::array<int, 2> polygon_self_intersection(const std::vector<Vec2>& poly) {
  const int n = static_cast<int>(poly.size());
  auto point = [&](int i) -> const Vec2& { return poly[static_cast<size_t>(i % n)]; };
  // Sweep over segments sorted by their smallest x; a pair is tested when their x ranges overlap.
  std::vector<int> order(static_cast<size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  auto min_x = [&](int i) { return std::min(point(i).x(), point(i + 1).x()); };
  auto max_x = [&](int i) { return std::max(point(i).x(), point(i + 1).x()); };
  std::sort(order.begin(), order.end(), [&](int a, int b) { return min_x(a) < min_x(b) || (min_x(a) == min_x(b) && a < b); });
  for (size_t u = 0; u < order.size(); ++u) {
    const int i = order[u];
    for (size_t w = u + 1; w < order.size() && min_x(order[w]) <= max_x(i); ++w) {
      const int j = order[w];
      const int lo = std::min(i, j), hi = std::max(i, j);
      const bool meet = hi == lo + 1 ? neighbours_fold_back(point(lo), point(hi), point(hi + 1))
                        : (lo == 0 && hi == n - 1) ? neighbours_fold_back(point(hi), point(0), point(1))
                                                   : segments_meet(point(lo), point(lo + 1), point(hi), point(hi + 1));
      if (meet) return {lo, hi};
    }
  }
  return {-1, -1};
}

StitchPoints sample_stitch(const Pattern& pattern, const Stitch& stitch, const EdgeSegmentCounts& counts) {
  const int na = counts[static_cast<size_t>(stitch.a.panel)][static_cast<size_t>(stitch.a.edge)];
  const int nb = counts[static_cast<size_t>(stitch.b.panel)][static_cast<size_t>(stitch.b.edge)];
  return sample_stitch_with(pattern, stitch, std::max(na, nb));
}

StitchPoints sample_stitch(const Pattern& pattern, const Stitch& stitch, double target_length_m) {
  return sample_stitch_with(pattern, stitch, std::max(segment_count(side_edge(pattern, stitch.a).curve, target_length_m),
                                                      segment_count(side_edge(pattern, stitch.b).curve, target_length_m)));
}

}  // namespace weft
