// Contacts against colliders at a step's start and end (ColliderContacts::detect,
// detect_end): node contacts and the holds of cloth faces over round colliders and over mesh
// colliders' vertices.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "collision/collider_query_nodes.hpp"
#include "collision/colliders.hpp"

namespace weft {

namespace {

// A face's nearest point with a barycentric weight above 1 less this is its vertex, which the
// node's own contact holds (hold_faces_off_round).
constexpr double kFaceHoldVertexWeight = 1e-6;
// hold_faces_off_round holds a face whose nearest point dips at least this many thicknesses
// below its vertices' predicted distances (half the fail-safe's trigger depth).
constexpr double kFaceHoldDip = 0.25;

}  // namespace

ColliderContacts::ColliderContacts(std::vector<Collider*> colliders, const VecX& mass,
                                   const std::vector<char>& scene_held, std::vector<std::array<int, 3>> triangles)
    : colliders_(std::move(colliders)), mass_(mass), scene_held_(scene_held), triangles_(std::move(triangles)) {
  for (Collider* c : colliders_) c->reserve_nodes(static_cast<int>(scene_held_.size()));
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

void ColliderContacts::detect(const VecX& x, const VecX& v, double t, double dt, std::vector<NodeContact>& out) {
  out.clear();
  const int n = static_cast<int>(scene_held_.size());
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
      if (gap >= tunables_.hold_margin * thickness) continue;
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
    if (sp.distance >= tunables_.hold_margin * thickness || w.maxCoeff() > 1 - kFaceHoldVertexWeight) continue;
    // Only a face dipping well below its vertices: a finer one, whose vertices' own holds keep
    // it clear of the fail-safe's trigger, is left to them.
    if (std::min({node_gap_[t[0]], node_gap_[t[1]], node_gap_[t[2]]}) - sp.distance < kFaceHoldDip * thickness) continue;
    const Vec3 face_velocity = w[0] * node(v, t[0]) + w[1] * node(v, t[1]) + w[2] * node(v, t[2]);
    const double displacement = dt * face_velocity.dot(sp.normal) + thickness - sp.distance;
    for (int k = 0; k < 3; ++k) {
      const int i = t[k];
      if (scene_held_[i]) continue;
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
  face_pokes(c, predicted_, tunables_.hold_margin * thickness, pokes_);
  const Points& start = *c.start_vertices();
  const Points& end = *c.end_vertices();
  const int n = static_cast<int>(scene_held_.size());
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
      if (scene_held_[i] || poke.height >= face_held_height_[i]) continue;
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
  const int n = static_cast<int>(scene_held_.size());
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

}  // namespace weft
