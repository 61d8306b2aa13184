#include "collision/geometry.hpp"

#include "mesh/exact_predicates.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace weft {

// ---------------------------------------------------------------------------------------------
// Closest points

namespace {

/// The parameter in [0, 1] of the point of the segment a + t ab nearest to p (0 for a
/// zero-length segment), from ap . ab and |ab|^2.
double segment_parameter(double ap_dot_ab, double len2) {
  return len2 > 0 ? std::clamp(ap_dot_ab / len2, 0.0, 1.0) : 0.0;
}

}  // namespace

PointSegmentClosest closest_point_segment(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  PointSegmentClosest r;
  r.t = segment_parameter((p - a).dot(ab), ab.squaredNorm());
  r.point = a + r.t * ab;
  r.distance = (p - r.point).norm();
  return r;
}

PointTriangleClosest closest_point_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const Vec3 n = ab.cross(ac);
  const double nn = n.squaredNorm();
  PointTriangleClosest r;
  // The projection of p onto the plane, in barycentric weights: when it lies in the triangle
  // it is the nearest point (distance = plane distance). A triangle whose area is lost to
  // rounding has no usable plane and is handled as its edges below.
  if (nn > 1e-30 * ab.squaredNorm() * ac.squaredNorm() && nn > 0) {
    const double wb = ap.cross(ac).dot(n) / nn;
    const double wc = ab.cross(ap).dot(n) / nn;
    const double wa = 1 - wb - wc;
    if (wa >= 0 && wb >= 0 && wc >= 0) {
      r.weights = Vec3(wa, wb, wc);
      r.point = wa * a + wb * b + wc * c;
      r.distance = (p - r.point).norm();
      r.feature = {FeatureKind::kFace, 0};
      return r;
    }
  }
  // Outside the triangle (in projection) the nearest point is on the boundary: the nearest of
  // the three edges' nearest points (compared by squared distance; one square root at the end).
  const Vec3* corner[3] = {&a, &b, &c};
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    const int k1 = (k + 1) % 3;
    const Vec3 e = *corner[k1] - *corner[k];
    const double t = segment_parameter((p - *corner[k]).dot(e), e.squaredNorm());
    const Vec3 q = *corner[k] + t * e;
    const double d2 = (p - q).squaredNorm();
    if (d2 < best) {
      best = d2;
      r.point = q;
      r.weights = Vec3::Zero();
      r.weights[k] = 1 - t;
      r.weights[k1] = t;
      if (t == 0)
        r.feature = {FeatureKind::kVertex, k};
      else if (t == 1)
        r.feature = {FeatureKind::kVertex, k1};
      else
        r.feature = {FeatureKind::kEdge, k};
    }
  }
  r.distance = std::sqrt(best);
  return r;
}

SegmentSegmentClosest closest_points_segments(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1) {
  // The squared distance is a convex quadratic over the unit square of (s, t): its minimum is
  // the unconstrained one when that lies in the square, otherwise on the square's boundary,
  // where one parameter is 0 or 1 and the other is a point-segment problem. Taking the least of
  // all these candidates needs no case analysis for parallel or zero-length segments. They are
  // compared by squared distance, with one square root at the end.
  const Vec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), b = d1.dot(d2);
  const double c = d1.dot(r), f = d2.dot(r);
  const double denom = a * e - b * b;
  SegmentSegmentClosest best;
  double best2 = std::numeric_limits<double>::infinity();
  auto consider = [&](double s, double t) {
    const Vec3 pp = p0 + s * d1, qq = q0 + t * d2;
    const double dd = (pp - qq).squaredNorm();
    if (dd < best2) {
      best2 = dd;
      best.s = s;
      best.t = t;
      best.point_p = pp;
      best.point_q = qq;
    }
  };
  if (denom > 1e-14 * a * e && denom > 0) {
    const double s = (b * f - c * e) / denom, t = (a * f - b * c) / denom;
    if (s >= 0 && s <= 1 && t >= 0 && t <= 1) consider(s, t);
  }
  // The endpoints against the other segment: p0 - q0 = r, p1 - q0 = r + d1, and the same
  // seen from p.
  consider(0, segment_parameter(f, e));
  consider(1, segment_parameter(f + b, e));
  consider(segment_parameter(-c, a), 0);
  consider(segment_parameter(b - c, a), 1);
  best.distance = std::sqrt(best2);
  return best;
}

// ---------------------------------------------------------------------------------------------
// Polynomials in the step's time t, for continuous detection

