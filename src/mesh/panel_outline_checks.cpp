#include "mesh/panel_outline_checks.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <tuple>

#include "mesh/exact_predicates.hpp"
#include "weft/error.hpp"

namespace weft {
namespace {

const std::vector<Vec2>& ring_points(const PanelOutline& outline, int ring) {
  return ring == 0 ? outline.outer : outline.holes[ring - 1];
}

std::string point_text(const Vec2& p) {
  std::ostringstream s;
  s << "(" << p.x() << ", " << p.y() << ")";
  return s.str();
}

[[noreturn]] void refuse(const std::string& what) { throw InputError("panel outline: " + what); }

struct Segment {
  int ring, index;  // joins point index and index + 1 (cyclically) of the ring
  Vec2 a, b;
};

bool on_closed_segment(const Vec2& a, const Vec2& b, const Vec2& p) {
  return orientation_sign(a, b, p) == 0 && std::min(a.x(), b.x()) <= p.x() &&
         p.x() <= std::max(a.x(), b.x()) && std::min(a.y(), b.y()) <= p.y() &&
         p.y() <= std::max(a.y(), b.y());
}

bool closed_segments_meet(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  const int abc = orientation_sign(a, b, c), abd = orientation_sign(a, b, d);
  const int cda = orientation_sign(c, d, a), cdb = orientation_sign(c, d, b);
  if (abc * abd < 0 && cda * cdb < 0) return true;
  return on_closed_segment(a, b, c) || on_closed_segment(a, b, d) || on_closed_segment(c, d, a) ||
         on_closed_segment(c, d, b);
}

// A point where two segments that meet have in common.
Vec2 meeting_point(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  // Neighbours share an end: the point where one folds back over the other says more.
  const std::array<std::tuple<Vec2, Vec2, Vec2>, 4> ends{std::tuple{c, a, b}, std::tuple{d, a, b},
                                                         std::tuple{a, c, d}, std::tuple{b, c, d}};
  for (const auto& [p, q, r] : ends)
    if (on_closed_segment(q, r, p) && p != q && p != r) return p;
  for (const auto& [p, q, r] : ends)
    if (on_closed_segment(q, r, p)) return p;
  const Vec2 ab = b - a, cd = d - c;
  const double t =
      ((c - a).x() * cd.y() - (c - a).y() * cd.x()) / (ab.x() * cd.y() - ab.y() * cd.x());
  return a + t * ab;
}

// Even-odd test; p is not on the ring (the segment checks rule that out).
bool inside_ring(const std::vector<Vec2>& ring, const Vec2& p) {
  bool inside = false;
  for (size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
    const Vec2& a = ring[j];
    const Vec2& b = ring[i];
    if ((a.y() > p.y()) != (b.y() > p.y())) {
      // Crossing to the right of p: orientation decides it exactly.
      const int side = orientation_sign(a, b, p);
      if ((b.y() > a.y()) ? side > 0 : side < 0) inside = !inside;
    }
  }
  return inside;
}

double signed_area(const std::vector<Vec2>& ring) {
  double twice = 0;
  for (size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++)
    twice += ring[j].x() * ring[i].y() - ring[i].x() * ring[j].y();
  return 0.5 * twice;
}

}  // namespace

std::string outline_point_name(int ring, int index) {
  return (ring == 0 ? std::string("outer") : "hole " + std::to_string(ring - 1)) + " point " +
         std::to_string(index);
}

void check_panel_outline(const PanelOutline& outline) {
  const int rings = 1 + static_cast<int>(outline.holes.size());
  struct Named {
    Vec2 p;
    int ring, index;
  };
  std::vector<Named> all;
  for (int r = 0; r < rings; ++r) {
    const auto& pts = ring_points(outline, r);
    const std::string name =
        r == 0 ? std::string("the outer boundary") : "hole " + std::to_string(r - 1);
    if (pts.size() < 3)
      refuse(name + " has " + std::to_string(pts.size()) + " points; expected at least 3");
    for (int i = 0; i < static_cast<int>(pts.size()); ++i) {
      if (!std::isfinite(pts[i].x()) || !std::isfinite(pts[i].y()))
        refuse(outline_point_name(r, i) + " is not finite: " + point_text(pts[i]));
      all.push_back({pts[i], r, i});
    }
  }
  std::sort(all.begin(), all.end(), [](const Named& a, const Named& b) {
    if (a.p.x() != b.p.x()) return a.p.x() < b.p.x();
    if (a.p.y() != b.p.y()) return a.p.y() < b.p.y();
    return std::make_pair(a.ring, a.index) < std::make_pair(b.ring, b.index);
  });
  for (size_t k = 1; k < all.size(); ++k)
    if (all[k].p == all[k - 1].p)
      refuse(outline_point_name(all[k].ring, all[k].index) + " repeats " +
             outline_point_name(all[k - 1].ring, all[k - 1].index) + " at " + point_text(all[k].p) +
             "; expected distinct points (no closing point)");
  // Segments against segments, swept along x so that only overlapping x ranges are compared.
  std::vector<Segment> segments;
  for (int r = 0; r < rings; ++r) {
    const auto& pts = ring_points(outline, r);
    const int n = static_cast<int>(pts.size());
    for (int i = 0; i < n; ++i) segments.push_back({r, i, pts[i], pts[(i + 1) % n]});
  }
  std::sort(segments.begin(), segments.end(), [](const Segment& s, const Segment& t) {
    return std::min(s.a.x(), s.b.x()) < std::min(t.a.x(), t.b.x());
  });
  bool found = false;
  std::tuple<int, int, int, int> found_order;
  size_t found_first = 0, found_second = 0;  // indices into segments
  for (size_t i = 0; i < segments.size(); ++i) {
    const Segment& s = segments[i];
    const double s_max_x = std::max(s.a.x(), s.b.x());
    for (size_t j = i + 1; j < segments.size(); ++j) {
      const Segment& t = segments[j];
      if (std::min(t.a.x(), t.b.x()) > s_max_x) break;
      bool meet;
      if (s.ring == t.ring && (s.b == t.a || t.b == s.a)) {
        // Neighbours share one end; they must not fold back over each other.
        const Vec2& shared = s.b == t.a ? s.b : s.a;
        const Vec2& s_far = s.b == t.a ? s.a : s.b;
        const Vec2& t_far = s.b == t.a ? t.b : t.a;
        meet = (s.b == t.a && t.b == s.a) ||  // a ring of two segments
               on_closed_segment(shared, s_far, t_far) || on_closed_segment(shared, t_far, s_far);
      } else {
        meet = closed_segments_meet(s.a, s.b, t.a, t.b);
      }
      if (!meet) continue;
      // Of all meeting pairs, the one named first in outline order is reported, whatever the
      // sort left in which order.
      const bool s_first = std::make_pair(s.ring, s.index) < std::make_pair(t.ring, t.index);
      const Segment& first = s_first ? s : t;
      const Segment& second = s_first ? t : s;
      const size_t first_index = s_first ? i : j, second_index = s_first ? j : i;
      const auto order = std::make_tuple(first.ring, first.index, second.ring, second.index);
      if (!found || order < found_order) {
        found = true;
        found_order = order;
        found_first = first_index;
        found_second = second_index;
      }
    }
  }
  if (found) {
    const Segment& first = segments[found_first];
    const Segment& second = segments[found_second];
    auto next_index = [&](const Segment& s) {
      return (s.index + 1) % static_cast<int>(ring_points(outline, s.ring).size());
    };
    refuse("segment from " + outline_point_name(first.ring, first.index) + " to point " +
           std::to_string(next_index(first)) + " meets segment from " +
           outline_point_name(second.ring, second.index) + " to point " +
           std::to_string(next_index(second)) + " at " +
           point_text(meeting_point(first.a, first.b, second.a, second.b)) +
           "; expected a simple outline (no crossing or touching segments)");
  }
  // A simple ring always encloses some area; this guards the meshing against the impossible.
  for (int r = 0; r < rings; ++r) {
    const double area = signed_area(ring_points(outline, r));
    if (!(std::abs(area) > 0))
      refuse((r == 0 ? std::string("the outer boundary") : "hole " + std::to_string(r - 1)) +
             " has zero area");
  }

  for (int h = 1; h < rings; ++h) {
    const Vec2& p = outline.holes[h - 1][0];
    if (!inside_ring(outline.outer, p))
      refuse("hole " + std::to_string(h - 1) +
             " lies outside the outer boundary (its point 0 is at " + point_text(p) + ")");
    for (int other = 1; other < rings; ++other)
      if (other != h && inside_ring(outline.holes[other - 1], p))
        refuse("hole " + std::to_string(h - 1) + " lies inside hole " + std::to_string(other - 1));
  }
}

}  // namespace weft
