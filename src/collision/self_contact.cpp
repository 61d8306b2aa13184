#include "collision/self_contact.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <optional>
#include <stdexcept>

#include "collision/geometry.hpp"
#include "util/threads.hpp"
#include "util/timer.hpp"

namespace weft {

namespace {

Box grown(Box b, double margin) {
  b.lo -= Vec3::Constant(margin);
  b.hi += Vec3::Constant(margin);
  return b;
}


// A unit normal for a pair whose closest points (nearly) coincide: `fallback` (a face normal or
// the edges' common normal), turned so that the pair's relative velocity approaches along it
// (the impulse then stops the approach whichever side the pair came from).
bool degenerate_normal(const Vec3& fallback, const Vec3& relative_velocity, Vec3& n) {
  const double len = fallback.norm();
  if (!(len > 0)) return false;
  n = fallback / len;
  if (n.dot(relative_velocity) > 0) n = -n;
  return true;
}

}  // namespace

SelfContacts::SelfContacts(const std::vector<std::array<int, 3>>& triangles, const VecX& rest_positions,
                           const VecX& mass, const std::vector<char>& scene_held, double thickness, double friction)
    : triangles_(triangles), scene_held_(scene_held), thickness_(thickness), friction_(friction) {
  if (!(thickness > 0)) throw std::invalid_argument("SelfContacts: the thickness must be positive");
  const int n = static_cast<int>(scene_held.size());
  if (mass.size() != n || rest_positions.size() != 3 * n)
    throw std::invalid_argument("SelfContacts: masses, pins and positions of different sizes");
  inverse_mass_ = VecX::Zero(n);
  for (int i = 0; i < n; ++i)
    if (!scene_held[i] && mass[i] > 0) inverse_mass_[i] = 1 / mass[i];
  // Each vertex and each edge is tested through one triangle holding it, its owner (the first).
  // A primitive's box lies inside every box of a triangle holding it, so a pair of primitives
  // whose boxes overlap comes from a pair of owners whose boxes overlap: every pair is visited
  // once, with no list to sort and deduplicate.
  const int faces = static_cast<int>(triangles.size());
  owned_vertices_.resize(faces);
  owned_edges_.resize(faces);
  std::vector<char> seen(n, 0);
  std::map<std::pair<int, int>, int> edge_id;
  for (int f = 0; f < faces; ++f)
    for (int k = 0; k < 3; ++k) {
      const int v = triangles[f][k];
      if (v < 0 || v >= n) throw std::invalid_argument("SelfContacts: a triangle's vertex is out of range");
      if (!seen[v]) {
        seen[v] = 1;
        Owned& o = owned_vertices_[f];
        o.item[o.count++] = v;
      }
      const int w = triangles[f][(k + 1) % 3];
      const auto key = std::minmax(v, w);
      if (edge_id.emplace(key, static_cast<int>(edges_.size())).second) {
        Owned& o = owned_edges_[f];
        o.item[o.count++] = static_cast<int>(edges_.size());
        edges_.push_back({key.first, key.second});
      }
    }
  // The tree's shape comes from the rest positions, so it is the same however the run started
  // (a resumed run visits the pairs in the same order and gives the same bits).
  tree_ = AabbTree(triangles_, rest_positions.data());
  culling_ = SelfCulling(triangles_, tree_);
  group_.resize(n);
  std::iota(group_.begin(), group_.end(), 0);
  set_primitive_groups();
}

void SelfContacts::set_primitive_groups() {
  triangle_group_.resize(triangles_.size());
  for (size_t f = 0; f < triangles_.size(); ++f)
    for (int k = 0; k < 3; ++k) triangle_group_[f][k] = group_[triangles_[f][k]];
  edge_group_.resize(edges_.size());
  for (size_t e = 0; e < edges_.size(); ++e) edge_group_[e] = {group_[edges_[e][0]], group_[edges_[e][1]]};
}

void SelfContacts::set_vertex_groups(std::vector<int> group) {
  if (group.size() != scene_held_.size()) throw std::invalid_argument("SelfContacts: one group per vertex");
  group_ = std::move(group);
  set_primitive_groups();
}

bool SelfContacts::holds(int f, int v) const {
  const int g = group_[v];
  const auto& t = triangle_group_[f];
  return t[0] == g || t[1] == g || t[2] == g;
}

template <class VertexFace, class EdgeEdge>
void SelfContacts::for_each_candidate(const VecX& xa, const VecX& xb, double margin, double reach,
                                      bool only_changed, VertexFace&& vertex_face, EdgeEdge&& edge_edge) {
  // Regions that cannot hold a pair within reach are passed over; when that is the whole cloth,
  // there is nothing to look at.
  if (culling_on_) {
    culling_.find(triangles_, tree_, xa, xb, reach, culled_);
    if (!culled_.empty() && culled_[0]) return;
  }
  // The tree's boxes hold the primitives at xa and xb, grown by the margin.
  if (&xa == &xb) tree_.refit(xa.data(), margin); else tree_.refit(xa.data(), xb.data(), margin);
  const int n = static_cast<int>(scene_held_.size());
  std::vector<Box>& vb = vertex_box_;
  std::vector<Box>& eb = edge_box_;
  vb.resize(n);
  for (int i = 0; i < n; ++i) {
    Box b;
    b.add(node(xa, i));
    b.add(node(xb, i));
    vb[i] = grown(b, margin);
  }
  eb.resize(edges_.size());
  for (size_t e = 0; e < edges_.size(); ++e) {
    eb[e] = vb[edges_[e][0]];
    eb[e].add(vb[edges_[e][1]].lo);
    eb[e].add(vb[edges_[e][1]].hi);
  }
  // The pairs of owner triangles whose boxes overlap, in the tree's order (found on every
  // thread, in the same order).
  tree_.collect_self_pairs(
      [&](int g, int h) {
        const auto& tg = triangles_[g];
        const auto& th = triangles_[h];
        // Unless only_changed: the same trajectories as at the last detection are left out.
        return !only_changed || changed_[tg[0]] || changed_[tg[1]] || changed_[tg[2]] || changed_[th[0]] ||
               changed_[th[1]] || changed_[th[2]];
      },
      triangle_pairs_, triangle_pair_pieces_, culling_on_ ? &culled_ : nullptr);
  // Their primitives' pairs, tested in chunks of triangle pairs on every thread; each chunk
  // keeps what it finds, and the chunks are joined in order: pairs_ holds the same pairs in
  // the same order whatever the number of threads.
  const size_t count = triangle_pairs_.size();
  const size_t chunks = (count + kCandidateChunk - 1) / kCandidateChunk;
  if (chunk_pairs_.size() < chunks) chunk_pairs_.resize(chunks);
  parallel_chunks(chunks, [&](size_t k) {
    std::vector<Stencil>& out = chunk_pairs_[k];
    out.clear();
    Stencil s;
    for (size_t c = k * kCandidateChunk, end = std::min(count, c + kCandidateChunk); c < end; ++c) {
      const int g = triangle_pairs_[c][0], h = triangle_pairs_[c][1];
      const Box& box_g = tree_.triangle_box(g);
      const Box& box_h = tree_.triangle_box(h);
      for (int pass = 0; pass < 2; ++pass) {
        const int a = pass ? h : g, b = pass ? g : h;
        const Box& box_b = pass ? box_g : box_h;
        for (int v : owned_vertices_[a])
          if (!holds(b, v) && vb[v].overlaps(box_b) && vertex_face(v, b, s)) out.push_back(s);
      }
      for (int e : owned_edges_[g]) {
        const Box& be = eb[e];
        if (!be.overlaps(box_h)) continue;
        const int p0 = edge_group_[e][0], p1 = edge_group_[e][1];
        for (int e2 : owned_edges_[h]) {
          const int q0 = edge_group_[e2][0], q1 = edge_group_[e2][1];
          if (p0 == q0 || p0 == q1 || p1 == q0 || p1 == q1) continue;
          if (be.overlaps(eb[e2]) && edge_edge(e, e2, s)) out.push_back(s);
        }
      }
    }
  });
  for (size_t k = 0; k < chunks; ++k) pairs_.insert(pairs_.end(), chunk_pairs_[k].begin(), chunk_pairs_[k].end());
}

void SelfContacts::find_proximities(const VecX& x0) {
  pairs_.clear();
  if (proximity_x_.size() == x0.size() && proximity_x_ == x0) {
    // The same positions as the last search (detect, then finish_step at the step's start):
    // the same pairs, the touching ones' normals turned to the current u as a search would.
    pairs_ = proximity_pairs_;
    for (Stencil& s : pairs_) {
      if (!s.touching) continue;
      const auto& k = s.node;
      const Vec3 fallback =
          s.vertex_face ? Vec3((node(x0, k[2]) - node(x0, k[1])).cross(node(x0, k[3]) - node(x0, k[1])))
                        : Vec3((node(x0, k[1]) - node(x0, k[0])).cross(node(x0, k[3]) - node(x0, k[2])));
      degenerate_normal(fallback, relative_velocity(s), s.normal);
    }
    return;
  }
  const double h = thickness_;
  const double reach = tunables_.self_hold_reach * h;  // the repulsions take those within h
  for_each_candidate(
      x0, x0, 0.5 * reach, reach, false,
      [&](int v, int f, Stencil& s) {
        const auto& t = triangles_[f];
        const PointTriangleClosest c = closest_point_triangle(node(x0, v), node(x0, t[0]), node(x0, t[1]), node(x0, t[2]));
        if (c.distance >= reach) return false;
        s = Stencil{};
        s.node = {v, t[0], t[1], t[2]};
        s.weight = {1, -c.weights[0], -c.weights[1], -c.weights[2]};
        s.vertex_face = true;
        s.gap = c.distance;
        s.distance = h;
        if (c.distance > 1e-9 * h) {
          s.normal = (node(x0, v) - c.point) / c.distance;
        } else {
          const Vec3 face = (node(x0, t[1]) - node(x0, t[0])).cross(node(x0, t[2]) - node(x0, t[0]));
          if (!degenerate_normal(face, relative_velocity(s), s.normal)) return false;
          s.touching = true;
        }
        return true;
      },
      [&](int e, int e2, Stencil& s) {
        const auto& p = edges_[e];
        const auto& q = edges_[e2];
        const SegmentSegmentClosest c =
            closest_points_segments(node(x0, p[0]), node(x0, p[1]), node(x0, q[0]), node(x0, q[1]));
        if (c.distance >= reach) return false;
        s = Stencil{};
        s.node = {p[0], p[1], q[0], q[1]};
        s.weight = {1 - c.s, c.s, -(1 - c.t), -c.t};
        s.gap = c.distance;
        s.distance = h;
        if (c.distance > 1e-9 * h) {
          s.normal = (c.point_p - c.point_q) / c.distance;
        } else {
          const Vec3 common = (node(x0, p[1]) - node(x0, p[0])).cross(node(x0, q[1]) - node(x0, q[0]));
          if (!degenerate_normal(common, relative_velocity(s), s.normal)) return false;
          s.touching = true;
        }
        return true;
      });
  proximity_x_ = x0;
  proximity_pairs_ = pairs_;
}

void SelfContacts::detect(const VecX& x, const VecX& v, double /*t*/, double dt, std::vector<NodeContact>& out) {
  if (!(dt > 0)) return;
  const int n = static_cast<int>(scene_held_.size());
  u_ = v;  // the approach direction of pairs whose closest points coincide
  detected_x_ = x;
  find_proximities(x);
  has_contact_.assign(n, 0);
  contact_slot_.assign(n, -1);
  for (size_t k = 0; k < out.size(); ++k) {
    has_contact_[out[k].node] = 1;
    contact_slot_[out[k].node] = static_cast<int>(k);
  }
  layered_.assign(n, 0);
  // A vertex a collider holds over a face that the collider holds too, on the collider's side
  // away from it, is held against that face instead: the layer lies between them, and the
  // collider's hold (at its own thickness) would pull the vertex into the layer, for the
  // fail-safe to push it out again with the difference as velocity.
  auto on_layer = [&](int i, const Stencil& s) {
    if (!s.vertex_face || s.node[0] != i) return false;
    const NodeContact& held = out[contact_slot_[i]];
    if (held.kinematic) return false;
    for (int k = 1; k < 4; ++k)
      if (!has_contact_[s.node[k]]) return false;
    return s.normal.dot(held.normal) > kLayerNormalAgreement;
  };
  // Each node's nearest pair within the thickness: as the vertex of a vertex-face pair, or as an
  // end of an edge of an edge-edge pair that carries at least kEdgeHoldWeight of the edge's
  // closest point (the nodes of both edges, each held against the other edge).
  closest_pair_.assign(n, -1);
  hold_normal_.assign(n, Vec3::Zero());
  closest_side_.assign(n, 0);
  auto offer = [&](int i, int k, int side) {
    if (scene_held_[i] || (has_contact_[i] && !on_layer(i, pairs_[k]))) return;
    const int c = closest_pair_[i];
    if (c < 0 || pairs_[k].gap < pairs_[c].gap) {
      closest_pair_[i] = k;
      closest_side_[i] = static_cast<char>(side);
    }
  };
  // The side of a pair (0: its vertex or first edge, 1: its face or second edge) whose every node
  // a collider that never moves holds at rest (NodeContact::still_surface, slower than
  // kHeldRestSpeed) while no node of the other side is held; -1 when no collider or clamp holds a
  // node of the pair, 2 otherwise.
  auto resting_side = [&](const Stencil& s) {
    const int split = s.vertex_face ? 1 : 2;
    int held[2] = {0, 0}, resting[2] = {0, 0};
    for (int j = 0; j < 4; ++j) {
      const int i = s.node[j];
      if (!has_contact_[i]) continue;
      const int side = j < split ? 0 : 1;
      ++held[side];
      const NodeContact& c = out[contact_slot_[i]];
      if (c.still_surface && !c.kinematic && node(v, i).norm() <= tunables_.held_rest_speed) ++resting[side];
    }
    if (held[0] == 0 && held[1] == 0) return -1;
    if (resting[0] == split && held[1] == 0) return 0;
    if (resting[1] == 4 - split && held[0] == 0) return 1;
    return 2;
  };
  auto each_offer = [&](auto&& offer_to) {
    for (size_t k = 0; k < pairs_.size(); ++k) {
      const Stencil& s = pairs_[k];
      const int kk = static_cast<int>(k);
      const int resting = resting_side(s);
      // Beyond the thickness only layers at rest on each other: no collider holds a node of
      // the pair, or it holds one side at rest and none of the other.
      if (s.gap >= s.distance && (resting == 2 || relative_velocity(s).norm() > tunables_.self_hold_reach_speed)) continue;
      // A side a collider holds at rest is the surface the other side's nodes are held against
      // (those carrying at least kEdgeHoldWeight of their side's point): a layer lying on a layer
      // that rests on a collider, along the vertex-face and edge-edge pairs between them.
      // Otherwise a vertex against a face, and the ends of two edges each against the other.
      if (resting == 0 || resting == 1) {
        const int split = s.vertex_face ? 1 : 2;
        const int begin = resting == 0 ? split : 0, end = resting == 0 ? 4 : split;
        for (int j = begin; j < end; ++j)
          if (std::abs(s.weight[j]) >= kEdgeHoldWeight) offer_to(s.node[j], kk, 1 - resting);
        continue;
      }
      if (s.vertex_face) {
        offer_to(s.node[0], kk, 0);
        continue;
      }
      // Another pair with a node a collider holds is left to the fail-safe: where the walking
      // body pinches the cloth between arm and torso, holding edges against edges the body
      // drives let the solve strain the sheet by up to 1,930 J in a step (docs/collisions.md).
      if (resting != -1) continue;
      for (int j = 0; j < 4; ++j)
        if (std::abs(s.weight[j]) >= kEdgeHoldWeight) offer_to(s.node[j], kk, j < 2 ? 0 : 1);
    }
  };
  each_offer(offer);
  // The normal from a pair's other side towards the node.
  auto normal_for = [&](int k, int side) { return side == 0 ? pairs_[k].normal : Vec3(-pairs_[k].normal); };
  // A node the cloth holds is held against a second pair too, its nearest whose normal leans
  // away from the first's by more than kSecondHoldSine: a node in a crease, or where two
  // layers meet at an angle, would otherwise be driven by the solve into the pair it is not
  // held against, in step after step, for the fail-safe to push it out again.
  second_pair_.assign(n, -1);
  second_side_.assign(n, 0);
  each_offer([&](int i, int k, int side) {
    const int c = closest_pair_[i];
    if (c < 0 || c == k || has_contact_[i]) return;
    if (normal_for(c, closest_side_[i]).cross(normal_for(k, side)).norm() < kSecondHoldSine) return;
    // Not against a layer a collider holds: where the walking body drives two layers at a node
    // from two sides (a pinch), holding it against both strains the cloth between them.
    for (int j : pairs_[k].node)
      if (has_contact_[j]) return;
    const int c2 = second_pair_[i];
    if (c2 < 0 || pairs_[k].gap < pairs_[c2].gap) {
      second_pair_[i] = k;
      second_side_[i] = static_cast<char>(side);
    }
  });
  const double push = 1 / std::max(tunables_.self_repulsion_time, dt);
  // The other side of a pair (the face, or the other edge: weights of magnitudes summing to one)
  // seen from a node on side `first` (the pair's first primitive) with the normal from that
  // side towards the node: its point's velocity, without approach along the normal. The node
  // follows a surface that draws back, but is not driven by one that comes at it: the
  // constraint only ever pushes (one that pulls is let go), so following every approach of a
  // face that jitters would rectify the jitter into work on the cloth. An approaching face is
  // left to the fail-safe's impulses, which act on both sides and keep momentum.
  auto other_side = [&](const Stencil& p, bool first, const Vec3& normal) {
    Vec3 velocity = Vec3::Zero();
    for (int k = 0; k < 4; ++k) {
      if (p.vertex_face ? (k == 0) == first : (k < 2) == first) continue;
      velocity += std::abs(p.weight[k]) * node(v, p.node[k]);
    }
    return Vec3(velocity - normal * std::max(0.0, normal.dot(velocity)));
  };
  for (int i = 0; i < n; ++i) {
    if (closest_pair_[i] < 0) continue;
    const Stencil& s = pairs_[closest_pair_[i]];
    const bool first = closest_side_[i] == 0;
    NodeContact c;
    c.node = i;
    c.normal = normal_for(closest_pair_[i], closest_side_[i]);
    hold_normal_[i] = c.normal;
    c.surface_velocity = other_side(s, first, c.normal);
    c.normal_displacement = dt * (c.normal.dot(c.surface_velocity) + std::max(0.0, s.distance - s.gap) * push);
    c.friction = s.gap < kFrictionReach * s.distance ? friction_ : 0.0;  // none across a wider gap
    if (second_pair_[i] >= 0) {
      // The second pair's prescribed dx . n2 = d2, with dx = d1 n + a t + (free part along
      // n x t), t the unit part of n2 orthogonal to n: a = (d2 - d1 n . n2) / (t . n2).
      const Stencil& s2 = pairs_[second_pair_[i]];
      const bool first2 = second_side_[i] == 0;
      const Vec3 n2 = normal_for(second_pair_[i], second_side_[i]);
      const Vec3 sv2 = other_side(s2, first2, n2);
      const double d2 = dt * (n2.dot(sv2) + std::max(0.0, s2.distance - s2.gap) * push);
      const Vec3 t = n2 - c.normal * c.normal.dot(n2);
      const double sine = t.norm();
      c.normal2 = t / sine;
      c.normal_displacement2 = (d2 - c.normal_displacement * c.normal.dot(n2)) / sine;
      c.surface_velocity += c.normal2 * c.normal2.dot(sv2 - c.surface_velocity);
    }
    if (has_contact_[i]) {
      out[contact_slot_[i]] = c;
      layered_[i] = 1;
    } else {
      out.push_back(c);
    }
  }
}

Vec3 SelfContacts::relative_velocity(const Stencil& s) const {
  Vec3 v = Vec3::Zero();
  for (int k = 0; k < 4; ++k) v += s.weight[k] * node(u_, s.node[k]);
  return v;
}

size_t SelfContacts::find_collisions(const VecX& x0, double dt, bool skip_zones) {
  pairs_.clear();
  const double delta = kCollisionDistanceFraction * thickness_;
  x_end_ = x0 + dt * u_;
  const VecX& x1 = x_end_;
  auto same_zone = [&](const std::array<int, 4>& nodes) {
    if (!skip_zones) return false;
    const int z = zone_of(nodes[0]);
    return zone_of(nodes[1]) == z && zone_of(nodes[2]) == z && zone_of(nodes[3]) == z;
  };
  // The pair's own distance: the collision distance, or half the distance it starts at when
  // it starts closer (a pair the repulsions could not lift is only kept from crossing).
  auto hit_time = [&](auto&& ccd, auto&& start_distance) -> std::optional<std::pair<double, double>> {
    const std::optional<double> t = ccd(delta);
    if (!t) return std::nullopt;
    if (*t > 0) return std::make_pair(*t, delta);
    const double own = 0.5 * std::min(2 * delta, start_distance());
    const std::optional<double> t_own = own < delta ? ccd(own) : t;
    if (!t_own) return std::nullopt;
    return std::make_pair(*t_own, own);
  };
  auto at = [&](int i, double t) -> Vec3 { return node(x0, i) + t * (node(x1, i) - node(x0, i)); };
  // Normal at the hit and separation along it at the step's start; the closest points'
  // direction, or for touching points the geometric normal turned to the side of the start.
  auto finish = [&](Stencil& s, const Vec3& offset, double distance, const Vec3& fallback) {
    Vec3 start = Vec3::Zero();
    for (int k = 0; k < 4; ++k) start += s.weight[k] * node(x0, s.node[k]);
    if (distance > 1e-9 * thickness_) {
      s.normal = offset / distance;
    } else {
      const double len = fallback.norm();
      if (!(len > 0)) return false;
      s.normal = fallback / len;
      if (s.normal.dot(start) < 0) s.normal = -s.normal;
    }
    s.gap = s.normal.dot(start);
    return true;
  };
  for_each_candidate(
      x0, x1, 0.5 * delta, delta, true,
      [&](int v, int f, Stencil& s) {
        const auto& t = triangles_[f];
        s = Stencil{};
        s.node = {v, t[0], t[1], t[2]};
        if (same_zone(s.node)) return false;
        const auto hit = hit_time(
            [&](double d) {
              return vertex_face_ccd(node(x0, v), node(x1, v), node(x0, t[0]), node(x1, t[0]), node(x0, t[1]),
                                     node(x1, t[1]), node(x0, t[2]), node(x1, t[2]), d);
            },
            [&] {
              return closest_point_triangle(node(x0, v), node(x0, t[0]), node(x0, t[1]), node(x0, t[2])).distance;
            });
        if (!hit) return false;
        const double th = hit->first;
        const Vec3 a = at(t[0], th), b = at(t[1], th), c = at(t[2], th), p = at(v, th);
        const PointTriangleClosest cl = closest_point_triangle(p, a, b, c);
        s.weight = {1, -cl.weights[0], -cl.weights[1], -cl.weights[2]};
        s.distance = hit->second;
        return finish(s, p - cl.point, cl.distance, (b - a).cross(c - a));
      },
      [&](int e, int e2, Stencil& s) {
        const auto& p = edges_[e];
        const auto& q = edges_[e2];
        s = Stencil{};
        s.node = {p[0], p[1], q[0], q[1]};
        if (same_zone(s.node)) return false;
        const auto hit = hit_time(
            [&](double d) {
              return edge_edge_ccd(node(x0, p[0]), node(x1, p[0]), node(x0, p[1]), node(x1, p[1]), node(x0, q[0]),
                                   node(x1, q[0]), node(x0, q[1]), node(x1, q[1]), d);
            },
            [&] {
              return closest_points_segments(node(x0, p[0]), node(x0, p[1]), node(x0, q[0]), node(x0, q[1])).distance;
            });
        if (!hit) return false;
        const double th = hit->first;
        const Vec3 p0 = at(p[0], th), p1 = at(p[1], th), q0 = at(q[0], th), q1 = at(q[1], th);
        const SegmentSegmentClosest cl = closest_points_segments(p0, p1, q0, q1);
        s.weight = {1 - cl.s, cl.s, -(1 - cl.t), -cl.t};
        s.distance = hit->second;
        return finish(s, cl.point_p - cl.point_q, cl.distance, (p1 - p0).cross(q1 - q0));
      });
  std::fill(changed_.begin(), changed_.end(), 0);
  return pairs_.size();
}

bool SelfContacts::apply(const Stencil& s, double target, bool with_friction, bool lever_limit) {
  double w = 0;
  for (int k = 0; k < 4; ++k) w += s.weight[k] * s.weight[k] * step_inverse_mass_[s.node[k]];
  if (!(w > 0)) return false;
  const Vec3 v = relative_velocity(s);
  const double vn = v.dot(s.normal);
  if (vn >= target) return false;
  // The change of the relative velocity: along the normal up to the target, and Coulomb
  // friction taking at most friction times that off the tangential part, never reversing it.
  const double normal_change = target - vn;
  Vec3 change = normal_change * s.normal;
  const Vec3 tangential = v - vn * s.normal;
  const double slide = tangential.norm();
  if (with_friction && friction_ > 0 && slide > 0) change -= std::min(friction_ * normal_change, slide) / slide * tangential;
  // The impulse weight_k change / w on node k changes the relative velocity by exactly
  // `change`, and its parts sum to zero (the weights do): momentum is kept. A light node of
  // small weight against heavy ones would take many times the change; the impulse is then cut
  // so that no node's velocity changes by more than kMaxVelocityChangeRatio times it, and
  // what is left to later passes and the impact zones.
  double largest = 0;
  for (int k = 0; k < 4; ++k) largest = std::max(largest, std::abs(s.weight[k]) * step_inverse_mass_[s.node[k]] / w);
  const double scale = std::min(1.0, kMaxVelocityChangeRatio / largest) / w;
  // One side of the pair immovable (a vertex of a layer lying on a collider, say): the other
  // side's nodes resting where the solve held them are not thrown off what they rest on.
  const int split = s.vertex_face ? 1 : 2;  // the first side's nodes: the vertex, or an edge
  double movable[2] = {0, 0};  // each side's share of its point carried by nodes that can move
  for (int k = 0; k < 4; ++k)
    if (step_inverse_mass_[s.node[k]] > 0) movable[k < split ? 0 : 1] += std::abs(s.weight[k]);
  const bool still[2] = {movable[0] == 0, movable[1] == 0};
  const bool against_still = still[0] || still[1];
  // A repulsion between a still side and a side carried almost wholly by still nodes would
  // lever the few light ones it can move many times the change, pair after pair (a node
  // carrying 2% of an edge whose other end rests, under a resting vertex of the layer beneath,
  // was thrown 2 cm in one step): such a pair is left to continuous detection.
  if (lever_limit && ((still[0] && movable[1] < kEdgeHoldWeight) || (still[1] && movable[0] < kEdgeHoldWeight)))
    return false;
  for (int k = 0; k < 4; ++k) {
    const int i = s.node[k];
    if (step_inverse_mass_[i] == 0) continue;
    Vec3 du = (s.weight[k] * step_inverse_mass_[i] * scale) * change;
    const Vec3& n = step_held_normal_[i];
    const double inward = -du.dot(n);
    if (inward > 0) {
      // Held against a collider: past its room, the part into the collider is the collider's.
      const double taken = std::min(inward, inward_budget_[i]);
      inward_budget_[i] -= taken;
      du += (inward - taken) * n;
    }
    if (against_still && !resting_normal_.empty()) {
      // Resting where the solve held it: not thrown off the face it rests on.
      const Vec3& r = resting_normal_[i];
      const double outward = du.dot(r);
      if (outward > 0) du -= outward * r;
    }
    node(u_, i) += du;
    changed_[i] = 1;
  }
  return true;
}

int SelfContacts::zone_of(int i) const {
  while (parent_[i] != i) i = parent_[i];
  return i;
}

void SelfContacts::merge(int a, int b) {
  a = zone_of(a);
  b = zone_of(b);
  if (a == b) return;
  if (a > b) std::swap(a, b);  // the lower node number is the root: independent of the order
  parent_[b] = a;
  zone_stopped_[a] = zone_stopped_[a] || zone_stopped_[b];
  zone_dirty_[a] = 1;
}

void SelfContacts::rigidify_zones(const VecX& x0, double dt, bool stop) {
  const int n = static_cast<int>(scene_held_.size());
  // Path compression once per round, then the members of every zone that grew.
  for (int i = 0; i < n; ++i) parent_[i] = zone_of(i);
  std::vector<std::vector<int>>& members = zone_members_;
  for (auto& m : members) m.clear();
  for (int i = 0; i < n; ++i)
    if (zone_dirty_[parent_[i]]) members[parent_[i]].push_back(i);
  for (int root = 0; root < n; ++root) {
    if (!zone_dirty_[root]) continue;
    zone_dirty_[root] = 0;
    const std::vector<int>& nodes = members[root];
    bool pinned = false;
    double mass = 0;
    Vec3 centre = Vec3::Zero(), velocity = Vec3::Zero();
    for (int i : nodes) {
      if (step_inverse_mass_[i] == 0) {
        pinned = true;
        break;
      }
      const double m = 1 / step_inverse_mass_[i];
      mass += m;
      centre += m * node(x0, i);
      velocity += m * node(u_, i);
    }
    Vec3 omega = Vec3::Zero();
    if (!pinned && !stop && !zone_stopped_[root]) {
      centre /= mass;
      velocity /= mass;
      // The angular velocity keeping the zone's angular momentum about its centre of mass:
      // I omega = L, I possibly singular (a zone on a line) and then solved in its range.
      Mat3 inertia = Mat3::Zero();
      Vec3 momentum = Vec3::Zero();
      for (int i : nodes) {
        const double m = 1 / step_inverse_mass_[i];
        const Vec3 r = node(x0, i) - centre;
        inertia += m * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
        momentum += m * r.cross(Vec3(node(u_, i)) - velocity);
      }
      const Eigen::SelfAdjointEigenSolver<Mat3> eig(inertia);
      const double largest = eig.eigenvalues().maxCoeff();
      for (int k = 0; k < 3; ++k) {
        const double lambda = eig.eigenvalues()[k];
        if (lambda > 1e-12 * largest) {
          const Vec3 axis = eig.eigenvectors().col(k);
          omega += axis * (axis.dot(momentum) / lambda);
        }
      }
    }
    // A zone turning by more than a radian in a step, holding a pinned node or past the rigid
    // rounds is stopped: all its nodes stay where they are.
    const double angle = omega.norm() * dt;
    const bool stopped = pinned || stop || zone_stopped_[root] || angle > 1.0;
    zone_stopped_[root] = stopped;
    const Mat3 R = angle > 0 ? Eigen::AngleAxisd(angle, omega / omega.norm()).toRotationMatrix() : Mat3::Identity();
    for (int i : nodes) {
      Vec3 u = Vec3::Zero();
      if (!stopped) {
        // Rotated positions rather than omega x r: the zone ends the step as a rigid copy of
        // its start, and in between an invertible affine image of it, so it cannot cross itself.
        const Vec3 r = node(x0, i) - centre;
        u = (centre + dt * velocity + R * r - Vec3(node(x0, i))) / dt;
      }
      if (u != node(u_, i)) {
        node(u_, i) = u;
        changed_[i] = 1;
      }
    }
  }
}

void SelfContacts::finish_step(const VecX& x0, VecX& x1, VecX& v1, double /*t*/, double dt, ContactReport& report) {
  if (!(dt > 0)) return;
  const auto start = Clock::now();
  const int n = static_cast<int>(scene_held_.size());
  u_ = (x1 - x0) / dt;
  step_inverse_mass_ = inverse_mass_;
  step_held_normal_.assign(n, Vec3::Zero());
  inward_budget_.assign(n, kHeldInwardRoom * thickness_ / dt);
  const bool with_normals = held_normal_ && held_normal_->size() == static_cast<size_t>(n);
  if (held_ && held_->size() == static_cast<size_t>(n))
    for (int i = 0; i < n; ++i) {
      if (!(*held_)[i] || (layered_.size() == static_cast<size_t>(n) && layered_[i])) continue;
      if (node(u_, i).norm() <= tunables_.held_rest_speed)
        step_inverse_mass_[i] = 0;
      else if (with_normals)
        step_held_normal_[i] = (*held_normal_)[i];
    }
  u_start_ = u_;
  changed_.assign(n, 1);

  // 1. Repulsions: pairs within the thickness at the start stop approaching and are pushed a
  // share of the way back to it (a few Gauss-Seidel sweeps, as the pairs share nodes). A node
  // the solve held against the cloth in this step and that ends it at rest is not moved away
  // from the face it rests on by a pair whose other side cannot move (apply): the solve keeps
  // it at the thickness, and that pair's impulse (a still vertex of the layer beneath under
  // one of its faces) would only throw it off the layer, to fall back and be thrown again
  // (layers at rest jittered). Between two layers that move, the repulsions carry the upper
  // one's weight to the lower (the solve's holds act on one side only) and act in full.
  const bool held_in_solve = static_cast<long>(detected_x_.size()) == x0.size() && detected_x_ == x0 &&
                             closest_pair_.size() == static_cast<size_t>(n);
  resting_normal_.assign(n, Vec3::Zero());
  if (held_in_solve)
    for (int i = 0; i < n; ++i)
      if (closest_pair_[i] >= 0 && step_inverse_mass_[i] > 0 && node(u_, i).norm() <= tunables_.held_rest_speed)
        resting_normal_[i] = hold_normal_[i];
  find_proximities(x0);
  for (int sweep = 0; sweep < 3; ++sweep) {
    long applied = 0;
    for (const Stencil& s : pairs_)
      if (s.gap < s.distance && apply(s, (s.distance - s.gap) / std::max(tunables_.self_repulsion_time, dt), true, true)) ++applied;
    stats_.repulsions += applied;
    if (applied == 0) break;
  }
  resting_normal_.assign(n, Vec3::Zero());

  // 2. Continuous collisions: impulses on the pairs found, until a pass finds none. Each pair
  // is to end the step at twice its collision distance along the normal, or keep approaching
  // no faster than before. These impulses are frictionless: they act on the step's mean
  // velocity, which under BDF-2 carries the last step's displacement, and stopping its
  // tangential part along with the collision pumped energy into layers resting on each other.
  // Friction between layers comes with the repulsions, on every pair within the thickness.
  std::fill(changed_.begin(), changed_.end(), 1);
  bool clear = false;
  for (int pass = 0; pass < tunables_.self_passes && !clear; ++pass) {
    clear = find_collisions(x0, dt, false) == 0;
    for (const Stencil& s : pairs_) {
      if (apply(s, (2 * s.distance - s.gap) / dt, false, false)) {
        ++stats_.collision_impulses;
      } else {
        for (int i : s.node) changed_[i] = 1;  // found but not changed: look again
      }
    }
  }

  // 3. Impact zones: the nodes of the pairs still found are merged into zones moving rigidly,
  // and zones grow by what is found next; past the rigid rounds they are stopped instead, which
  // always ends (at worst every node of the cloth stands still) and marks the step invalid.
  bool stopped = false;
  if (!clear) {
    parent_.resize(n);
    std::iota(parent_.begin(), parent_.end(), 0);
    zone_stopped_.assign(n, 0);
    zone_dirty_.assign(n, 0);
    zone_members_.resize(n);
    clear = find_collisions(x0, dt, true) == 0;
    for (int round = 0; !clear; ++round) {
      for (const Stencil& s : pairs_)
        for (int k = 1; k < 4; ++k) merge(s.node[0], s.node[k]);
      stopped = stopped || round >= tunables_.self_zone_rounds;
      rigidify_zones(x0, dt, round >= tunables_.self_zone_rounds);
      clear = find_collisions(x0, dt, true) == 0;
    }
    std::vector<int> size(n, 0);
    for (int i = 0; i < n; ++i) ++size[zone_of(i)];
    for (int i = 0; i < n; ++i)
      if (size[i] > 1) {
        ++stats_.impact_zones;
        stats_.zone_nodes += size[i];
      }
    if (stopped) {
      ++stats_.failed_steps;
      report.ok = false;
    }
  }

  // The step's end on the nodes whose mean velocity changed; v1 changes as u did.
  for (int i = 0; i < n; ++i) {
    const Vec3 du = node(u_, i) - node(u_start_, i);
    if (du == Vec3::Zero()) continue;
    node(x1, i) = node(x0, i) + dt * node(u_, i);
    const Vec3 v_old = node(v1, i);
    node(v1, i) += du;
    report.work += 0.5 * (inverse_mass_[i] > 0 ? 1 / inverse_mass_[i] : 0.0) *
                   (node(v1, i).squaredNorm() - v_old.squaredNorm());
    ++report.fail_safe_moves;
  }
  stats_.seconds += seconds_since(start);
}

}  // namespace weft
