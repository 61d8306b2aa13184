#include "collision/colliders.hpp"

#include "collision/aabb_tree.hpp"
#include "collision/geometry.hpp"
#include "sim/threads.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <unordered_map>

namespace weft {

Mat3 rotation_from_degrees(const Vec3& deg) {
  const Vec3 r = deg * (M_PI / 180.0);
  return (Eigen::AngleAxisd(r.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(r.y(), Vec3::UnitY()) *
          Eigen::AngleAxisd(r.x(), Vec3::UnitX()))
      .toRotationMatrix();
}

Vec3 degrees_from_rotation(const Mat3& R) {
  // R = Rz(c) Ry(b) Rx(a): Eigen's angles about the axes 2, 1, 0 in that order.
  const Vec3 zyx = R.eulerAngles(2, 1, 0);
  return Vec3(zyx.z(), zyx.y(), zyx.x()) * (180.0 / M_PI);
}

Eigen::Isometry3d RigidMotion::at(double t) const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  switch (kind) {
    case Kind::kStatic:
      break;
    case Kind::kVelocity: {
      // Turning about the moving centre c + v t: x -> R (x - c) + c + v t.
      const double angle = angular_velocity.norm() * t;
      const Mat3 R = angle > 0 ? Eigen::AngleAxisd(angle, angular_velocity.normalized()).toRotationMatrix()
                               : Mat3::Identity();
      T.linear() = R;
      T.translation() = centre + linear_velocity * t - R * centre;
      break;
    }
    case Kind::kKeyframes: {
      if (keys.empty()) break;
      size_t k = 0;
      while (k + 1 < keys.size() && keys[k + 1].time <= t) ++k;
      const Key& a = keys[k];
      const Key& b = k + 1 < keys.size() ? keys[k + 1] : keys[k];
      const double s = b.time > a.time ? std::clamp((t - a.time) / (b.time - a.time), 0.0, 1.0) : 0.0;
      const Eigen::Quaterniond qa(rotation_from_degrees(a.rotation_deg)), qb(rotation_from_degrees(b.rotation_deg));
      T.linear() = qa.slerp(s, qb).toRotationMatrix();
      T.translation() = (1 - s) * a.translation + s * b.translation;
      break;
    }
  }
  return T;
}

namespace {

/// Nodes predicted to end within this multiple of the thickness are held.
constexpr double kHoldMargin = 1.1;
// A face's nearest point with a barycentric weight above 1 less this is its vertex, which the
// node's own contact holds (hold_faces_off_round).
constexpr double kFaceHoldVertexWeight = 1e-6;
// hold_faces_off_round holds a face whose nearest point dips at least this many thicknesses
// below its vertices' predicted distances (half the fail-safe's trigger depth).
constexpr double kFaceHoldDip = 0.25;
// In the fail-safe's later rounds (ContactReport::round), nodes and faces the other handlers
// moved closer than kLaterRoundTrigger thicknesses are put back at kLaterRoundTarget.
constexpr double kLaterRoundTrigger = 0.25;
constexpr double kLaterRoundTarget = 0.5;

// The closest surface point of a shape in its own (t = 0) placement.
struct Closest {
  double distance;
  Vec3 normal, point;
};

Vec3 any_unit_normal_to(const Vec3& axis) {
  const Vec3 other = std::abs(axis.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  return axis.cross(other).normalized();
}

Closest round(const Vec3& p, const Vec3& centre, double radius, const Vec3& fallback_normal) {
  const Vec3 d = p - centre;
  const double r = d.norm();
  const Vec3 n = r > 1e-12 ? Vec3(d / r) : fallback_normal;
  return {r - radius, n, centre + radius * n};
}

// Adds a latitude-longitude sphere of `radius` about `centre`, its upper half (y >= 0 in the
// frame R) shifted by `stretch` (a capsule's axis), to positions and triangles.
void add_round_surface(const Vec3& centre, double radius, const Mat3& R, const Vec3& stretch,
                       std::vector<Vec3>& points, std::vector<Eigen::Vector3i>& tris) {
  const int rings = 16, segments = 32;
  const int base = static_cast<int>(points.size());
  for (int i = 0; i <= rings; ++i) {
    const double theta = M_PI * i / rings;  // from the top
    for (int j = 0; j < segments; ++j) {
      const double phi = 2 * M_PI * j / segments;
      const Vec3 local(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
      points.push_back(centre + radius * (R * local) + (i <= rings / 2 ? stretch : Vec3::Zero()));
    }
  }
  auto at = [&](int i, int j) { return base + i * segments + (j % segments); };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      tris.emplace_back(at(i, j), at(i + 1, j), at(i + 1, j + 1));
      tris.emplace_back(at(i, j), at(i + 1, j + 1), at(i, j + 1));
    }
}

// The box's surface, wound outwards: two triangles per face when its edges are sharp; rounded,
// each face a grid whose lines near the face's rim sit where the rounding turns by equal angles
// (up to 45 degrees, the neighbouring face's grid taking the other half), every grid point
// then put on the rounded surface. Each edge's quarter circle gets 2 * kArcSteps chords, whose
// vertices lie on the surface, so the chords lie inside it.
void add_box_surface(const ColliderSpec& s, std::vector<Vec3>& points, std::vector<Eigen::Vector3i>& tris) {
  constexpr int kArcSteps = 4;
  const Mat3 R = rotation_from_degrees(s.rotation_deg);
  const double r = s.edge_radius;
  const Vec3 inner = s.half_extents - Vec3::Constant(r);
  std::array<std::vector<double>, 3> lines;
  for (int k = 0; k < 3; ++k) {
    std::vector<double>& l = lines[k];
    if (r > 0) {
      for (int j = kArcSteps; j >= 1; --j) l.push_back(-inner[k] - r * std::tan(M_PI / 4 * j / kArcSteps));
      l.push_back(-inner[k]);
      if (inner[k] > 0) l.push_back(inner[k]);
      for (int j = 1; j <= kArcSteps; ++j) l.push_back(inner[k] + r * std::tan(M_PI / 4 * j / kArcSteps));
    } else {
      l = {-s.half_extents[k], s.half_extents[k]};
    }
  }
  for (int axis = 0; axis < 3; ++axis)
    for (double side : {-1.0, 1.0}) {
      const int i = (axis + 1) % 3, j = (axis + 2) % 3;  // e_i x e_j = e_axis
      const int base = static_cast<int>(points.size());
      const int ni = static_cast<int>(lines[i].size()), nj = static_cast<int>(lines[j].size());
      for (int b = 0; b < nj; ++b)
        for (int a = 0; a < ni; ++a) {
          Vec3 p;
          p[axis] = side * s.half_extents[axis];
          p[i] = lines[i][a];
          p[j] = lines[j][b];
          if (r > 0) {
            const Vec3 c = p.cwiseMax(-inner).cwiseMin(inner);
            p = c + r * (p - c).normalized();
          }
          points.push_back(s.centre + R * p);
        }
      for (int b = 0; b + 1 < nj; ++b)
        for (int a = 0; a + 1 < ni; ++a) {
          const int v00 = base + b * ni + a, v10 = v00 + 1, v01 = v00 + ni, v11 = v01 + 1;
          if (side > 0) {
            tris.emplace_back(v00, v10, v11);
            tris.emplace_back(v00, v11, v01);
          } else {
            tris.emplace_back(v00, v11, v10);
            tris.emplace_back(v00, v01, v11);
          }
        }
    }
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

// How much farther than asked a mesh collider's query searches, to measure a bound on the
// node's distance that rules out its next queries (docs/collisions.md, "Distance bounds");
// the most its surface may move in a step, as a share of that, for the wider search to pay;
// and what a bound gives up for the rounding of its sums.
constexpr double kBoundReach = 0.02;
constexpr double kBoundMotionShare = 0.25;
constexpr double kBoundRounding = 1e-9;

// A triangle mesh collider. The closest point is the nearest triangle's within the reach (a
// search of the tree refitted to the surface at the query's time, AabbTree::nearest); its
// side from the pseudo-normal of the feature it lies on (the face's normal, the sum of an
// edge's two faces' normals, the angle-weighted normals of a vertex's faces), which tells
// inside from outside at every point of a closed surface.
class MeshCollider : public Collider {
 public:
  MeshCollider(const ColliderSpec& spec, const Triangles& triangles, SurfaceMotion motion, bool closed)
      : Collider(spec), triangles_(triangles), list_(weft::triangle_list(triangles)), motion_(std::move(motion)), closed_(closed) {
    motion_(0.0, start_);
    end_ = start_;
    tree_start_ = AabbTree(list_, start_.data());
    tree_end_ = tree_start_;
    tree_swept_ = tree_start_;
    // Each edge's faces (for its pseudo-normal).
    for (int f = 0; f < static_cast<int>(list_.size()); ++f)
      for (int k = 0; k < 3; ++k) {
        const int a = list_[f][k], b = list_[f][(k + 1) % 3];
        edge_faces_[key(a, b)].push_back(f);
      }
    // Each vertex's faces (for its pseudo-normal), in compressed rows.
    vertex_face_start_.assign(static_cast<size_t>(start_.rows()) + 1, 0);
    for (const auto& t : list_)
      for (int v : t) ++vertex_face_start_[v + 1];
    for (size_t v = 0; v + 1 < vertex_face_start_.size(); ++v) vertex_face_start_[v + 1] += vertex_face_start_[v];
    vertex_faces_.resize(3 * list_.size());
    std::vector<int> fill(vertex_face_start_.begin(), vertex_face_start_.end() - 1);
    for (int f = 0; f < static_cast<int>(list_.size()); ++f)
      for (int v : list_[f]) vertex_faces_[fill[v]++] = f;
    face_normals(start_, face_normal_start_);
    face_normal_end_ = face_normal_start_;
    for (auto& side : vertex_normal_) side.assign(static_cast<size_t>(start_.rows()), Vec3::Zero());
    for (auto& side : vertex_normal_state_) side = std::make_unique<std::atomic<signed char>[]>(start_.rows());
    clear_vertex_normals(0);
    clear_vertex_normals(1);
  }

  void reserve_nodes(int n) override {
    if (side_.size() < static_cast<size_t>(n)) side_.resize(n, 0);
    if (bound_.size() < static_cast<size_t>(n)) bound_.resize(n);
  }

  void prepare(double t0, double t1) override {
    const bool next = t0 == t1_ && t0 != t0_;
    const bool same = t0 == t0_ && t1 == t1_;
    if (next) {
      // The step after the last: its start is the last one's end.
      std::swap(start_, end_);
      std::swap(tree_start_, tree_end_);
      std::swap(face_normal_start_, face_normal_end_);
      std::swap(vertex_normal_[0], vertex_normal_[1]);
      std::swap(vertex_normal_state_[0], vertex_normal_state_[1]);
    } else if (t0 != t0_) {
      motion_(t0, start_);
      tree_start_.refit(start_.data());
      face_normals(start_, face_normal_start_);
      clear_vertex_normals(0);
    }
    if (t1 != t1_ || t0 != t0_) {
      motion_(t1, end_);
      tree_end_.refit(end_.data());
      face_normals(end_, face_normal_end_);
      clear_vertex_normals(1);
    }
    t0_ = t0;
    t1_ = t1;
    swept_fitted_ = false;
    step_motion_ = 0;
    for (Eigen::Index v = 0; v < start_.rows(); ++v)
      step_motion_ = std::max(step_motion_, (end_.row(v) - start_.row(v)).squaredNorm());
    step_motion_ = std::sqrt(step_motion_);
    // The distance bounds' clock: the surface's motion summed along the steps prepared one
    // after the other; any other change of step voids every bound kept.
    if (next) {
      motion_start_ = motion_end_;
      motion_end_ = motion_start_ + step_motion_;
    } else if (!same) {
      ++epoch_;
      motion_start_ = 0;
      motion_end_ = step_motion_;
    }
  }

  double distance_bound(const Vec3& p, int node, bool end) const override {
    if (node < 0 || static_cast<size_t>(node) >= bound_.size()) return 0;
    const DistanceBound& b = bound_[node];
    if (b.epoch != epoch_) return 0;
    // Every point of the surface now lies within the clock's difference of a point of the
    // surface when the bound was measured (each vertex moved no farther, and a triangle's
    // points move as its vertices' weighted means): the distance shrinks by no more than
    // that and p's own distance from where it was measured.
    const double clock = end ? motion_end_ : motion_start_;
    return b.distance - (p - b.point).norm() - std::abs(clock - b.clock) - kBoundRounding;
  }

  double step_motion() const override { return step_motion_; }
  const AabbTree* end_tree() const override { return &tree_end_; }
  const AabbTree* swept_tree() const override {
    if (step_motion_ == 0) return &tree_end_;  // a still surface sweeps nothing
    if (!swept_fitted_) {
      tree_swept_.refit(start_.data(), end_.data(), 0);
      swept_fitted_ = true;
    }
    return &tree_swept_;
  }
  const Points* end_vertices() const override { return &end_; }
  const Points* start_vertices() const override { return &start_; }
  Vec3 end_vertex_normal(int v) const override { return vertex_normal(v, true).normalized(); }
  const std::vector<std::array<int, 3>>* triangle_list() const override { return &list_; }

  bool closest(const Vec3& p, double reach, bool end, int node, SurfacePoint& out) const override {
    const Points& x = end ? end_ : start_;
    const AabbTree& tree = end ? tree_end_ : tree_start_;
    const bool bounded = node >= 0 && static_cast<size_t>(node) < bound_.size();
    // A node known to be farther than the reach is answered without a search (docs/collisions.md,
    // "Distance bounds"); any other searches kBoundReach farther, which changes no answer
    // (the nearest triangle within a reach does not depend on the reach beyond its distance)
    // and measures a bound that rules out the next queries while the node stays clear.
    double known = 0;
    if (bounded) {
      known = distance_bound(p, node, end);
      if (known > reach) return false;
    }
    // Searching farther pays while the surface moves less in a step than a fraction of the
    // extra reach (the bound then rules out several steps' queries); past that the wider
    // searches cost more than the queries they rule out (docs/notes/contact-cost.md, "Distance
    // bounds and the swept tree").
    const bool extend = bounded && step_motion_ < kBoundReach * kBoundMotionShare;
    const double search = extend ? reach + kBoundReach : reach;
    // The nearest triangle within the search (its point found again for the winner only).
    double best = 0;
    const int best_face = tree.nearest(p, search, [&](int f) {
      const auto& t = list_[f];
      return closest_point_triangle(p, x.row(t[0]).transpose(), x.row(t[1]).transpose(), x.row(t[2]).transpose())
          .distance;
    }, best);
    if (bounded) bound_[node] = {p, std::max(best, known), end ? motion_end_ : motion_start_, epoch_};
    if (best_face < 0 || best > reach) return false;
    const auto& t = list_[best_face];
    const PointTriangleClosest hit =
        closest_point_triangle(p, x.row(t[0]).transpose(), x.row(t[1]).transpose(), x.row(t[2]).transpose());
    const Vec3 pseudo = pseudo_normal(best_face, hit.feature, end);
    const Vec3 away = p - hit.point;
    // The free side: outside a closed surface (where its normals point); for an open one the
    // side the node was on when last clear of it. Positive distances and the normal are on it.
    const double actual = away.dot(pseudo) >= 0 ? 1.0 : -1.0;
    double free = 1.0;
    if (!closed_) {
      if (side_.size() <= static_cast<size_t>(node)) side_.resize(node + 1, 0);
      signed char& kept = side_[node];
      if (kept == 0 || (!end && best > 2 * spec().thickness)) kept = static_cast<signed char>(actual);
      free = kept;
    }
    const double sign = actual * free;
    out.distance = sign * best;
    out.normal = best > 1e-12 ? Vec3(sign * away / best) : Vec3(free * pseudo.normalized());
    out.point = hit.point;
    Vec3 before = Vec3::Zero(), after = Vec3::Zero();
    for (int k = 0; k < 3; ++k) {
      before += hit.weights[k] * start_.row(t[k]).transpose();
      after += hit.weights[k] * end_.row(t[k]).transpose();
    }
    out.displacement = after - before;
    return true;
  }

  void surface(double t, Points& positions, Triangles& triangles) const override {
    motion_(t, positions);
    triangles = triangles_;
  }

 private:
  static long long key(int a, int b) { return (static_cast<long long>(std::min(a, b)) << 32) | std::max(a, b); }

  void face_normals(const Points& x, std::vector<Vec3>& face) const {
    face.resize(list_.size());
    for (size_t f = 0; f < list_.size(); ++f) {
      const auto& t = list_[f];
      const Vec3 a = x.row(t[0]), b = x.row(t[1]), c = x.row(t[2]);
      const Vec3 n = (b - a).cross(c - a);
      face[f] = n.norm() > 0 ? Vec3(n.normalized()) : Vec3::Zero();
    }
  }

  void clear_vertex_normals(int side) {
    for (Eigen::Index v = 0; v < start_.rows(); ++v) vertex_normal_state_[side][v].store(0, std::memory_order_relaxed);
  }

  /// The angle-weighted normal of vertex v (not unit) at the step's start or end, computed
  /// when first asked for in a step (most queries end on a face or an edge) and kept. Queries
  /// on several threads may ask at once: the thread that claims the vertex (state 0 -> 1)
  /// stores the normal and publishes it (state 2); the others compute the same value.
  Vec3 vertex_normal(int v, bool end) const {
    std::atomic<signed char>& state = vertex_normal_state_[end][v];
    if (state.load(std::memory_order_acquire) == 2) return vertex_normal_[end][v];
    const Points& x = end ? end_ : start_;
    const std::vector<Vec3>& face = end ? face_normal_end_ : face_normal_start_;
    Vec3 sum = Vec3::Zero();
    for (int k = vertex_face_start_[v]; k < vertex_face_start_[v + 1]; ++k) {
      const int f = vertex_faces_[k];
      const auto& t = list_[f];
      const int at = t[0] == v ? 0 : t[1] == v ? 1 : 2;
      const Vec3 p = x.row(v), e1 = Vec3(x.row(t[(at + 1) % 3])) - p, e2 = Vec3(x.row(t[(at + 2) % 3])) - p;
      sum += std::atan2(e1.cross(e2).norm(), e1.dot(e2)) * face[f];
    }
    signed char unclaimed = 0;
    if (state.compare_exchange_strong(unclaimed, 1, std::memory_order_acq_rel)) {
      vertex_normal_[end][v] = sum;
      state.store(2, std::memory_order_release);
    }
    return sum;
  }

  Vec3 pseudo_normal(int f, TriangleFeature feature, bool end) const {
    const std::vector<Vec3>& face = end ? face_normal_end_ : face_normal_start_;
    switch (feature.kind) {
      case FeatureKind::kFace:
        return face[f];
      case FeatureKind::kEdge: {
        const auto& t = list_[f];
        const auto it = edge_faces_.find(key(t[feature.index], t[(feature.index + 1) % 3]));
        Vec3 n = Vec3::Zero();
        for (int g : it->second) n += face[g];
        return n;
      }
      case FeatureKind::kVertex:
        return vertex_normal(list_[f][feature.index], end);
    }
    return face[f];
  }

  Triangles triangles_;
  std::vector<std::array<int, 3>> list_;
  SurfaceMotion motion_;
  bool closed_;
  Points start_, end_;
  AabbTree tree_start_, tree_end_;
  mutable AabbTree tree_swept_;  ///< swept_tree(), refitted when first asked for in a step
  mutable bool swept_fitted_ = false;
  std::unordered_map<long long, std::vector<int>> edge_faces_;
  std::vector<Vec3> face_normal_start_, face_normal_end_;
  std::vector<int> vertex_face_start_, vertex_faces_;  ///< each vertex's faces, compressed rows
  mutable std::vector<Vec3> vertex_normal_[2];          ///< [0] start, [1] end
  /// Per vertex and side: 0 not computed, 1 being stored, 2 stored (vertex_normal).
  std::unique_ptr<std::atomic<signed char>[]> vertex_normal_state_[2];
  double t0_ = std::numeric_limits<double>::quiet_NaN(), t1_ = std::numeric_limits<double>::quiet_NaN();
  double step_motion_ = 0;
  mutable std::vector<signed char> side_;  ///< per cloth node, open surfaces: +1 or -1 (0: not yet)
  /// Per cloth node: no point of the surface was nearer than `distance` to `point` when the
  /// surface had moved `clock` along this epoch's steps (distance_bound).
  struct DistanceBound {
    Vec3 point = Vec3::Zero();
    double distance = 0, clock = 0;
    unsigned epoch = 0;
  };
  mutable std::vector<DistanceBound> bound_;
  unsigned epoch_ = 0;  ///< bumped by every prepare that is not the next step or the same one
  double motion_start_ = 0, motion_end_ = 0;  ///< the clock at the step's start and end
};

}  // namespace

std::unique_ptr<Collider> make_mesh_collider(const ColliderSpec& spec, const Triangles& triangles, SurfaceMotion motion,
                                             bool closed) {
  return std::make_unique<MeshCollider>(spec, triangles, std::move(motion), closed);
}

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

ColliderContacts::ColliderContacts(std::vector<Collider*> colliders, const VecX& mass, const std::vector<char>& fixed,
                                   std::vector<std::array<int, 3>> triangles)
    : colliders_(std::move(colliders)), mass_(mass), fixed_(fixed), triangles_(std::move(triangles)) {
  for (Collider* c : colliders_) c->reserve_nodes(static_cast<int>(fixed_.size()));
  for (const auto& t : triangles_)
    for (int k = 0; k < 3; ++k) cloth_edges_.push_back({std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])});
  std::sort(cloth_edges_.begin(), cloth_edges_.end());
  cloth_edges_.erase(std::unique(cloth_edges_.begin(), cloth_edges_.end()), cloth_edges_.end());
  owned_edges_.resize(colliders_.size());
  for (size_t ci = 0; ci < colliders_.size(); ++ci) {
    const auto* list = colliders_[ci]->triangle_list();
    if (!list) continue;
    std::vector<std::array<int, 3>> edges;  // (low, high, 3 f + k)
    for (int f = 0; f < static_cast<int>(list->size()); ++f)
      for (int k = 0; k < 3; ++k) {
        const int a = (*list)[f][k], b = (*list)[f][(k + 1) % 3];
        edges.push_back({std::min(a, b), std::max(a, b), 3 * f + k});
      }
    std::sort(edges.begin(), edges.end());
    owned_edges_[ci].assign(list->size(), 0);
    for (size_t j = 0; j < edges.size(); ++j)
      if (j == 0 || edges[j][0] != edges[j - 1][0] || edges[j][1] != edges[j - 1][1])
        owned_edges_[ci][edges[j][2] / 3] |= static_cast<unsigned char>(1u << (edges[j][2] % 3));
  }
}

template <class Query>
void ColliderContacts::query_nodes(const Query& query) {
  const int n = static_cast<int>(fixed_.size());
  found_.assign(n, 0);
  surface_.resize(n);
  constexpr int kChunk = 256;
  parallel_chunks((n + kChunk - 1) / kChunk, [&](size_t k) {
    for (int i = static_cast<int>(k) * kChunk, end = std::min(n, i + kChunk); i < end; ++i)
      if (!fixed_[i]) found_[i] = query(i, surface_[i]) ? 1 : 0;
  });
}

void ColliderContacts::detect(const VecX& x, const VecX& v, double t, double dt, std::vector<NodeContact>& out) {
  out.clear();
  const int n = static_cast<int>(fixed_.size());
  best_gap_.assign(n, 0);
  std::vector<int>& slot = slot_;  // the node's contact in out
  slot.assign(n, -1);
  touching_.assign(n, 0);
  touching_normal_.assign(n, Vec3::Zero());
  prepared_t_ = t;
  prepared_dt_ = dt;
  predicted_ = x + dt * v;  // the face holds' positions
  for (Collider* c : colliders_) {
    c->prepare(t, t + dt);
    const double thickness = c->spec().thickness;
    query_nodes([&](int i, SurfacePoint& s) {
      // Anything the node could reach this step, and the layer it must stay out of.
      const double reach = 2 * thickness + dt * node(v, i).norm() + c->step_motion();
      return c->closest(node(x, i), reach, false, i, s);
    });
    node_gap_.assign(n, std::numeric_limits<double>::infinity());
    for (int i = 0; i < n; ++i) {
      if (!found_[i]) continue;
      const Vec3 vi = node(v, i);
      const SurfacePoint& s = surface_[i];
      const double approach = dt * vi.dot(s.normal) - s.displacement.dot(s.normal);
      // Where the node would end without the contact, at its present velocity. A node resting
      // at the thickness has gap = thickness: the margin keeps it held (its forces are not in
      // the prediction), and a held node that pulls away is released by the integrator.
      const double gap = s.distance + approach;
      node_gap_[i] = gap;
      if (gap >= kHoldMargin * thickness) continue;
      if (slot[i] >= 0 && gap >= best_gap_[i]) continue;  // another collider is closer
      NodeContact contact;
      contact.node = i;
      contact.normal = s.normal;
      contact.normal_displacement = thickness - s.distance + s.displacement.dot(s.normal);
      contact.surface_velocity = s.displacement / dt;
      contact.friction = c->spec().friction;
      contact.penetrating = s.distance < 0;
      contact.still_surface = never_moves(*c);
      best_gap_[i] = gap;
      touching_[i] = 1;
      touching_normal_[i] = s.normal;
      if (slot[i] >= 0) {
        out[slot[i]] = contact;
      } else {
        slot[i] = static_cast<int>(out.size());
        out.push_back(contact);
      }
    }
    if (c->end_tree() && c->start_vertices() && !triangles_.empty()) hold_faces_over_vertices(*c, x, dt, out);
    if (!triangles_.empty()) hold_faces_off_round(*c, v, dt, out);
  }
}

void ColliderContacts::place(std::vector<NodeContact>& out, int i, const Vec3& normal, double displacement,
                             const Vec3& surface_velocity, const Collider& c) {
  NodeContact contact;
  contact.node = i;
  contact.still_surface = never_moves(c);
  contact.normal = normal;
  contact.normal_displacement = displacement;
  contact.surface_velocity = surface_velocity;
  contact.friction = c.spec().friction;
  touching_[i] = 1;
  touching_normal_[i] = normal;
  if (slot_[i] >= 0) {
    out[slot_[i]] = contact;
  } else {
    slot_[i] = static_cast<int>(out.size());
    out.push_back(contact);
  }
}

void ColliderContacts::hold_faces_off_round(const Collider& c, const VecX& v, double dt,
                                            std::vector<NodeContact>& out) {
  // A cloth face over a round collider (or a box's rounded edge) dips between its vertices
  // towards the surface: by about r^2 / (2 R) for a face of circumradius r over a radius R,
  // 3 mm for a 17 x 17 metre square over a sphere of 0.3 m. Holding only its vertices at the
  // thickness leaves its inside within the thickness, which the fail-safe lifts after every
  // solve and the next solve pulls back down. So a face whose nearest point to the surface at
  // its predicted end (x + dt v) lies off its vertices, within the hold margin and a quarter of
  // the thickness (kFaceHoldDip) or more below its vertices' own has its free
  // vertices held as that point is: moved along the surface's normal there by what puts the
  // point at the thickness at the step's end. A node takes the hold of its lowest face, or its
  // own contact where that is lower.
  if (!c.answers_triangles()) return;
  const double thickness = c.spec().thickness;
  for (const auto& t : triangles_) {
    if (!found_[t[0]] && !found_[t[1]] && !found_[t[2]]) continue;  // no vertex near this collider
    if (found_[t[0]] && found_[t[1]] && found_[t[2]]) {
      // Over a convex surface whose normals at the vertices' nearest points are at most theta
      // apart, a face of longest edge L dips at most about L theta / 2 below its vertices (a
      // chord over an arc: L theta / 8): over a box's flat side, or finer than the curvature,
      // it cannot dip enough to be held.
      double cos_least = 1, longest2 = 0;
      for (int k = 0; k < 3; ++k) {
        const int a = t[k], b = t[(k + 1) % 3];
        cos_least = std::min(cos_least, surface_[a].normal.dot(surface_[b].normal));
        longest2 = std::max(longest2, (node(predicted_, a) - node(predicted_, b)).squaredNorm());
      }
      const double theta2 = 2 * std::max(0.0, 1 - cos_least);  // theta^2, nearly, for small angles
      if (longest2 * theta2 < 4 * kFaceHoldDip * kFaceHoldDip * thickness * thickness) continue;
    }
    SurfacePoint sp;
    Vec3 w;
    c.closest_to_triangle(node(predicted_, t[0]), node(predicted_, t[1]), node(predicted_, t[2]), sp, w);
    if (sp.distance >= kHoldMargin * thickness || w.maxCoeff() > 1 - kFaceHoldVertexWeight) continue;
    // Only a face dipping well below its vertices: a finer one, whose vertices' own holds keep
    // it clear of the fail-safe's trigger, is left to them.
    if (std::min({node_gap_[t[0]], node_gap_[t[1]], node_gap_[t[2]]}) - sp.distance < kFaceHoldDip * thickness) continue;
    const Vec3 face_velocity = w[0] * node(v, t[0]) + w[1] * node(v, t[1]) + w[2] * node(v, t[2]);
    const double displacement = dt * face_velocity.dot(sp.normal) + thickness - sp.distance;
    for (int k = 0; k < 3; ++k) {
      const int i = t[k];
      if (fixed_[i]) continue;
      if (slot_[i] >= 0 && sp.distance >= best_gap_[i]) continue;
      best_gap_[i] = sp.distance;
      place(out, i, sp.normal, displacement, sp.displacement / dt, c);
    }
  }
}

void ColliderContacts::hold_faces_over_vertices(const Collider& c, const VecX& x, double dt,
                                                std::vector<NodeContact>& out) {
  // A cloth face that sags over a ridge of a mesh collider (a shoulder, a knuckle: the
  // collider's vertex between the face's vertices) is held like a node: its vertices, unless
  // held themselves, may not approach the collider along that vertex's normal, and the face's
  // point over the vertex ends the step at the thickness from where the vertex will be. The
  // fail-safe would otherwise lift such faces after every solve and the solve pull them back,
  // putting elastic energy in at each step.
  const double thickness = c.spec().thickness;
  face_pokes(c, predicted_, kHoldMargin * thickness, pokes_);
  const Points& start = *c.start_vertices();
  const Points& end = *c.end_vertices();
  const int n = static_cast<int>(fixed_.size());
  if (static_cast<int>(face_held_height_.size()) != n) face_held_height_.resize(n);
  std::fill(face_held_height_.begin(), face_held_height_.end(), std::numeric_limits<double>::infinity());
  for (const FacePoke& poke : pokes_) {
    // Under an edge the fail-safe lifts the edge; holding its two vertices in the solve as
    // well put energy in where sheets crumple in a funnel's neck (scenes/funnel.json).
    if (poke.on_edge) continue;
    const auto& t = triangles_[poke.face];
    const Vec3 p_end = end.row(poke.vertex).transpose();
    const Vec3 point = poke.weights[0] * node(x, t[0]) + poke.weights[1] * node(x, t[1]) + poke.weights[2] * node(x, t[2]);
    // The face point's displacement along the normal that puts it at the thickness above the
    // vertex's end position; each free vertex of the face is prescribed that displacement.
    const double lift = thickness - (point - p_end).dot(poke.normal);
    const Vec3 surface_velocity = (p_end - start.row(poke.vertex).transpose()) / dt;
    for (int k = 0; k < 3; ++k) {
      const int i = t[k];
      if (fixed_[i] || poke.height >= face_held_height_[i]) continue;
      // A node held against the surface closer than the face is to the vertex keeps that
      // contact; otherwise the face's is the more pressing one (a node can have only one).
      if (slot_[i] >= 0 && !std::isfinite(face_held_height_[i]) && best_gap_[i] <= poke.height) continue;
      face_held_height_[i] = poke.height;
      if (slot_[i] < 0) best_gap_[i] = poke.height;
      place(out, i, poke.normal, lift, surface_velocity, c);
    }
  }
}

void ColliderContacts::detect_end(const VecX& x0, const VecX& x1, double /*t*/, double dt,
                                  const std::vector<char>& held, std::vector<NodeContact>& out) {
  const int n = static_cast<int>(fixed_.size());
  std::vector<int>& slot = slot_;
  slot.assign(n, -1);
  for (Collider* c : colliders_) {
    const double thickness = c->spec().thickness;
    query_nodes([&](int i, SurfacePoint& s) {
      if (held[i]) return false;
      // A node the surface swept past may be deep inside it at the end.
      const double reach = thickness + c->step_motion() + (node(x1, i) - node(x0, i)).norm();
      return c->closest(node(x1, i), reach, true, i, s);
    });
    for (int i = 0; i < n; ++i) {
      if (!found_[i]) continue;
      const SurfacePoint& s = surface_[i];
      if (s.distance >= thickness) continue;
      if (slot[i] >= 0 && s.distance >= best_gap_[i]) continue;
      NodeContact contact;
      contact.node = i;
      contact.normal = s.normal;
      contact.normal_displacement = s.normal.dot(node(x1, i) - node(x0, i)) + thickness - s.distance;
      contact.surface_velocity = s.displacement / dt;
      contact.friction = c->spec().friction;
      contact.penetrating = s.distance < 0;
      contact.still_surface = never_moves(*c);
      best_gap_[i] = s.distance;
      touching_[i] = 1;
      touching_normal_[i] = s.normal;
      if (slot[i] >= 0) {
        out[slot[i]] = contact;
      } else {
        slot[i] = static_cast<int>(out.size());
        out.push_back(contact);
      }
    }
  }
}

void ColliderContacts::finish_step(const VecX& x0, VecX& x1, VecX& v1, double t, double dt, ContactReport& report) {
  const int n = static_cast<int>(fixed_.size());
  if (t != prepared_t_ || dt != prepared_dt_) {
    for (Collider* c : colliders_) c->prepare(t, t + dt);
    prepared_t_ = t;
    prepared_dt_ = dt;
    touching_.assign(n, 0);  // no detection for this step (explicit methods)
    touching_normal_.assign(n, Vec3::Zero());
  }
  // The first round puts back what ends within half the thickness, at the thickness; a later
  // one only what the other handlers moved within a quarter of it, at half of it (the cloth's
  // impulses may move a held node in by a quarter: docs/collisions.md, "One fail-safe after
  // the other").
  const bool later = report.round > 0 && report.left && report.left->size() == x1.size();
  moved_.clear();
  if (later) {
    // The first round left every node it found at half a thickness or more, and its faces
    // likewise: only what moved by the difference since can be closer than the trigger now.
    double least = std::numeric_limits<double>::infinity();
    for (const Collider* c : colliders_) least = std::min(least, c->spec().thickness);
    const double reach = (0.5 - kLaterRoundTrigger) * least;
    moved_.assign(n, 0);
    for (int i = 0; i < n; ++i) moved_[i] = (node(x1, i) - node(*report.left, i)).squaredNorm() >= reach * reach;
  }
  trigger_ = later ? kLaterRoundTrigger : 0.5;
  target_ = later ? kLaterRoundTarget : 1.0;
  for (size_t ci = 0; ci < colliders_.size(); ++ci) {
    Collider* c = colliders_[ci];
    const double thickness = c->spec().thickness;
    // A node held by a constraint ends at the thickness; one that ends well inside the layer
    // was missed or pushed in by its neighbours: it is put back at the thickness, its
    // velocity along the normal no faster towards the surface than the surface itself. (A
    // node's query reads only its own position, so all are made before any is moved.)
    query_nodes([&](int i, SurfacePoint& s) {
      if (!looks_at(i)) return false;
      const double reach = thickness + c->step_motion() + (node(x1, i) - node(x0, i)).norm();
      return c->closest(node(x1, i), reach, true, i, s);
    });
    for (int i = 0; i < n; ++i) {
      if (!found_[i]) continue;
      const SurfacePoint& s = surface_[i];
      if (s.distance >= trigger_ * thickness) continue;
      node(x1, i) += (target_ * thickness - s.distance) * s.normal;
      const Vec3 v_old = node(v1, i);
      const double surface_speed = s.displacement.dot(s.normal) / dt;
      const double vn = v_old.dot(s.normal);
      if (vn < surface_speed) {
        node(v1, i) += (surface_speed - vn) * s.normal;
        report.work += 0.5 * mass_[i] * (node(v1, i).squaredNorm() - v_old.squaredNorm());
      }
      touching_[i] = 1;
      touching_normal_[i] = s.normal;
      ++report.fail_safe_moves;
    }
    if (c->end_tree() && !triangles_.empty()) {
      push_faces_off_vertices(*c, x1, v1, dt, report);
      keep_edges_off_edges(ci, *c, x0, x1, v1, dt, report);
    }
    lift_faces_off_round(*c, x1, v1, report);
  }
  moved_.clear();  // detection's face holds look at every face
}

void ColliderContacts::lift_faces_off_round(const Collider& c, VecX& x1, VecX& v1, ContactReport& report) {
  const double thickness = c.spec().thickness;
  for (const auto& t : triangles_) {
    if (!looks_at(t)) continue;
    SurfacePoint sp;
    Vec3 w;
    if (!c.closest_to_triangle(node(x1, t[0]), node(x1, t[1]), node(x1, t[2]), sp, w)) return;
    if (sp.distance >= trigger_ * thickness) continue;
    lift_face(t, w, target_ * thickness - sp.distance, sp.normal, x1, v1, report);
  }
}

void ColliderContacts::lift_face(const std::array<int, 3>& t, const Vec3& weights, double lift, const Vec3& n, VecX& x1,
                                 VecX& v1, ContactReport& report, double surface_speed) {
  // The face's point with these weights moves by `lift` along n: vertex i by w_i lift / sum w^2.
  double w2 = 0;
  for (int k = 0; k < 3; ++k) w2 += fixed_[t[k]] ? 0.0 : weights[k] * weights[k];
  if (!(w2 > 0)) return;
  for (int k = 0; k < 3; ++k) {
    const int i = t[k];
    if (fixed_[i] || (k > 0 && i == t[k - 1])) continue;  // an edge given as (a, b, b): b once
    node(x1, i) += (weights[k] * lift / w2) * n;
    const Vec3 v_old = node(v1, i);
    const double vn = v_old.dot(n);
    if (vn < surface_speed) {
      node(v1, i) += (surface_speed - vn) * n;
      report.work += 0.5 * mass_[i] * (node(v1, i).squaredNorm() - v_old.squaredNorm());
    }
    ++report.fail_safe_moves;
  }
}

namespace {
// A collider vertex deeper than this behind a cloth face is taken to be on the face's other
// side (under an arm, say), not poking through it.
constexpr double kMaxPokeDepth = 0.02;
// A face is lifted along its own normal only where its vertices' nearest surface normals lean
// to the side it is lifted to: the sum of their cosines with it above kFaceSideAgreement, none
// below kFaceSideLeast (a face across a chin, one vertex under the jaw, is lifted over it).
constexpr double kFaceSideAgreement = 0.2;
constexpr double kFaceSideLeast = -0.5;
}  // namespace

bool ColliderContacts::clear_of(const Collider& c, const VecX& x, const std::array<int, 3>& t, double thickness,
                                double limit) const {
  // A face gives no poke when its vertices' distance bounds show that (1) one of them is
  // farther from the collider than its side normal's reach (the side check then fails) and
  // (2) the whole face is farther than a poke measured along the face's normal can be.
  double lowest = std::numeric_limits<double>::infinity(), highest = 0, longest2 = 0;
  for (int k = 0; k < 3; ++k) {
    const double b = c.distance_bound(node(x, t[k]), t[k], true);
    lowest = std::min(lowest, b);
    highest = std::max(highest, b);
    longest2 = std::max(longest2, (node(x, t[k]) - node(x, t[(k + 1) % 3])).squaredNorm());
  }
  if (!(highest > kMaxPokeDepth + thickness)) return false;
  // Every point of a triangle lies within its longest edge L of each vertex and within
  // L / sqrt(3) of the nearest one.
  const double longest = std::sqrt(longest2);
  const double face = std::max(highest - longest, lowest - longest / std::sqrt(3.0));
  return face >= std::max(limit, kMaxPokeDepth);
}

void ColliderContacts::face_pokes(const Collider& c, const VecX& x, double limit, std::vector<FacePoke>& out) {
  out.clear();
  const double thickness = c.spec().thickness;
  const double margin = std::max(limit, thickness);
  const Points& body = *c.end_vertices();
  const auto& body_triangles = *c.triangle_list();
  const AabbTree& body_tree = *c.end_tree();
  side_normal_known_.assign(fixed_.size(), 0);
  side_normal_.resize(fixed_.size());
  // Each (cloth face, collider vertex) pair once: the vertices of the collider's triangles
  // whose boxes overlap the face's (grown by the margin), faces in order and each face's
  // vertices in increasing order. Their geometry on every thread, each chunk of faces keeping
  // the candidates that qualify, joined in order; then, in order, the side check (its
  // nearest-normal queries are kept per node and made only when needed).
  const int faces = static_cast<int>(triangles_.size());
  constexpr int kChunk = 128;
  const size_t chunks = (faces + kChunk - 1) / kChunk;
  if (chunk_tests_.size() < chunks) chunk_tests_.resize(chunks);
  parallel_chunks(chunks, [&](size_t k) {
    std::vector<PokeTest>& found = chunk_tests_[k];
    found.clear();
    std::vector<int> vertices;
    for (int f = static_cast<int>(k) * kChunk, last = std::min(faces, f + kChunk); f < last; ++f) {
      const auto& t = triangles_[f];
      if (!looks_at(t)) continue;
      if (clear_of(c, x, t, thickness, limit)) continue;
      Box box;
      for (int j = 0; j < 3; ++j) box.add(node(x, t[j]));
      box.lo -= Vec3::Constant(margin);
      box.hi += Vec3::Constant(margin);
      vertices.clear();
      body_tree.for_each_overlapping(box, [&](int b) {
        for (int j = 0; j < 3; ++j) vertices.push_back(body_triangles[b][j]);
      });
      std::sort(vertices.begin(), vertices.end());
      vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
      const Vec3 a = node(x, t[0]), b = node(x, t[1]), cc = node(x, t[2]);
      const Vec3 face_normal = (b - a).cross(cc - a);
      const double area2 = face_normal.norm();
      const Vec3 unit_face_normal = area2 > 0 ? Vec3(face_normal / area2) : Vec3::Zero();
      for (const int vertex : vertices) {
        const Vec3 p = body.row(vertex).transpose();
        const PointTriangleClosest q = closest_point_triangle(p, a, b, cc);
        if (q.feature.kind == FeatureKind::kVertex) continue;  // a neighbouring face's
        const Vec3 n = c.end_vertex_normal(vertex);
        const bool on_edge = q.feature.kind == FeatureKind::kEdge;
        // Two ways to measure the face's height over the vertex: along the vertex's normal, and,
        // for a vertex whose normal says little about the face (a nose's tip, a chin, where the
        // collider is finer than the cloth) and which lies right under the face's inside, along
        // the face's own normal, turned to the cloth's side in the check below.
        PokeTest test;
        test.poke = {f, vertex, q.weights, (q.point - p).dot(n), n, on_edge};
        // A vertex under one of the face's edges (the edge across a ridge, the faces on both
        // sides clear of it): the edge itself, found from both its faces, each move measured
        // where the last left it. Only where the edge passes over the vertex, not beside it (the
        // rim of a sleeve around an arm).
        const double height = test.poke.height;
        test.by_vertex_normal = height < limit && height >= -kMaxPokeDepth &&
                                !(on_edge && (q.point - p - height * n).norm() > 0.5 * thickness);
        test.face_normal = unit_face_normal;
        test.face_height = (q.point - p).dot(test.face_normal);
        test.by_face_normal = area2 > 0 && !on_edge && std::abs(test.face_height) < std::max(limit, kMaxPokeDepth);
        if (test.by_vertex_normal || test.by_face_normal) found.push_back(test);
      }
    }
  });
  auto side_normal = [&](int i) -> const Vec3& {
    if (!side_normal_known_[i]) {
      SurfacePoint sp;
      side_normal_known_[i] = 1;
      side_normal_[i] = c.closest(node(x, i), kMaxPokeDepth + thickness, true, i, sp) ? sp.normal : Vec3::Zero();
    }
    return side_normal_[i];
  };
  if (thread_count() > 1) {
    // On several threads, the side normals of every face with a candidate are found first, in
    // chunks of nodes (each node's query reads only its own position: the checks below read the
    // same normals as when each is found on demand, and a query a check would not have made
    // changes no other query's answer).
    side_nodes_.clear();
    for (size_t chunk = 0; chunk < chunks; ++chunk)
      for (const PokeTest& test : chunk_tests_[chunk])
        for (const int i : triangles_[test.poke.face])
          if (!side_normal_known_[i]) {
            side_normal_known_[i] = 2;  // listed
            side_nodes_.push_back(i);
          }
    for (const int i : side_nodes_) side_normal_known_[i] = 0;
    constexpr size_t kNodesPerChunk = 64;
    parallel_chunks((side_nodes_.size() + kNodesPerChunk - 1) / kNodesPerChunk, [&](size_t k) {
      for (size_t j = k * kNodesPerChunk, end = std::min(side_nodes_.size(), j + kNodesPerChunk); j < end; ++j)
        side_normal(side_nodes_[j]);
    });
  }
  auto check = [&](const PokeTest& test) {
    const auto& t = triangles_[test.poke.face];
    // The face must lie on the vertex's side of the collider: its own vertices' nearest
    // surface normals face the same way (not a face on the far side of a thin part). Lifting
    // faces more freely (those wrapped round an arm) moves so many vertices that the cloth's
    // elastic energy blows up: on coarse cloth (triangles as wide as an arm) edges can still
    // cut the body (docs/collisions.md).
    bool same_side = test.by_vertex_normal;
    for (int k = 0; k < 3 && same_side; ++k) same_side = side_normal(t[k]).dot(test.poke.normal) > 0.5;
    if (same_side) {
      out.push_back(test.poke);
      return;
    }
    if (!test.by_face_normal) return;
    // Measured along the face's normal, turned to the side its vertices' nearest surface
    // normals lean to: they must lean that way together, none strongly against it (a face
    // across a chin, one vertex under the jaw, is lifted over the chin), and the collider's
    // vertex must face that side too (not the inner side of an arm beside the face, which
    // lies in front of the face, not through it).
    Vec3 sum = Vec3::Zero();
    for (int k = 0; k < 3; ++k) sum += side_normal(t[k]);
    const bool flip = sum.dot(test.face_normal) < 0;
    const Vec3 normal = flip ? Vec3(-test.face_normal) : test.face_normal;
    const double height = flip ? -test.face_height : test.face_height;
    if (height >= limit || height < -kMaxPokeDepth || test.poke.normal.dot(normal) <= 0) return;
    double agreement = 0, least = 1;
    for (int k = 0; k < 3; ++k) {
      agreement += side_normal(t[k]).dot(normal);
      least = std::min(least, side_normal(t[k]).dot(normal));
    }
    if (agreement <= kFaceSideAgreement || least <= kFaceSideLeast) return;
    FacePoke poke = test.poke;
    poke.normal = normal;
    poke.height = height;
    out.push_back(poke);
  };
  for (size_t chunk = 0; chunk < chunks; ++chunk)
    for (const PokeTest& test : chunk_tests_[chunk]) check(test);
}

void ColliderContacts::push_faces_off_vertices(const Collider& c, VecX& x1, VecX& v1, double /*dt*/,
                                               ContactReport& report) {
  // As for vertices: a face resting at the thickness sags a little between its vertices over
  // a curved surface, so only a face closer than half the thickness is moved.
  const double thickness = c.spec().thickness;
  face_pokes(c, x1, trigger_ * thickness, pokes_);
  // Move the face's point over the vertex out to the thickness (the pokes in turn, each
  // measured where the earlier lifts left its face).
  for (const FacePoke& poke : pokes_) {
    const auto& t = triangles_[poke.face];
    const Vec3 p = c.end_vertices()->row(poke.vertex).transpose();
    const Vec3 point = poke.weights[0] * node(x1, t[0]) + poke.weights[1] * node(x1, t[1]) + poke.weights[2] * node(x1, t[2]);
    const double height = (point - p).dot(poke.normal);
    if (height >= trigger_ * thickness) continue;
    lift_face(t, poke.weights, target_ * thickness - height, poke.normal, x1, v1, report);
  }
}

namespace {
// The most lifts one cloth edge gets in one pass (it is checked again after each).
constexpr int kEdgeLiftsPerEdge = 3;
}  // namespace

void ColliderContacts::keep_edges_off_edges(size_t collider, const Collider& c, const VecX& x0, VecX& x1, VecX& v1,
                                            double dt, ContactReport& report) {
  const Points* start = c.start_vertices();
  const Points* end = c.end_vertices();
  const auto* list = c.triangle_list();
  if (!start || !end || !list) return;
  const auto& owned = owned_edges_[collider];
  const double thickness = c.spec().thickness;
  const double gap = kEdgeCrossingGap * thickness;
  const double target = kEdgeLiftHeight * target_ * thickness;
  // The collider's triangles whose sweep over the step comes within the gap of the cloth
  // edge's (those of no other can come that close to it in the step).
  const AabbTree* swept_tree = c.swept_tree();
  auto body = [](const Points& p, int v) -> Vec3 { return p.row(v).transpose(); };
  // At any time of the step the edge's point a fraction s along it lies within s L of its
  // first end and (1 - s) L of its second (L its longer length), each end within its
  // displacement of where it ends, and the surface within its step motion of where it ends. So
  // with B the ends' distance bounds at the end less those motions, no point of the edge comes
  // nearer the surface than max(B_a - s L, B_b - (1 - s) L) >= (B_a + B_b - L) / 2: an edge for
  // which that exceeds the gap is skipped. (Neither end being near the surface is not enough:
  // the middle of an edge longer than its ends' reach can cross a ridge, as a cloth quad's folded
  // diagonal did on the body's chest.)
  const double motion = c.step_motion();
  auto bound = [&](int i) {
    const Vec3 end = node(x1, i);
    return c.distance_bound(end, i, true) - (end - node(x0, i)).norm() - motion;
  };
  for (const auto& e : cloth_edges_) {
    if (!looks_at(e[0]) && !looks_at(e[1])) continue;
    const double longest =
        std::sqrt(std::max((node(x0, e[1]) - node(x0, e[0])).squaredNorm(), (node(x1, e[1]) - node(x1, e[0])).squaredNorm()));
    if (0.5 * (bound(e[0]) + bound(e[1]) - longest) > gap) continue;
    for (int lift = 0; lift < kEdgeLiftsPerEdge; ++lift) {
      const Vec3 a0 = node(x0, e[0]), b0 = node(x0, e[1]), a1 = node(x1, e[0]), b1 = node(x1, e[1]);
      Box box;
      box.add(a0);
      box.add(b0);
      box.add(a1);
      box.add(b1);
      box.lo -= Vec3::Constant(gap);
      box.hi += Vec3::Constant(gap);
      edge_candidates_.clear();
      swept_tree->for_each_overlapping(box, [&](int f) {
        for (int k = 0; k < 3; ++k)
          if (owned[f] & (1u << k)) edge_candidates_.push_back({(*list)[f][k], (*list)[f][(k + 1) % 3]});
      });
      // The collider's edge the cloth edge meets first.
      double first = 2;
      std::array<int, 2> hit{-1, -1};
      for (const auto& q : edge_candidates_) {
        Box swept;
        swept.add(body(*start, q[0]));
        swept.add(body(*start, q[1]));
        swept.add(body(*end, q[0]));
        swept.add(body(*end, q[1]));
        if (!swept.overlaps(box)) continue;
        const auto when = edge_edge_ccd(a0, a1, b0, b1, body(*start, q[0]), body(*end, q[0]), body(*start, q[1]),
                                        body(*end, q[1]), gap);
        if (when && *when < first) {
          first = *when;
          hit = q;
        }
      }
      if (hit[0] < 0) break;
      // The pair at that time: its closest points and the normal from the collider's edge out.
      const double u = first;
      const Vec3 p0 = body(*start, hit[0]) + u * (body(*end, hit[0]) - body(*start, hit[0]));
      const Vec3 p1 = body(*start, hit[1]) + u * (body(*end, hit[1]) - body(*start, hit[1]));
      const SegmentSegmentClosest at = closest_points_segments(a0 + u * (a1 - a0), b0 + u * (b1 - b0), p0, p1);
      Vec3 outward = (1 - at.t) * c.end_vertex_normal(hit[0]) + at.t * c.end_vertex_normal(hit[1]);
      Vec3 normal = at.point_p - at.point_q;
      if (normal.norm() > 1e-3 * gap) {
        normal.normalize();
        // The cloth edge already on the collider's inner side of this edge (the step started
        // crossed): nothing this pass can tell about which way is out.
        if (normal.dot(outward) < 0) break;
      } else {
        if (!(outward.norm() > 0)) break;
        normal = outward.normalized();
      }
      const Vec3 q_end = (1 - at.t) * body(*end, hit[0]) + at.t * body(*end, hit[1]);
      const Vec3 q_start = (1 - at.t) * body(*start, hit[0]) + at.t * body(*start, hit[1]);
      const double height = ((1 - at.s) * a1 + at.s * b1 - q_end).dot(normal);
      if (height >= target) break;
      const std::array<int, 3> t{e[0], e[1], e[1]};
      lift_face(t, Vec3(1 - at.s, at.s, 0), target - height, normal, x1, v1, report,
                (q_end - q_start).dot(normal) / dt);
    }
  }
}

}  // namespace weft