namespace {

constexpr int kMaxDegree = 6;

/// c[0] + c[1] t + ... + c[degree] t^degree.
struct Poly {
  std::array<double, kMaxDegree + 1> c{};
  int degree = 0;
  double operator()(double t) const {
    double v = c[degree];
    for (int k = degree - 1; k >= 0; --k) v = v * t + c[k];
    return v;
  }
};

Poly operator*(const Poly& p, const Poly& q) {
  Poly r;
  r.degree = p.degree + q.degree;
  for (int i = 0; i <= p.degree; ++i)
    for (int j = 0; j <= q.degree; ++j) r.c[i + j] += p.c[i] * q.c[j];
  return r;
}

Poly operator-(const Poly& p, const Poly& q) {
  Poly r;
  r.degree = std::max(p.degree, q.degree);
  for (int k = 0; k <= r.degree; ++k) r.c[k] = (k <= p.degree ? p.c[k] : 0.0) - (k <= q.degree ? q.c[k] : 0.0);
  return r;
}

Poly constant(double v) {
  Poly r;
  r.c[0] = v;
  return r;
}

/// A point moving over the step, or a product of such (degree <= 2 here).
struct VecPoly {
  std::array<Vec3, 3> c{Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  int degree = 0;
};

VecPoly moving(const Vec3& x_t0, const Vec3& x_t1) {
  VecPoly r;
  r.c[0] = x_t0;
  r.c[1] = x_t1 - x_t0;
  r.degree = 1;
  return r;
}

VecPoly operator-(const VecPoly& p, const VecPoly& q) {
  VecPoly r;
  r.degree = std::max(p.degree, q.degree);
  for (int k = 0; k <= r.degree; ++k)
    r.c[k] = (k <= p.degree ? p.c[k] : Vec3::Zero()) - (k <= q.degree ? q.c[k] : Vec3::Zero());
  return r;
}

VecPoly cross(const VecPoly& p, const VecPoly& q) {
  VecPoly r;
  r.degree = p.degree + q.degree;
  for (int i = 0; i <= p.degree; ++i)
    for (int j = 0; j <= q.degree; ++j) r.c[i + j] += p.c[i].cross(q.c[j]);
  return r;
}

Poly dot(const VecPoly& p, const VecPoly& q) {
  Poly r;
  r.degree = p.degree + q.degree;
  for (int i = 0; i <= p.degree; ++i)
    for (int j = 0; j <= q.degree; ++j) r.c[i + j] += p.c[i].dot(q.c[j]);
  return r;
}

/// A root in (lo, hi) of p, which is monotone there with p(lo) of sign `lo_negative` and p(hi)
/// of the other: Newton steps, kept inside the shrinking bracket by bisection.
double refine_root(const Poly& p, const Poly& dp, double lo, double hi, bool lo_negative) {
  double x = 0.5 * (lo + hi);
  for (int iteration = 0; iteration < 200; ++iteration) {
    const double f = p(x);
    if (f == 0) return x;
    ((f < 0) == lo_negative ? lo : hi) = x;
    const double slope = dp(x);
    double next = slope != 0 ? x - f / slope : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - x) <= 1e-16 || hi - lo <= 1e-16) return next;
    x = next;
  }
  return x;
}

Poly derivative(const Poly& p) {
  Poly d;
  d.degree = std::max(0, p.degree - 1);
  for (int k = 1; k <= p.degree; ++k) d.c[k - 1] = k * p.c[k];
  return d;
}

/// Appends to `out` the roots of p in [0, 1] with odd multiplicity and those where p is exactly
/// zero at an end of a monotone piece, given its critical points `critical` in [0, 1], sorted.
/// Between consecutive critical points p is monotone, so each sign change brackets exactly one
/// root: none is missed, however close together the roots are.
template <class Out>
void roots_between(const Poly& p, const Poly& dp, const double* critical, int n_critical, Out& out) {
  double lo = 0, f_lo = p(0);
  for (int i = 0; i <= n_critical; ++i) {
    const double hi = i < n_critical ? critical[i] : 1.0;
    const double f_hi = p(hi);
    if (f_lo == 0)
      out.push(lo);
    else if (f_hi != 0 && (f_lo < 0) != (f_hi < 0))
      out.push(refine_root(p, dp, lo, hi, f_lo < 0));
    lo = hi;
    f_lo = f_hi;
  }
  if (f_lo == 0) out.push(1.0);
}

/// A short list of times, of fixed capacity.
template <int N>
struct Times {
  std::array<double, N> t;
  int size = 0;
  void push(double x) {
    if (size < N && x >= 0 && x <= 1) t[size++] = x;
  }
};

