#pragma once
// Geometric queries of collision handling (docs/collision-geometry.md, "Detection"): closest points
// between a point and a triangle and between two segments, continuous collision detection of a
// vertex against a triangle and of an edge against an edge along straight trajectories over a step,
// and intersection tests of segments and triangles.
//
// Naming: `_t0` and `_t1` are positions at the start and end of the step; in between a vertex
// moves on the straight line x(t) = x_t0 + t (x_t1 - x_t0), t in [0, 1].
#include <optional>

#include "weft/types.hpp"

namespace weft {

/// The part of a triangle (a, b, c) a closest point lies on. Edge k joins vertex k and vertex
/// (k + 1) % 3: edge 0 is ab, edge 1 bc, edge 2 ca. Vertex k is a, b or c.
enum class FeatureKind { kFace, kEdge, kVertex };
struct TriangleFeature {
  FeatureKind kind = FeatureKind::kFace;
  int index = 0;  ///< the edge or vertex number; 0 for the face
  bool operator==(const TriangleFeature&) const = default;
};

struct PointTriangleClosest {
  Vec3 point = Vec3::Zero();    ///< the triangle's point nearest to p
  Vec3 weights = Vec3::Zero();  ///< its barycentric weights for (a, b, c): each in [0, 1], sum 1
  double distance = 0;          ///< |p - point|
  TriangleFeature feature;      ///< the face, or the edge or vertex the point lies on
};

/// The point of the closed triangle (a, b, c) nearest to p. A triangle of zero area (its
/// vertices collinear or coincident) is treated as its three edges.
PointTriangleClosest closest_point_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);

struct PointSegmentClosest {
  double t = 0;                ///< parameter along a -> b, in [0, 1]
  Vec3 point = Vec3::Zero();   ///< a + t (b - a)
  double distance = 0;
};

/// The point of the segment ab nearest to p (t = 0 for a zero-length segment).
PointSegmentClosest closest_point_segment(const Vec3& p, const Vec3& a, const Vec3& b);

struct SegmentSegmentClosest {
  double s = 0, t = 0;          ///< parameters along p0 -> p1 and q0 -> q1, each in [0, 1]
  Vec3 point_p = Vec3::Zero();  ///< p0 + s (p1 - p0)
  Vec3 point_q = Vec3::Zero();  ///< q0 + t (q1 - q0)
  double distance = 0;          ///< |point_p - point_q|, the least distance between the segments
};

/// A nearest pair of points of the segments p0p1 and q0q1. Parallel segments (a whole range of
/// nearest pairs) get one of the pairs with an endpoint; zero-length segments are points.
SegmentSegmentClosest closest_points_segments(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1);

/// Continuous detection of a vertex against a triangle: the earliest time t in [0, 1] at
/// which the vertex p(t) comes within `thickness` (>= 0, m) of the triangle (a(t), b(t), c(t)),
/// every vertex moving on its straight line over the step; none if it never does.
///
/// Never misses: whenever the distance falls below `thickness` at some time, a time is
/// returned, and it is no later than the first such time (to within 1e-9 of the motion).
/// At the time returned the distance is at most `thickness` plus 1e-9 (thickness + motion):
/// a false alarm is a pair that comes within the thickness only to that rounding.
std::optional<double> vertex_face_ccd(const Vec3& p_t0, const Vec3& p_t1, const Vec3& a_t0, const Vec3& a_t1,
                                      const Vec3& b_t0, const Vec3& b_t1, const Vec3& c_t0, const Vec3& c_t1,
                                      double thickness);

/// Continuous detection of an edge (p0, p1) against an edge (q0, q1): the earliest time t in
/// [0, 1] at which the segments come within `thickness` of each other; none if they never do.
/// The same guarantees as vertex_face_ccd, parallel and zero-length edges included.
std::optional<double> edge_edge_ccd(const Vec3& p0_t0, const Vec3& p0_t1, const Vec3& p1_t0, const Vec3& p1_t1,
                                    const Vec3& q0_t0, const Vec3& q0_t1, const Vec3& q1_t0, const Vec3& q1_t1,
                                    double thickness);

/// (b - a) x (c - a) . (d - a): positive when d lies on the side of the plane abc that the
/// normal of the counter-clockwise triangle (a, b, c) points to, zero when coplanar.
double orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

/// Whether the closed segment pq meets the closed triangle (a, b, c), touching included (an
/// endpoint on the triangle, the segment through an edge or a vertex, a segment lying in the
/// triangle's plane across it). The orientation signs are exact (mesh/exact_predicates.hpp),
/// so the answer is that of the points as given, nearly coplanar ones included. A triangle of
/// zero area (no plane) meets nothing here.
bool segment_triangle_intersect(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c);

/// Whether the closed triangles (a, b, c) and (d, e, f) have a point in common. Touching counts
/// as intersecting: a vertex on the other triangle, edges that cross, coplanar triangles that
/// overlap or share a boundary point. Two triangles sharing a vertex or an edge of a mesh
/// therefore always intersect; callers counting a mesh's intersections leave such pairs out.
/// A triangle of zero area counts through its edges (it meets a triangle its edges meet); two
/// of them never intersect. Exact, as segment_triangle_intersect.
bool triangles_intersect(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, const Vec3& e, const Vec3& f);

}  // namespace weft
