// The triangle mesh collider (OBJ colliders, the walking body): closest points through the
// bounding-volume tree refitted each step, pseudo-normals, distance bounds.
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <unordered_map>

#include "collision/aabb_tree.hpp"
#include "collision/colliders.hpp"
#include "collision/geometry.hpp"

namespace weft {

namespace {

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
    if (last_face_.size() < static_cast<size_t>(n)) last_face_.resize(n, -1);
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
    double search = extend ? reach + kBoundReach : reach;
    auto distance = [&](int f) {
      const auto& t = list_[f];
      return closest_point_triangle(p, x.row(t[0]).transpose(), x.row(t[1]).transpose(), x.row(t[2]).transpose())
          .distance;
    };
    // The node's nearest triangle of its last query, most often its nearest again or a
    // neighbour of it: its distance bounds the search (the nearest triangle within a reach does
    // not depend on the reach beyond its distance, ties included), so that boxes farther than
    // it are not opened on the way down to it (with a little room, so that rounding in the
    // boxes' distances cannot leave it out).
    if (bounded && last_face_[node] >= 0) search = std::min(search, distance(last_face_[node]) * (1 + 1e-9) + 1e-12);
    // The nearest triangle within the search (its point found again for the winner only).
    double best = 0;
    const int best_face = tree.nearest(p, search, distance, best);
    if (bounded && best_face >= 0) last_face_[node] = best_face;
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
  mutable std::vector<int> last_face_;  ///< per cloth node: the nearest triangle of its last query (-1: none)
  unsigned epoch_ = 0;  ///< bumped by every prepare that is not the next step or the same one
  double motion_start_ = 0, motion_end_ = 0;  ///< the clock at the step's start and end
};

}  // namespace

std::unique_ptr<Collider> make_mesh_collider(const ColliderSpec& spec, const Triangles& triangles, SurfaceMotion motion,
                                             bool closed) {
  return std::make_unique<MeshCollider>(spec, triangles, std::move(motion), closed);
}

}  // namespace weft