/// The roots of p in [0, 1] (odd multiplicity; see roots_between), sorted.
Times<kMaxDegree + 1> roots_in_unit_interval(const Poly& p) {
  Times<kMaxDegree + 1> roots;
  int degree = p.degree;
  while (degree > 0 && p.c[degree] == 0) --degree;
  if (degree == 0) return roots;
  Poly q = p;
  q.degree = degree;
  if (degree == 1) {
    roots.push(-q.c[0] / q.c[1]);
    return roots;
  }
  const Poly dq = derivative(q);
  const Times<kMaxDegree + 1> critical = roots_in_unit_interval(dq);
  // roots_between visits the pieces from left to right: the roots come out sorted.
  roots_between(q, dq, critical.t.data(), critical.size, roots);
  return roots;
}

/// The times at which the distance of a continuous-detection query is checked: t = 0 and 1,
/// and the roots and critical points of every polynomial that bounds the set of times where
/// the two primitives are within the thickness.
struct Candidates : Times<256> {
  void add(const Poly& p) {
    int degree = p.degree;
    while (degree > 0 && p.c[degree] == 0) --degree;
    if (degree == 0) return;
    Poly q = p;
    q.degree = degree;
    const Poly dq = derivative(q);
    // The critical points catch a root of even multiplicity (a constraint touching zero
    // without a sign change, e.g. a grazing contact), which no sign change brackets.
    const Times<kMaxDegree + 1> critical = roots_in_unit_interval(dq);
    for (int i = 0; i < critical.size; ++i) push(critical.t[i]);
    roots_between(q, dq, critical.t.data(), critical.size, *this);
  }
};

/// Constraints of "point within h of the segment ab": the cylinder |w x e|^2 <= h^2 |e|^2
/// with the projection 0 <= w.e <= e.e, and the spheres around a and b.
void add_point_segment(Candidates& cand, const VecPoly& point, const VecPoly& a, const VecPoly& b, const Poly& h2) {
  const VecPoly w = point - a, e = b - a, wb = point - b;
  const Poly ee = dot(e, e), we = dot(w, e);
  const VecPoly wxe = cross(w, e);
  cand.add(dot(wxe, wxe) - h2 * ee);
  cand.add(we);
  cand.add(ee - we);
  cand.add(dot(w, w) - h2);
  cand.add(dot(wb, wb) - h2);
}

/// The earliest candidate time at which `distance` is within `thickness` (and the tolerance);
/// the candidates include the infimum of the set of such times, so none earlier exists.
template <class Distance>
std::optional<double> earliest_within(Candidates& cand, const Distance& distance, double thickness, double tolerance) {
  std::sort(cand.t.begin(), cand.t.begin() + cand.size);
  for (int i = 0; i < cand.size; ++i)
    if (distance(cand.t[i]) <= thickness + tolerance) return cand.t[i];
  return std::nullopt;
}

Vec3 at(const Vec3& x_t0, const Vec3& x_t1, double t) { return x_t0 + t * (x_t1 - x_t0); }

}  // namespace

std::optional<double> vertex_face_ccd(const Vec3& p_t0, const Vec3& p_t1, const Vec3& a_t0, const Vec3& a_t1,
                                      const Vec3& b_t0, const Vec3& b_t1, const Vec3& c_t0, const Vec3& c_t1,
                                      double thickness) {
  // Coordinates relative to the vertex's start, so the polynomials' coefficients are of the
  // size of the neighbourhood, not of the scene.
  const Vec3 o = p_t0;
  const Vec3 p0 = p_t0 - o, p1 = p_t1 - o, a0 = a_t0 - o, a1 = a_t1 - o, b0 = b_t0 - o, b1 = b_t1 - o,
             c0 = c_t0 - o, c1 = c_t1 - o;
  auto distance = [&](double t) {
    return closest_point_triangle(at(p0, p1, t), at(a0, a1, t), at(b0, b1, t), at(c0, c1, t)).distance;
  };
  // Every point of the triangle moves relative to p by a convex combination of its vertices'
  // relative motions, so the distance changes at most `reach` over the step.
  const Vec3 dp = p1 - p0;
  const double reach = std::max({(a1 - a0 - dp).norm(), (b1 - b0 - dp).norm(), (c1 - c0 - dp).norm()});
  const double tolerance = 1e-9 * (thickness + reach);
  const double d_start = distance(0);
  if (d_start <= thickness + tolerance) return 0.0;
  // The end's distance is at least d_start - reach: far enough apart at the start, the bound
  // below holds without it (by a margin of the tolerance, which rounding cannot cross).
  if (d_start - reach > thickness + 2 * tolerance) return std::nullopt;
  const double d_end = distance(1);
  if (0.5 * (d_start + d_end - reach) > thickness + tolerance) return std::nullopt;

  // Within the thickness of the triangle means within the prism over the face (projection
  // inside, plane distance <= h) or within h of an edge (docs/collisions.md).
  const VecPoly p = moving(p0, p1), a = moving(a0, a1), b = moving(b0, b1), c = moving(c0, c1);
  const Poly h2 = constant(thickness * thickness);
  const VecPoly n = cross(b - a, c - a);
  const Poly nn = dot(n, n), s = dot(n, p - a);
  Candidates cand;
  cand.push(0);
  cand.push(1);
  cand.add(s * s - h2 * nn);
  cand.add(dot(cross(b - a, p - a), n));
  cand.add(dot(cross(c - b, p - b), n));
  cand.add(dot(cross(a - c, p - c), n));
  add_point_segment(cand, p, a, b, h2);
  add_point_segment(cand, p, b, c, h2);
  add_point_segment(cand, p, c, a, h2);
  return earliest_within(cand, distance, thickness, tolerance);
}

