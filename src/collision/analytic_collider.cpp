// The analytic colliders: plane, sphere, capsule and box with rounded edges.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

#include "collision/collider_surfaces.hpp"
#include "collision/colliders.hpp"
#include "collision/geometry.hpp"

namespace weft {

namespace {

// The closest surface point of a shape in its own (t = 0) placement.
struct Closest {
  double distance;
  Vec3 normal, point;
};

Closest round(const Vec3& p, const Vec3& centre, double radius, const Vec3& fallback_normal) {
  const Vec3 d = p - centre;
  const double r = d.norm();
  const Vec3 n = r > 1e-12 ? Vec3(d / r) : fallback_normal;
  return {r - radius, n, centre + radius * n};
}

class AnalyticCollider : public Collider {
 public:
  explicit AnalyticCollider(const ColliderSpec& spec) : Collider(spec), box_rotation_(rotation_from_degrees(spec.rotation_deg)) {
    if (spec.shape == ColliderShape::kPlane || spec.shape == ColliderShape::kMesh || spec.shape == ColliderShape::kBody) {
      normal_ = spec.normal.normalized();
    }
    if (spec.shape == ColliderShape::kCapsule) {
      const Vec3 axis = spec.end_b - spec.end_a;
      axis_ = axis.norm() > 0 ? Vec3(axis.normalized()) : Vec3::UnitY();
    }
  }

  void prepare(double t0, double t1) override {
    start_ = spec().motion.at(t0);
    end_ = spec().motion.at(t1);
    start_inverse_ = start_.inverse();
    end_inverse_ = end_.inverse();
  }

  bool closest(const Vec3& p, double reach, bool end, int /*node*/, SurfacePoint& out) const override {
    const Eigen::Isometry3d& T = end ? end_ : start_;
    const Vec3 local = (end ? end_inverse_ : start_inverse_) * p;
    const Closest c = closest_local(local);
    (void)reach;  // computing the closest point costs no more than ruling it out
    out.distance = c.distance;
    out.normal = T.linear() * c.normal;
    out.point = T * c.point;
    // The surface point's motion over the step (for the end query: over the step before).
    if (end) {
      const Vec3 before = start_ * c.point;
      out.displacement = out.point - before;
    } else {
      out.displacement = end_ * c.point - out.point;
    }
    return true;
  }

  bool answers_triangles() const override {
    const ColliderShape shape = spec().shape;
    return shape == ColliderShape::kBox || shape == ColliderShape::kSphere || shape == ColliderShape::kCapsule;
  }

  bool closest_to_triangle(const Vec3& a, const Vec3& b, const Vec3& c, SurfacePoint& out,
                           Vec3& weights) const override {
    const ColliderSpec& s = spec();
    if (!answers_triangles()) return false;
    if (s.shape == ColliderShape::kBox) return box_closest_to_triangle(a, b, c, out, weights);
    // In the shape's frame at the step's end: the triangle's point nearest the centre (or the
    // axis: alternate projections between the segment and the triangle, both convex).
    const Vec3 la = end_inverse_ * a, lb = end_inverse_ * b, lc = end_inverse_ * c;
    Vec3 centre = s.shape == ColliderShape::kSphere ? s.centre : s.end_a;
    PointTriangleClosest q = closest_point_triangle(centre, la, lb, lc);
    if (s.shape == ColliderShape::kCapsule)
      for (int k = 0; k < 8; ++k) {
        centre = closest_point_segment(q.point, s.end_a, s.end_b).point;
        q = closest_point_triangle(centre, la, lb, lc);
      }
    const Closest r = round(q.point, centre, s.radius, Vec3::UnitY());
    out.distance = r.distance;
    out.normal = end_.linear() * r.normal;
    out.point = end_ * r.point;
    out.displacement = out.point - start_ * r.point;
    weights = q.weights;
    return true;
  }

