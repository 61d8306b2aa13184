#include "mesh/panel_mesher.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <queue>
#include <sstream>
#include <string>
#include <unordered_set>

#include "mesh/exact_predicates.hpp"
#include "mesh/panel_outline_checks.hpp"
#include "weft/error.hpp"

namespace weft {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Edge k of a triangle joins v[(k + 1) % 3] and v[(k + 2) % 3] and is shared with n[k]
// (-1 across the panel boundary once the outside is removed).
struct Triangle {
  std::array<int, 3> v;
  std::array<int, 3> n;
  std::array<bool, 3> segment;  // edge k is a boundary segment
  bool alive = true;
};

int next(int k) { return k == 2 ? 0 : k + 1; }
int prev(int k) { return k == 0 ? 2 : k - 1; }

double cross(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

Vec2 circumcentre(const Vec2& a, const Vec2& b, const Vec2& c) {
  const Vec2 ab = b - a, ac = c - a;
  const double d = 2 * cross(ab, ac);
  const Vec2 offset(ac.y() * ab.squaredNorm() - ab.y() * ac.squaredNorm(),
                    ab.x() * ac.squaredNorm() - ac.x() * ab.squaredNorm());
  return a + offset / d;
}

std::string number_text(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

// Where a walk towards a point ended.
struct Location {
  enum Kind { kInside, kOnEdge, kOnVertex, kBlocked, kLost } kind;
  int triangle;
  int edge;  // kOnEdge, kBlocked: the edge of `triangle`; kOnVertex: its vertex slot
};

class Triangulation {
 public:
  std::vector<Vec2> points;
  std::vector<Triangle> triangles;
  std::vector<int> vertex_triangle;  // a triangle holding each vertex
  std::vector<int> changed;          // triangles written since the last clear

  int add_point(const Vec2& p) {
    points.push_back(p);
    vertex_triangle.push_back(-1);
    return static_cast<int>(points.size()) - 1;
  }

  void start(int a, int b, int c) {
    triangles.push_back({{a, b, c}, {-1, -1, -1}, {false, false, false}, true});
    for (int v : {a, b, c}) vertex_triangle[v] = 0;
  }

  int orient(int a, int b, const Vec2& p) const {
    return orientation_sign(points[a], points[b], p);
  }

  int slot_of(int t, int vertex) const {
    const auto& v = triangles[t].v;
    return v[0] == vertex ? 0 : v[1] == vertex ? 1 : 2;
  }
  int neighbour_slot(int t, int neighbour) const {
    const auto& n = triangles[t].n;
    return n[0] == neighbour ? 0 : n[1] == neighbour ? 1 : 2;
  }

  // Visibility walk (no regard for segments): used while the outline's points go in.
  Location locate(const Vec2& p, int t) const {
    for (size_t steps = 0; steps <= triangles.size() + 3; ++steps) {
      const Triangle& tri = triangles[t];
      int zero_edges = 0, zero_edge = -1, out = -1;
      for (int k = 0; k < 3 && out < 0; ++k) {
        const int s = orient(tri.v[next(k)], tri.v[prev(k)], p);
        if (s < 0) out = k;
        if (s == 0) ++zero_edges, zero_edge = k;
      }
      if (out >= 0) {
        t = tri.n[out];
        continue;
      }
      if (zero_edges == 0) return {Location::kInside, t, -1};
      if (zero_edges == 1) return {Location::kOnEdge, t, zero_edge};
      return {Location::kOnVertex, t, -1};
    }
    return {Location::kLost, t, -1};
  }

  // Straight walk from the centroid of triangle t to p, stopping at boundary segments.
  Location walk(int t, const Vec2& p) const {
    const auto& v0 = triangles[t].v;
    const Vec2 origin = (points[v0[0]] + points[v0[1]] + points[v0[2]]) / 3.0;
    for (size_t steps = 0; steps <= triangles.size(); ++steps) {
      const Triangle& tri = triangles[t];
      int exit = -1, zero_edges = 0, zero_edge = -1;
      for (int k = 0; k < 3; ++k) {
        const int b = tri.v[next(k)], c = tri.v[prev(k)];
        const int s = orient(b, c, p);
        if (s == 0) ++zero_edges, zero_edge = k;
        if (s < 0 && exit < 0 && orientation_sign(origin, p, points[b]) <= 0 &&
            orientation_sign(origin, p, points[c]) >= 0)
          exit = k;
      }
      if (exit < 0) {
        bool outside = false;
        for (int k = 0; k < 3; ++k) outside |= orient(tri.v[next(k)], tri.v[prev(k)], p) < 0;
        if (outside) return {Location::kLost, t, -1};
        if (zero_edges == 0) return {Location::kInside, t, -1};
        if (zero_edges == 1) return {Location::kOnEdge, t, zero_edge};
        for (int k = 0; k < 3; ++k)
          if (points[tri.v[k]] == p) return {Location::kOnVertex, t, k};
        return {Location::kLost, t, -1};
      }
      if (tri.segment[exit] || tri.n[exit] < 0) return {Location::kBlocked, t, exit};
      t = tri.n[exit];
    }
    return {Location::kLost, t, -1};
  }

  void write(int t, std::array<int, 3> v, std::array<int, 3> n, std::array<bool, 3> segment) {
    triangles[t] = {v, n, segment, true};
    for (int x : v) vertex_triangle[x] = t;
    changed.push_back(t);
  }

  void relink(int t, int old_neighbour, int new_neighbour) {
    if (t >= 0) triangles[t].n[neighbour_slot(t, old_neighbour)] = new_neighbour;
  }

  int new_triangle() {
    triangles.emplace_back();
    return static_cast<int>(triangles.size()) - 1;
  }

  // Replaces the edge k of t and its mirror by the other diagonal of their quadrilateral;
  // afterwards t = (a, b, d) and the neighbour = (a, d, c), with a = t.v[k].
  void flip(int t, int k) {
    const Triangle T = triangles[t];
    const int u = T.n[k];
    const Triangle U = triangles[u];
    const int j = neighbour_slot(u, t);
    const int a = T.v[k], b = T.v[next(k)], c = T.v[prev(k)], d = U.v[j];
    const int n_ca = T.n[next(k)], n_ab = T.n[prev(k)];
    const bool s_ca = T.segment[next(k)], s_ab = T.segment[prev(k)];
    const int n_bd = U.n[next(j)], n_dc = U.n[prev(j)];
    const bool s_bd = U.segment[next(j)], s_dc = U.segment[prev(j)];
    write(t, {a, b, d}, {n_bd, u, n_ab}, {s_bd, false, s_ab});
    write(u, {a, d, c}, {n_dc, n_ca, t}, {s_dc, s_ca, false});
    relink(n_bd, u, t);
    relink(n_ca, t, u);
  }

  bool flippable(int t, int k) const {
    const Triangle& T = triangles[t];
    const int u = T.n[k];
    if (u < 0) return false;
    const int d = triangles[u].v[neighbour_slot(u, t)];
    const Vec2& pd = points[d];
    return orient(T.v[k], T.v[next(k)], pd) > 0 &&
           orientation_sign(points[T.v[k]], pd, points[T.v[prev(k)]]) > 0;
  }

  bool locally_delaunay(int t, int k) const {
    const Triangle& T = triangles[t];
    const int u = T.n[k];
    if (u < 0 || T.segment[k]) return true;
    const int d = triangles[u].v[neighbour_slot(u, t)];
    return incircle_sign(points[T.v[0]], points[T.v[1]], points[T.v[2]], points[d]) <= 0;
  }

  // Lawson flips around the new vertex p until every edge opposite it is locally Delaunay.
  void legalize(int p, std::vector<int> stack) {
    while (!stack.empty()) {
      const int t = stack.back();
      stack.pop_back();
      const int k = slot_of(t, p);
      if (locally_delaunay(t, k)) continue;
      const int u = triangles[t].n[k];
      flip(t, k);
      stack.push_back(t);
      stack.push_back(u);
    }
  }

  void split_triangle(int t, int p) {
    const Triangle T = triangles[t];
    const int t2 = new_triangle(), t3 = new_triangle();
    const auto [a, b, c] = T.v;
    write(t, {p, b, c}, {T.n[0], t2, t3}, {T.segment[0], false, false});
    write(t2, {p, c, a}, {T.n[1], t3, t}, {T.segment[1], false, false});
    write(t3, {p, a, b}, {T.n[2], t, t2}, {T.segment[2], false, false});
    relink(T.n[1], t, t2);
    relink(T.n[2], t, t3);
    legalize(p, {t, t2, t3});
  }

  // Puts p on edge k of t (and of its mirror, if any); a segment's halves stay segments.
  void split_edge(int t, int k, int p) {
    const Triangle T = triangles[t];
    const int u = T.n[k];
    const bool seg = T.segment[k];
    const int a = T.v[k], b = T.v[next(k)], c = T.v[prev(k)];
    const int t2 = new_triangle();
    int u2 = -1;
    if (u >= 0) u2 = new_triangle();
    write(t, {a, b, p}, {u2, t2, T.n[prev(k)]}, {seg, false, T.segment[prev(k)]});
    write(t2, {a, p, c}, {u, T.n[next(k)], t}, {seg, T.segment[next(k)], false});
    relink(T.n[next(k)], t, t2);
    std::vector<int> stack{t, t2};
    if (u >= 0) {
      const Triangle U = triangles[u];
      const int j = neighbour_slot(u, t);
      const int d = U.v[j];
      write(u, {d, c, p}, {t2, u2, U.n[prev(j)]}, {seg, false, U.segment[prev(j)]});
      write(u2, {d, p, b}, {t, U.n[next(j)], u}, {seg, U.segment[next(j)], false});
      relink(U.n[next(j)], u, u2);
      stack.push_back(u);
      stack.push_back(u2);
    }
    legalize(p, stack);
  }

  // A triangle with vertex a whose wedge at a holds the direction to b, or -1 when the edge
  // (a, b) already exists (its triangle is returned in `edge_triangle`).
  int wedge_towards(int a, int b, int& edge_triangle) const {
    edge_triangle = -1;
    int t = vertex_triangle[a];
    // Turn around a (clockwise, then counter-clockwise from the start if a border is hit).
    const int start = t;
    for (int pass = 0; pass < 2; ++pass) {
      t = start;
      for (size_t steps = 0; steps < triangles.size() && t >= 0; ++steps) {
        const Triangle& T = triangles[t];
        const int k = slot_of(t, a);
        const int v1 = T.v[next(k)], v2 = T.v[prev(k)];
        if (v1 == b || v2 == b) {
          edge_triangle = t;
          return -1;
        }
        if (orient(a, v1, points[b]) > 0 && orient(a, v2, points[b]) < 0) return t;
        t = pass == 0 ? T.n[prev(k)] : T.n[next(k)];
        if (t == start) break;
      }
    }
    return -2;
  }

  // Makes (a, b) an edge by flipping the edges that cross it (Sloan's method), and marks it a
  // segment. No point lies on the open segment (the outline checks rule that out).
  void insert_segment(int a, int b) {
    int edge_triangle;
    int t = wedge_towards(a, b, edge_triangle);
    if (t == -2) throw std::logic_error("panel mesher: lost the wedge of a segment");
    if (t >= 0) {
      // The crossed edges, as vertex pairs (flips renumber the triangles).
      std::deque<std::pair<int, int>> crossing;
      int k = slot_of(t, a);  // the segment leaves t through edge k
      while (true) {
        const Triangle& T = triangles[t];
        crossing.emplace_back(T.v[next(k)], T.v[prev(k)]);
        const int u = T.n[k];
        const int j = neighbour_slot(u, t);
        const Triangle& U = triangles[u];
        const int w = U.v[j];
        if (w == b) break;
        const int side = orient(a, b, points[w]);
        k = orient(a, b, points[U.v[next(j)]]) != side ? prev(j) : next(j);
        t = u;
      }
      recover(a, b, crossing);
      wedge_towards(a, b, edge_triangle);
    }
    mark_segment(edge_triangle, a, b);
  }

  void recover(int a, int b, std::deque<std::pair<int, int>>& crossing) {
    size_t stuck = 0;
    while (!crossing.empty()) {
      const auto [x, y] = crossing.front();
      crossing.pop_front();
      int t, k;
      find_edge(x, y, t, k);
      if (!flippable(t, k)) {
        crossing.emplace_back(x, y);
        if (++stuck > 4 * crossing.size() + 16)
          throw std::logic_error("panel mesher: segment recovery stalled");
        continue;
      }
      stuck = 0;
      flip(t, k);
      const int p = triangles[t].v[0], q = triangles[t].v[2];  // the new diagonal
      const int sp = orient(a, b, points[p]), sq = orient(a, b, points[q]);
      if (p != a && p != b && q != a && q != b && sp * sq < 0) crossing.emplace_back(p, q);
    }
  }

  void find_edge(int x, int y, int& t, int& k) const {
    int edge_triangle;
    wedge_towards(x, y, edge_triangle);
    t = edge_triangle;
    const Triangle& T = triangles[t];
    for (k = 0; k < 3; ++k)
      if (T.v[k] != x && T.v[k] != y) break;
  }

  void mark_segment(int t, int a, int b) {
    const Triangle& T = triangles[t];
    int k = 0;
    for (; k < 3; ++k)
      if (T.v[k] != a && T.v[k] != b) break;
    triangles[t].segment[k] = true;
    const int u = T.n[k];
    if (u >= 0) triangles[u].segment[neighbour_slot(u, t)] = true;
  }

  // Lawson flips over the whole triangulation until every non-segment edge is locally
  // Delaunay (constrained Delaunay triangulation).
  void make_delaunay() {
    std::vector<std::pair<int, int>> stack;
    for (int t = 0; t < static_cast<int>(triangles.size()); ++t)
      for (int k = 0; k < 3; ++k) stack.emplace_back(t, triangles[t].v[k]);
    while (!stack.empty()) {
      const auto [t, apex] = stack.back();
      stack.pop_back();
      const Triangle& T = triangles[t];
      if (T.v[0] != apex && T.v[1] != apex && T.v[2] != apex) continue;
      const int k = slot_of(t, apex);
      if (locally_delaunay(t, k)) continue;
      const int u = T.n[k];
      flip(t, k);
      for (int q = 0; q < 3; ++q) {
        stack.emplace_back(t, triangles[t].v[q]);
        stack.emplace_back(u, triangles[u].v[q]);
      }
    }
  }
};

// Delaunay refinement: circumcentres of bad triangles go in, largest circumradius first.
class Refiner {
 public:
  Refiner(Triangulation& mesh, const PanelMeshOptions& options, int input_points,
          std::vector<double> corner_angle_rad)
      : mesh_(mesh),
        options_(options),
        input_points_(input_points),
        corner_angle_rad_(std::move(corner_angle_rad)) {
    const double min_angle = options.min_angle_deg * kPi / 180;
    // An equilateral triangle of edge target_edge_m has circumradius target / sqrt(3); the
    // bound is a little above so that edges come out about the target on average.
    circumradius_max_ = kCircumradiusPerEdge * options.target_edge_m;
    ratio_max_ = 1 / (2 * std::sin(min_angle));
    guard_tan_ = std::tan(min_angle + 5 * kPi / 180);
    apex_tan_ = std::tan(0.5 * (min_angle + kPi / 3));
  }

  static constexpr double kCircumradiusPerEdge = 0.75;
  static constexpr double kSegmentRadiusFactor = 0.6;

  void run() {
    for (int t = 0; t < static_cast<int>(mesh_.triangles.size()); ++t) consider(t);
    mesh_.changed.clear();
    while (!queue_.empty()) {
      const Item item = queue_.top();
      queue_.pop();
      const Triangle& T = mesh_.triangles[item.triangle];
      if (!T.alive || T.v != item.v || given_up_.count(key(item.v))) continue;
      attempt(item.triangle);
      const Triangle& after = mesh_.triangles[item.triangle];
      if (after.alive && after.v == item.v) given_up_.insert(key(item.v));
      for (int t : mesh_.changed) consider(t);
      mesh_.changed.clear();
      if (static_cast<long>(mesh_.points.size()) - 3 > options_.max_vertices)
        throw InputError(
            "panel mesh: more than max_vertices = " + std::to_string(options_.max_vertices) +
            " vertices needed at target_edge_m = " + number_text(options_.target_edge_m) +
            "; expected a larger target_edge_m or max_vertices");
    }
  }

 private:
  struct Item {
    double priority;
    int triangle;
    std::array<int, 3> v;
    bool operator<(const Item& o) const { return priority < o.priority; }
  };

  static unsigned long long key(std::array<int, 3> v) {
    std::sort(v.begin(), v.end());
    return (static_cast<unsigned long long>(v[0]) << 42) ^
           (static_cast<unsigned long long>(v[1]) << 21) ^ static_cast<unsigned long long>(v[2]);
  }

  void consider(int t) {
    const Triangle& T = mesh_.triangles[t];
    if (!T.alive) return;
    const Vec2& a = mesh_.points[T.v[0]];
    const Vec2& b = mesh_.points[T.v[1]];
    const Vec2& c = mesh_.points[T.v[2]];
    const std::array<double, 3> edge{(c - b).norm(), (a - c).norm(), (b - a).norm()};
    const double twice_area = cross(b - a, c - a);
    const double radius = edge[0] * edge[1] * edge[2] / (2 * twice_area);
    const int shortest =
        static_cast<int>(std::min_element(edge.begin(), edge.end()) - edge.begin());
    // A triangle standing on a boundary segment cannot be smaller than the equilateral one on
    // it (circumradius length / sqrt(3)); with segments kept, a long one sets the bound.
    double radius_max = circumradius_max_;
    for (int k = 0; k < 3; ++k)
      if (!options_.split_boundary && (T.segment[k] || T.n[k] < 0))
        radius_max = std::max(radius_max, kSegmentRadiusFactor * edge[k]);
    bool bad = radius > radius_max;
    if (!bad && radius > ratio_max_ * edge[shortest]) {
      // The smallest angle sits opposite the shortest edge; at a sharp input corner it is
      // forced by the outline and refining would only cut the corner finer and finer.
      const int corner = T.v[shortest];
      bad = !(corner < input_points_ && corner_angle_rad_[corner] < kPi / 3);
    }
    if (bad && !given_up_.count(key(T.v))) queue_.push({radius, t, T.v});
  }

  // Whether p, seen from the inside of segment edge k of triangle t, is too close to it.
  bool encroaches(const Vec2& p, int t, int k) const {
    const Triangle& T = mesh_.triangles[t];
    const Vec2& a = mesh_.points[T.v[next(k)]];
    const Vec2& b = mesh_.points[T.v[prev(k)]];
    if (options_.split_boundary) return (p - a).dot(p - b) < 0;  // inside the diametral circle
    const Vec2 ab = b - a;
    const double length = ab.norm();
    const double along = (p - a).dot(ab) / (length * length);
    const double height = cross(ab, p - a) / length;
    if (along <= 0 || along >= 1) return false;
    return height < guard_tan_ * std::min(along, 1 - along) * length;
  }

  // A segment edge near triangle t (t itself or its neighbours) that p encroaches on.
  bool encroached_near(const Vec2& p, int t, int& seg_t, int& seg_k) const {
    std::array<int, 4> around{t, mesh_.triangles[t].n[0], mesh_.triangles[t].n[1],
                              mesh_.triangles[t].n[2]};
    for (int u : around) {
      if (u < 0) continue;
      for (int k = 0; k < 3; ++k)
        if ((mesh_.triangles[u].segment[k] || mesh_.triangles[u].n[k] < 0) && encroaches(p, u, k)) {
          seg_t = u, seg_k = k;
          return true;
        }
    }
    return false;
  }

  double nearest_vertex_distance(const Vec2& p, int t) const {
    double d = std::numeric_limits<double>::infinity();
    std::array<int, 4> around{t, mesh_.triangles[t].n[0], mesh_.triangles[t].n[1],
                              mesh_.triangles[t].n[2]};
    for (int u : around)
      if (u >= 0)
        for (int v : mesh_.triangles[u].v) d = std::min(d, (mesh_.points[v] - p).norm());
    return d;
  }

  void insert_at(const Vec2& p, const Location& where) {
    const int vertex = mesh_.add_point(p);
    if (where.kind == Location::kInside)
      mesh_.split_triangle(where.triangle, vertex);
    else
      mesh_.split_edge(where.triangle, where.edge, vertex);
  }

  void attempt(int t) {
    const Triangle& T = mesh_.triangles[t];
    const Vec2 centre =
        circumcentre(mesh_.points[T.v[0]], mesh_.points[T.v[1]], mesh_.points[T.v[2]]);
    const double radius = (centre - mesh_.points[T.v[0]]).norm();
    const Location where = mesh_.walk(t, centre);
    int seg_t = -1, seg_k = -1;
    if (where.kind == Location::kLost || where.kind == Location::kOnVertex) return;
    if (where.kind == Location::kBlocked) {
      seg_t = where.triangle, seg_k = where.edge;
    } else if (where.kind == Location::kOnEdge &&
               mesh_.triangles[where.triangle].segment[where.edge]) {
      seg_t = where.triangle, seg_k = where.edge;
    } else if (!encroached_near(centre, where.triangle, seg_t, seg_k)) {
      if (nearest_vertex_distance(centre, where.triangle) > 1e-3 * radius) insert_at(centre, where);
      return;
    }
    if (options_.split_boundary)
      split_segment(seg_t, seg_k);
    else
      insert_apex(centre, radius, seg_t, seg_k);
  }

  void split_segment(int t, int k) {
    const Triangle& T = mesh_.triangles[t];
    const Vec2& a = mesh_.points[T.v[next(k)]];
    const Vec2& b = mesh_.points[T.v[prev(k)]];
    // Segments far below the target size are left alone: splitting them again and again is
    // how refinement loops at sharp corners.
    if ((b - a).norm() < 0.2 * options_.target_edge_m) return;
    mesh_.split_edge(t, k, mesh_.add_point(0.5 * (a + b)));
  }

  // Instead of a circumcentre too close to (or beyond) a segment, the apex of a well-shaped
  // triangle standing on the segment, if it lies in the bad triangle's circumcircle (so the
  // triangle goes) and has room.
  void insert_apex(const Vec2& centre, double radius, int seg_t, int seg_k) {
    const Triangle& S = mesh_.triangles[seg_t];
    const Vec2 a = mesh_.points[S.v[next(seg_k)]];
    const Vec2 b = mesh_.points[S.v[prev(seg_k)]];
    const double length = (b - a).norm();
    const Vec2 inward = Vec2(a.y() - b.y(), b.x() - a.x()) / length;
    for (double tan_base : {std::sqrt(3.0), apex_tan_}) {
      const Vec2 p = 0.5 * (a + b) + inward * (0.5 * length * tan_base);
      if ((p - centre).norm() >= radius) continue;
      const Location where = mesh_.walk(seg_t, p);
      if (where.kind != Location::kInside &&
          !(where.kind == Location::kOnEdge &&
            !mesh_.triangles[where.triangle].segment[where.edge]))
        continue;
      int other_t, other_k;
      if (encroached_near(p, where.triangle, other_t, other_k)) continue;
      if (nearest_vertex_distance(p, where.triangle) <
          0.4 * std::min(length, options_.target_edge_m))
        continue;
      insert_at(p, where);
      return;
    }
  }

  Triangulation& mesh_;
  const PanelMeshOptions& options_;
  int input_points_;
  std::vector<double> corner_angle_rad_;
  double circumradius_max_, ratio_max_, guard_tan_, apex_tan_;
  std::priority_queue<Item> queue_;
  std::unordered_set<unsigned long long> given_up_;
};

void check_options(const PanelMeshOptions& options) {
  if (!(options.target_edge_m > 0) || !std::isfinite(options.target_edge_m))
    throw InputError("panel mesh: target_edge_m = " + number_text(options.target_edge_m) +
                     "; expected a positive length in metres");
  if (!(options.min_angle_deg > 0 && options.min_angle_deg <= 34))
    throw InputError("panel mesh: min_angle_deg = " + number_text(options.min_angle_deg) +
                     "; expected an angle in (0, 34] degrees");
  if (options.max_vertices < 3)
    throw InputError("panel mesh: max_vertices = " + std::to_string(options.max_vertices) +
                     "; expected at least 3");
}

// Interior angle of the panel at every outline point (the panel on the left of each ring as
// walked with the outer boundary counter-clockwise and the holes clockwise).
std::vector<double> corner_angles(const std::vector<std::vector<Vec2>>& rings) {
  std::vector<double> angles;
  for (size_t r = 0; r < rings.size(); ++r) {
    const auto& ring = rings[r];
    const int n = static_cast<int>(ring.size());
    double twice_area = 0;
    for (int i = 0; i < n; ++i) twice_area += cross(ring[i], ring[(i + 1) % n]);
    const bool reversed = (twice_area > 0) != (r == 0);
    for (int i = 0; i < n; ++i) {
      Vec2 before = ring[(i + n - 1) % n] - ring[i], after = ring[(i + 1) % n] - ring[i];
      if (reversed) std::swap(before, after);
      double angle = std::atan2(cross(after, before), after.dot(before));
      if (angle < 0) angle += 2 * kPi;
      angles.push_back(angle);
    }
  }
  return angles;
}

}  // namespace

PanelMesh mesh_panel(const PanelOutline& outline, const PanelMeshOptions& options) {
  check_options(options);
  check_panel_outline(outline);
  std::vector<std::vector<Vec2>> rings{outline.outer};
  rings.insert(rings.end(), outline.holes.begin(), outline.holes.end());

  Triangulation mesh;
  Vec2 low = outline.outer[0], high = outline.outer[0];
  for (const auto& ring : rings)
    for (const Vec2& p : ring) {
      mesh.add_point(p);
      low = low.cwiseMin(p);
      high = high.cwiseMax(p);
    }
  const int input_points = static_cast<int>(mesh.points.size());
  if (input_points > options.max_vertices)
    throw InputError("panel mesh: the outline has " + std::to_string(input_points) +
                     " points, more than max_vertices = " + std::to_string(options.max_vertices));

  // A triangle around everything; it and the outside of the panel go at the end.
  const Vec2 centre = 0.5 * (low + high);
  const double span = std::max((high - low).maxCoeff(), 1e-300);
  const int s0 = mesh.add_point(centre + Vec2(-20 * span, -20 * span));
  const int s1 = mesh.add_point(centre + Vec2(20 * span, -20 * span));
  const int s2 = mesh.add_point(centre + Vec2(0, 20 * span));
  mesh.start(s0, s1, s2);
  int hint = 0;
  for (int i = 0; i < input_points; ++i) {
    const Location where = mesh.locate(mesh.points[i], hint);
    if (where.kind == Location::kInside)
      mesh.split_triangle(where.triangle, i);
    else if (where.kind == Location::kOnEdge)
      mesh.split_edge(where.triangle, where.edge, i);
    else
      throw std::logic_error("panel mesher: could not place outline point " + std::to_string(i));
    hint = mesh.vertex_triangle[i];
  }
  int first = 0;
  for (const auto& ring : rings) {
    const int n = static_cast<int>(ring.size());
    for (int i = 0; i < n; ++i) mesh.insert_segment(first + i, first + (i + 1) % n);
    first += n;
  }
  mesh.make_delaunay();

  // Crossing a segment goes in or out of the panel; the big triangle's corners are outside.
  std::vector<int> parity(mesh.triangles.size(), -1);
  std::vector<int> stack{mesh.vertex_triangle[s0]};
  parity[stack[0]] = 0;
  while (!stack.empty()) {
    const int t = stack.back();
    stack.pop_back();
    for (int k = 0; k < 3; ++k) {
      const int u = mesh.triangles[t].n[k];
      if (u < 0 || parity[u] >= 0) continue;
      parity[u] = parity[t] ^ static_cast<int>(mesh.triangles[t].segment[k]);
      stack.push_back(u);
    }
  }
  for (size_t t = 0; t < mesh.triangles.size(); ++t)
    if (parity[t] != 1) mesh.triangles[t].alive = false;
  for (auto& T : mesh.triangles)
    if (T.alive)
      for (int k = 0; k < 3; ++k)
        if (T.n[k] >= 0 && !mesh.triangles[T.n[k]].alive) T.n[k] = -1;
  mesh.changed.clear();

  Refiner(mesh, options, input_points, corner_angles(rings)).run();

  PanelMesh out;
  out.boundary_vertices = input_points;
  auto renumber = [&](int v) { return v < input_points ? v : v - 3; };
  for (int v = 0; v < static_cast<int>(mesh.points.size()); ++v)
    if (v < input_points || v > s2) out.vertices.push_back(mesh.points[v]);
  for (const auto& T : mesh.triangles)
    if (T.alive) out.triangles.push_back({renumber(T.v[0]), renumber(T.v[1]), renumber(T.v[2])});
  return out;
}

}  // namespace weft