std::optional<double> edge_edge_ccd(const Vec3& p0_t0, const Vec3& p0_t1, const Vec3& p1_t0, const Vec3& p1_t1,
                                    const Vec3& q0_t0, const Vec3& q0_t1, const Vec3& q1_t0, const Vec3& q1_t1,
                                    double thickness) {
  const Vec3 o = p0_t0;
  const Vec3 e0 = p0_t0 - o, e0e = p0_t1 - o, e1 = p1_t0 - o, e1e = p1_t1 - o, f0 = q0_t0 - o, f0e = q0_t1 - o,
             f1 = q1_t0 - o, f1e = q1_t1 - o;
  auto distance = [&](double t) {
    return closest_points_segments(at(e0, e0e, t), at(e1, e1e, t), at(f0, f0e, t), at(f1, f1e, t)).distance;
  };
  const Vec3 m[4] = {e0e - e0, e1e - e1, f0e - f0, f1e - f1};
  double reach = 0;
  for (int i = 0; i < 2; ++i)
    for (int j = 2; j < 4; ++j) reach = std::max(reach, (m[i] - m[j]).norm());
  const double tolerance = 1e-9 * (thickness + reach);
  const double d_start = distance(0);
  if (d_start <= thickness + tolerance) return 0.0;
  if (d_start - reach > thickness + 2 * tolerance) return std::nullopt;  // as for vertex_face_ccd
  const double d_end = distance(1);
  if (0.5 * (d_start + d_end - reach) > thickness + tolerance) return std::nullopt;

  // Within h of each other means: the lines' common perpendicular has its feet inside both
  // segments and is at most h long, or an endpoint is within h of the other segment.
  const VecPoly p0 = moving(e0, e0e), p1 = moving(e1, e1e), q0 = moving(f0, f0e), q1 = moving(f1, f1e);
  const Poly h2 = constant(thickness * thickness);
  const VecPoly d1 = p1 - p0, d2 = q1 - q0, w = q0 - p0;
  const VecPoly n = cross(d1, d2);
  const Poly nn = dot(n, n), s = dot(n, w);
  const Poly foot_p = dot(cross(w, d2), n), foot_q = dot(cross(w, d1), n);
  Candidates cand;
  cand.push(0);
  cand.push(1);
  cand.add(s * s - h2 * nn);
  cand.add(foot_p);
  cand.add(nn - foot_p);
  cand.add(foot_q);
  cand.add(nn - foot_q);
  add_point_segment(cand, p0, q0, q1, h2);
  add_point_segment(cand, p1, q0, q1, h2);
  add_point_segment(cand, q0, p0, p1, h2);
  add_point_segment(cand, q1, p0, p1, h2);
  return earliest_within(cand, distance, thickness, tolerance);
}

// ---------------------------------------------------------------------------------------------
// Intersection tests

double orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return (b - a).cross(c - a).dot(d - a);
}