  // The box's surface point nearest the triangle: the nearest pair of points of the triangle
  // and the inner box (the box less its edge radius), both convex polytopes, is among the
  // triangle's corners against the box, the box's corners against the triangle and the edges
  // of one against the edges of the other; then the rounding. A triangle reaching into the
  // inner box takes the nearest face of the box at its point found.
  bool box_closest_to_triangle(const Vec3& a, const Vec3& b, const Vec3& c, SurfacePoint& out, Vec3& weights) const {
    const ColliderSpec& s = spec();
    // In the box's own frame (centred, axis-aligned) at the step's end.
    auto local = [&](const Vec3& p) -> Vec3 { return box_rotation_.transpose() * (end_inverse_ * p - s.centre); };
    const std::array<Vec3, 3> tri = {local(a), local(b), local(c)};
    const Vec3 e = s.half_extents - Vec3::Constant(s.edge_radius);
    double best = std::numeric_limits<double>::infinity();
    Vec3 on_box = Vec3::Zero(), w = Vec3(1, 0, 0);
    auto consider = [&](double d, const Vec3& box_point, const Vec3& tri_weights) {
      if (d < best) {
        best = d;
        on_box = box_point;
        w = tri_weights;
      }
    };
    for (int k = 0; k < 3; ++k) {
      const Vec3 p = tri[k].cwiseMax(-e).cwiseMin(e);
      consider((tri[k] - p).norm(), p, Vec3::Unit(k));
    }
    for (int k = 0; k < 8; ++k) {
      const Vec3 corner((k & 1) ? e[0] : -e[0], (k & 2) ? e[1] : -e[1], (k & 4) ? e[2] : -e[2]);
      const PointTriangleClosest q = closest_point_triangle(corner, tri[0], tri[1], tri[2]);
      consider(q.distance, corner, q.weights);
      for (int axis = 0; axis < 3; ++axis) {
        if (corner[axis] > 0) continue;  // each box edge once, from its lower corner
        Vec3 other = corner;
        other[axis] = e[axis];
        for (int j = 0; j < 3; ++j) {
          const int j1 = (j + 1) % 3;
          const SegmentSegmentClosest g = closest_points_segments(tri[j], tri[j1], corner, other);
          Vec3 tw = Vec3::Zero();
          tw[j] = 1 - g.s;
          tw[j1] = g.s;
          consider(g.distance, g.point_q, tw);
        }
      }
    }
    const Vec3 tri_point = w[0] * tri[0] + w[1] * tri[1] + w[2] * tri[2];
    Closest r;
    if (best > 1e-12) {
      const Vec3 n = (tri_point - on_box) / best;
      r = {best - s.edge_radius, n, on_box + s.edge_radius * n};
    } else {
      r = closest_local(s.centre + box_rotation_ * tri_point);
      r.normal = box_rotation_.transpose() * r.normal;
      r.point = box_rotation_.transpose() * (r.point - s.centre);
    }
    out.distance = r.distance;
    out.normal = end_.linear() * (box_rotation_ * r.normal);
    out.point = end_ * (s.centre + box_rotation_ * r.point);
    out.displacement = out.point - start_ * (s.centre + box_rotation_ * r.point);
    weights = w;
    return true;
  }

  void surface(double t, Points& positions, Triangles& triangles) const override {
    std::vector<Vec3> points;
    std::vector<Eigen::Vector3i> tris;
    const ColliderSpec& s = spec();
    switch (s.shape) {
      case ColliderShape::kPlane: {
        // A 4 m square about the plane's point stands for the unbounded plane.
        const Vec3 u = any_unit_normal_to(normal_), w = normal_.cross(u);
        for (int k = 0; k < 4; ++k) {
          const double a = (k == 1 || k == 2) ? 2 : -2, b = k >= 2 ? 2 : -2;
          points.push_back(s.point + a * u + b * w);
        }
        tris.emplace_back(0, 1, 2);
        tris.emplace_back(0, 2, 3);
        break;
      }
      case ColliderShape::kSphere:
        add_round_surface(s.centre, s.radius, Mat3::Identity(), Vec3::Zero(), points, tris);
        break;
      case ColliderShape::kCapsule: {
        // Frame whose y axis runs from end a to end b.
        Mat3 R;
        const Vec3 x = any_unit_normal_to(axis_);
        R.col(0) = x;
        R.col(1) = axis_;
        R.col(2) = x.cross(axis_);
        add_round_surface(s.end_a, s.radius, R, s.end_b - s.end_a, points, tris);
        break;
      }
      case ColliderShape::kBox:
        add_box_surface(s, points, tris);
        break;
      default:
        break;
    }
    const Eigen::Isometry3d T = spec().motion.at(t);
    positions.resize(static_cast<Eigen::Index>(points.size()), 3);
    for (size_t k = 0; k < points.size(); ++k) positions.row(static_cast<Eigen::Index>(k)) = (T * points[k]).transpose();
    triangles.resize(static_cast<Eigen::Index>(tris.size()), 3);
    for (size_t k = 0; k < tris.size(); ++k) triangles.row(static_cast<Eigen::Index>(k)) = tris[k].transpose();
  }

