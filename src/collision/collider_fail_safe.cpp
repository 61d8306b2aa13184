// The colliders' fail-safe at a step's end (ColliderContacts::finish_step): nodes, faces and
// edges that ended within the layer are put back out.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "collision/aabb_tree.hpp"
#include "collision/collider_query_nodes.hpp"
#include "collision/colliders.hpp"
#include "collision/geometry.hpp"

namespace weft {

namespace {

// In the fail-safe's later rounds (ContactReport::round), nodes and faces the other handlers
// moved closer than kLaterRoundTrigger thicknesses are put back at kLaterRoundTarget.
constexpr double kLaterRoundTrigger = 0.25;
constexpr double kLaterRoundTarget = 0.5;

}  // namespace

void ColliderContacts::finish_step(const VecX& x0, VecX& x1, VecX& v1, double t, double dt, ContactReport& report) {
  const int n = static_cast<int>(scene_held_.size());
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
  for (int k = 0; k < 3; ++k) w2 += scene_held_[t[k]] ? 0.0 : weights[k] * weights[k];
  if (!(w2 > 0)) return;
  for (int k = 0; k < 3; ++k) {
    const int i = t[k];
    if (scene_held_[i] || (k > 0 && i == t[k - 1])) continue;  // an edge given as (a, b, b): b once
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