namespace {

// The signs of the intersection tests are exact (mesh/exact_predicates.hpp): rounded ones can
// contradict each other where the points are nearly coplanar and report crossings far from
// any touching (two faces of a nearly flat sheet centimetres apart).
int orient2d_sign(const Vec2& a, const Vec2& b, const Vec2& c) { return orientation_sign(a, b, c); }

bool in_closed_box_2d(const Vec2& p, const Vec2& a, const Vec2& b) {
  return p.x() >= std::min(a.x(), b.x()) && p.x() <= std::max(a.x(), b.x()) && p.y() >= std::min(a.y(), b.y()) &&
         p.y() <= std::max(a.y(), b.y());
}

bool segments_intersect_2d(const Vec2& p, const Vec2& q, const Vec2& a, const Vec2& b) {
  const int o1 = orient2d_sign(p, q, a), o2 = orient2d_sign(p, q, b);
  const int o3 = orient2d_sign(a, b, p), o4 = orient2d_sign(a, b, q);
  if (o1 * o2 < 0 && o3 * o4 < 0) return true;
  // Touching or collinear: an endpoint on the other segment.
  return (o1 == 0 && in_closed_box_2d(a, p, q)) || (o2 == 0 && in_closed_box_2d(b, p, q)) ||
         (o3 == 0 && in_closed_box_2d(p, a, b)) || (o4 == 0 && in_closed_box_2d(q, a, b));
}

bool point_in_triangle_2d(const Vec2& p, const Vec2& a, const Vec2& b, const Vec2& c) {
  const int s0 = orient2d_sign(a, b, p), s1 = orient2d_sign(b, c, p), s2 = orient2d_sign(c, a, p);
  return !((s0 < 0 || s1 < 0 || s2 < 0) && (s0 > 0 || s1 > 0 || s2 > 0));
}

// A segment in the plane of a triangle: dropping the coordinate along which the normal is
// largest keeps the triangle's area, so the test becomes two-dimensional.
bool coplanar_segment_triangle(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c,
                               const Vec3& normal) {
  Eigen::Index drop = 0;
  normal.cwiseAbs().maxCoeff(&drop);
  const int i = static_cast<int>(drop + 1) % 3, j = static_cast<int>(drop + 2) % 3;
  auto flat = [&](const Vec3& x) { return Vec2(x[i], x[j]); };
  const Vec2 p2 = flat(p), q2 = flat(q), a2 = flat(a), b2 = flat(b), c2 = flat(c);
  return point_in_triangle_2d(p2, a2, b2, c2) || point_in_triangle_2d(q2, a2, b2, c2) ||
         segments_intersect_2d(p2, q2, a2, b2) || segments_intersect_2d(p2, q2, b2, c2) ||
         segments_intersect_2d(p2, q2, c2, a2);
}

}  // namespace

bool segment_triangle_intersect(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 normal = (b - a).cross(c - a);
  if (normal.squaredNorm() == 0) return false;
  const int sp = orient3d_sign(a, b, c, p), sq = orient3d_sign(a, b, c, q);
  if (sp * sq > 0) return false;
  if (sp == 0 && sq == 0) return coplanar_segment_triangle(p, q, a, b, c, normal);
  // p and q on opposite sides (or one on the plane): the line pq meets the plane within the
  // segment, and meets the closed triangle exactly when it passes each edge on the same side.
  const int s0 = orient3d_sign(p, q, a, b), s1 = orient3d_sign(p, q, b, c), s2 = orient3d_sign(p, q, c, a);
  return !((s0 < 0 || s1 < 0 || s2 < 0) && (s0 > 0 || s1 > 0 || s2 > 0));
}

bool triangles_intersect(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, const Vec3& e, const Vec3& f) {
  // Quick rejection: one triangle strictly on one side of the other's plane.
  const int sd = orient3d_sign(a, b, c, d), se = orient3d_sign(a, b, c, e), sf = orient3d_sign(a, b, c, f);
  if ((sd > 0 && se > 0 && sf > 0) || (sd < 0 && se < 0 && sf < 0)) return false;
  const int sa = orient3d_sign(d, e, f, a), sb = orient3d_sign(d, e, f, b), sc = orient3d_sign(d, e, f, c);
  if ((sa > 0 && sb > 0 && sc > 0) || (sa < 0 && sb < 0 && sc < 0)) return false;
  // Two closed triangles that meet have an edge of one meeting the other: the ends of their
  // common segment lie on the triangles' boundaries, and a coplanar overlap either crosses
  // boundaries or holds one triangle's edges inside the other.
  return segment_triangle_intersect(a, b, d, e, f) || segment_triangle_intersect(b, c, d, e, f) ||
         segment_triangle_intersect(c, a, d, e, f) || segment_triangle_intersect(d, e, a, b, c) ||
         segment_triangle_intersect(e, f, a, b, c) || segment_triangle_intersect(f, d, a, b, c);
}

}  // namespace weft