 private:
  Closest closest_local(const Vec3& p) const {
    const ColliderSpec& s = spec();
    switch (s.shape) {
      case ColliderShape::kPlane: {
        const double d = (p - s.point).dot(normal_);
        return {d, normal_, p - d * normal_};
      }
      case ColliderShape::kSphere:
        return round(p, s.centre, s.radius, Vec3::UnitY());
      case ColliderShape::kCapsule: {
        const Vec3 ab = s.end_b - s.end_a;
        const double len2 = ab.squaredNorm();
        const double u = len2 > 0 ? std::clamp((p - s.end_a).dot(ab) / len2, 0.0, 1.0) : 0.0;
        return round(p, s.end_a + u * ab, s.radius, any_unit_normal_to(axis_));
      }
      case ColliderShape::kBox: {
        // The box with rounded edges is its inner box (half extents less the radius) grown by
        // the radius; with radius 0, the box itself.
        const Vec3 q = box_rotation_.transpose() * (p - s.centre);
        const Vec3& h = s.half_extents;
        const double r = s.edge_radius;
        const Vec3 inner = h - Vec3::Constant(r);
        const Vec3 clamped = q.cwiseMax(-inner).cwiseMin(inner);
        const Vec3 outside = q - clamped;
        if (outside.squaredNorm() > 0) {
          const double d = outside.norm();
          const Vec3 n = outside / d;
          return {d - r, box_rotation_ * n, s.centre + box_rotation_ * (clamped + r * n)};
        }
        // Inside the inner box: the nearest face.
        int axis = 0;
        double depth = h[0] - std::abs(q[0]);
        for (int k = 1; k < 3; ++k)
          if (h[k] - std::abs(q[k]) < depth) {
            depth = h[k] - std::abs(q[k]);
            axis = k;
          }
        const double side = q[axis] >= 0 ? 1.0 : -1.0;
        Vec3 n = Vec3::Zero();
        n[axis] = side;
        Vec3 on = q;
        on[axis] = side * h[axis];
        return {-depth, box_rotation_ * n, s.centre + box_rotation_ * on};
      }
      default:
        throw std::logic_error("not an analytic collider");
    }
  }

  Mat3 box_rotation_;
  Vec3 normal_ = Vec3::UnitY();
  Vec3 axis_ = Vec3::UnitY();
  Eigen::Isometry3d start_ = Eigen::Isometry3d::Identity(), end_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d start_inverse_ = Eigen::Isometry3d::Identity(), end_inverse_ = Eigen::Isometry3d::Identity();
};

}  // namespace

std::unique_ptr<Collider> make_analytic_collider(const ColliderSpec& spec) {
  switch (spec.shape) {
    case ColliderShape::kPlane:
    case ColliderShape::kSphere:
    case ColliderShape::kCapsule:
    case ColliderShape::kBox: {
      auto c = std::make_unique<AnalyticCollider>(spec);
      c->prepare(0, 0);
      return c;
    }
    default:
      throw std::invalid_argument("make_analytic_collider: not a plane, sphere, capsule or box");
  }
}

}  // namespace weft
