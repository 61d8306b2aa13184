#pragma once
// Cloth-cloth contact (docs/collisions.md, "Self-collision"): vertex-face and edge-edge holds
// in the solve for layers already within the thickness, then, after the solve, a fail-safe on
// the step's displacement in the spirit of Bridson, Fedkiw and Anderson 2002 (repulsions,
// continuous-collision impulses, rigid impact zones) that ends every accepted step with no
// cloth-cloth contact found by continuous detection along the straight trajectories.
#include <array>
#include <cstddef>
#include <vector>

#include "collision/aabb_tree.hpp"
#include "collision/self_culling.hpp"
#include "integrate/contact.hpp"
#include "weft/settings.hpp"
#include "weft/statistics.hpp"

namespace weft {

// The defaults of the tunables SelfContacts reads (ContactSettings, scene key `contacts`),
// under the names the tests' expectations use.
constexpr double kHeldRestSpeed = ContactSettings{}.held_rest_speed;
constexpr double kRepulsionTime = ContactSettings{}.self_repulsion_time;
constexpr double kHoldReach = ContactSettings{}.self_hold_reach;
constexpr double kHoldReachSpeed = ContactSettings{}.self_hold_reach_speed;
/// The most an impulse may change a node's velocity, as a multiple of the change of the
/// pair's relative velocity it makes (see SelfContacts::apply).
constexpr double kMaxVelocityChangeRatio = 2;
/// The distance continuous detection keeps primitives apart, as a fraction of the thickness.
constexpr double kCollisionDistanceFraction = 0.1;
/// The most the fail-safe's impulses may move a node held against a collider into it in one
/// step, as a fraction of the cloth's thickness (see SelfContacts::set_held_nodes).
constexpr double kHeldInwardRoom = 0.25;

/// An end of an edge in an edge-edge pair within the thickness is held in the solve when it
/// carries at least this share of the edge's closest point (1 - s or s).
constexpr double kEdgeHoldWeight = 0.25;
/// Holds of pairs beyond the thickness have friction out to this multiple of it (a vertex the
/// solve put at the thickness ends a hair outside it as often as inside), none beyond.
constexpr double kFrictionReach = 1.1;
/// A node the cloth holds is held against a second pair where that pair's normal and its
/// first's differ by an angle whose sine is at least this (30 degrees).
constexpr double kSecondHoldSine = 0.5;
/// A vertex a collider holds is held against a cloth face the collider also holds when the
/// pair's normal (from the face to the vertex) and the collider's agree by this cosine: the
/// face is the layer between the vertex and the collider.
constexpr double kLayerNormalAgreement = 0.5;

/// Counts of what the fail-safe did (accumulated over the steps it ran; checkpoints keep them),
/// each declared once: X(kind, field, key, meaning), kind kCount (a long) or kSeconds (a double),
/// key its name in summary.json's contacts.self. A checkpoint holds them in this order (the
/// counts first). A new statistic is a line here.
#define WEFT_SELF_CONTACT_STATISTICS(X)                                                              \
  X(kCount, repulsions, "repulsions", "impulses on pairs within the thickness at the step's start")  \
  X(kCount, collision_impulses, "collision_impulses",                                                \
    "impulses on pairs continuous detection found over the step")                                    \
  X(kCount, impact_zones, "impact_zones", "rigid impact zones formed (counted in the step they end in)") \
  X(kCount, zone_nodes, "impact_zone_nodes", "nodes in those zones")                                 \
  X(kCount, failed_steps, "failed_steps",                                                            \
    "steps whose zones had to be stopped, reported invalid (taken again at half the size)")          \
  X(kSeconds, seconds, "seconds", "time in the fail-safe")

struct SelfContactStatistics {
#define WEFT_SELF_CONTACT_FIELD(kind, field, key, meaning) WEFT_STATISTIC_TYPE_##kind field = 0;
  WEFT_SELF_CONTACT_STATISTICS(WEFT_SELF_CONTACT_FIELD)
#undef WEFT_SELF_CONTACT_FIELD
};

/// One line of WEFT_SELF_CONTACT_STATISTICS, for code that visits each (the checkpoint,
/// summary.json).
struct SelfContactStatistic {
  const char* field;
  const char* key;                         ///< the key in summary.json's contacts.self
  long SelfContactStatistics::*count;      ///< the field of a kCount (else null)
  double SelfContactStatistics::*value;    ///< the field of a kSeconds (else null)
};

namespace self_contact_detail {
constexpr SelfContactStatistic entry(const char* field, const char* key, long SelfContactStatistics::*count) {
  return {field, key, count, nullptr};
}
constexpr SelfContactStatistic entry(const char* field, const char* key, double SelfContactStatistics::*value) {
  return {field, key, nullptr, value};
}
}  // namespace self_contact_detail

/// WEFT_SELF_CONTACT_STATISTICS as a table, in its order.
inline constexpr SelfContactStatistic kSelfContactStatistics[] = {
#define WEFT_SELF_CONTACT_ENTRY(kind, field, key, meaning) \
  self_contact_detail::entry(#field, key, &SelfContactStatistics::field),
    WEFT_SELF_CONTACT_STATISTICS(WEFT_SELF_CONTACT_ENTRY)
#undef WEFT_SELF_CONTACT_ENTRY
};

/// Cloth-cloth contact handling (integrate/contact.hpp) for one cloth mesh: vertex-face and
/// edge-edge holds in the solve (detect), then the fail-safe after it (finish_step). It keeps no
/// state between steps but its statistics.
class SelfContacts : public ContactHandler {
 public:
  /// `triangles` (#F vertex triples), `rest_positions` (3n, m: they shape the bounding-volume
  /// tree), `mass` (n, kg) and `scene_held` (n, the nodes the scene holds, pinned or clamped,
  /// which do not move and count as infinitely heavy); `thickness` (m, > 0): the separation
  /// the repulsions keep; `friction`: the Coulomb coefficient between layers. Throws
  /// std::invalid_argument for sizes that do not fit or a thickness that is not positive.
  SelfContacts(const std::vector<std::array<int, 3>>& triangles, const VecX& rest_positions, const VecX& mass,
               const std::vector<char>& scene_held, double thickness, double friction);

  /// Vertices that stand for one point of the cloth (the two sides of a seam being sewn):
  /// group[v] is the same for each, and a vertex meets no face and an edge no edge holding a
  /// vertex of its own group, as if they were welded. Without it every vertex is its own.
  void set_vertex_groups(std::vector<int> group);

  /// Nodes within the thickness of the cloth at x (and held by no handler before this one in
  /// `out`) held in the solve against their nearest pair's other side as against a surface: a
  /// vertex within the thickness of a face, and the ends of two edges within the thickness of
  /// each other (each end carrying at least kEdgeHoldWeight of its edge's closest point, and
  /// no node of the pair held by a collider), each against the other edge. Where a collider
  /// that never moves holds one side of a pair at rest (every node of it, none of the other
  /// side; NodeContact::still_surface), the other side's nodes carrying at least
  /// kEdgeHoldWeight are held against it instead: a layer lying on cloth that rests on a box
  /// or a floor. No approach along the pair's normal (a surface drawing back is followed at its velocity at the start), the
  /// missing thickness restored over kRepulsionTime, and the layers' friction. A node is held
  /// against a second pair as well (NodeContact::normal2) where that pair's normal leans from
  /// the first's by more than kSecondHoldSine and no collider holds a node of it. The
  /// solve then sees the layers it would otherwise drive into each other: a correction after
  /// the solve alone undoes part of the solve's motion, and under backward Euler and BDF-2
  /// that fight pumped elastic energy into folded cloth until the run blew up.
  void detect(const VecX& x, const VecX& v, double t, double dt, std::vector<NodeContact>& out) override;
  void detect_end(const VecX&, const VecX&, double, double, const std::vector<char>&,
                  std::vector<NodeContact>&) override {}
  /// With u = (x1 - x0) / dt: repulsions on pairs within the thickness at x0, then impulses on
  /// the pairs continuous detection finds along x0 -> x0 + dt u, then rigid impact zones;
  /// x1 = x0 + dt u and v1 changed by the change of u on the nodes it changed. Reports
  /// ok = false when zones had to be stopped to clear the step.
  void finish_step(const VecX& x0, VecX& x1, VecX& v1, double t, double dt, ContactReport& report) override;

  /// Per-node flags (n entries, read at every step; null or another size: none) of nodes the
  /// handlers before this one hold against a collider in the step. Those moving slower than
  /// kHeldRestSpeed count as infinitely heavy, so that layers resting on cloth that rests on a
  /// collider do not drive it in step after step (the collider would push it back out, and the
  /// two would pump energy into the layers). Faster ones keep their mass: a node the collider's
  /// prediction carries onto the collider through cloth lying in between must not act as a
  /// moving wall on that cloth.
  ///
  /// `normals` (n entries, or null: none): the collider's normal at each held node, pointing
  /// out of it. The faster held nodes, which keep their mass, are then moved towards the
  /// collider by the impulses of one step by at most kHeldInwardRoom times the thickness: past
  /// that, an impulse's share that would push one further in is dropped (the collider takes
  /// it). Where the walking body drives the layer it holds into the layer outside, the
  /// repulsions would otherwise push the held layer back into the body by half their change.
  void set_held_nodes(const std::vector<char>* flags, const std::vector<Vec3>* normals = nullptr) {
    held_ = flags;
    held_normal_ = normals;
  }

  double thickness() const { return thickness_; }
  double friction() const { return friction_; }
  /// The tunables it reads (ContactSettings' held_rest_speed and self_*); the defaults until set.
  void set_tunables(const ContactSettings& s) { tunables_ = s; }
  const ContactSettings& tunables() const { return tunables_; }
  const SelfContactStatistics& statistics() const { return stats_; }
  void set_statistics(const SelfContactStatistics& s) { stats_ = s; }

  /// Whether the searches pass over regions of the cloth that cannot hold a pair
  /// (collision/self_culling.hpp); on by default. The pairs found are the same either way:
  /// the switch is for the tests that check so and for the benchmarks.
  /// Culling on or off; keep_regions: regions found kept for later searches while the cloth
  /// stays near a rigid motion of where they were found (self_culling.hpp).
  void set_culling(bool on, bool keep_regions = true) {
    culling_on_ = on;
    culling_.set_keeping(keep_regions);
  }
  const SelfCullingStatistics& culling_statistics() const { return culling_.statistics(); }

  /// A vertex-face or edge-edge pair: four nodes and their weights in the relative position
  /// (vertex-face: 1, -w_a, -w_b, -w_c; edge-edge: 1 - s, s, -(1 - t), -t), which sum to 0.
  struct Stencil {
    std::array<int, 4> node{};
    std::array<double, 4> weight{};
    Vec3 normal = Vec3::UnitZ();  ///< unit, from the second primitive towards the first
    double gap = 0;               ///< separation along the normal at the step's start (m)
    double distance = 0;          ///< the distance the pair is kept at (m)
    bool vertex_face = false;     ///< node[0] is a vertex, the others a face's
    /// The closest points (nearly) coincide: the normal is the face's or the edges' common
    /// one, turned against the relative velocity (it depends on u, not only on positions).
    bool touching = false;
  };

 private:
  /// Calls vertex_face(v, f, s) and edge_edge(e, e2, s) for the pairs of primitives sharing no
  /// node whose boxes (holding them at xa and xb, grown by `margin`; xa alone when xb is the
  /// same vector) overlap, the tree refitted the same way, and appends to pairs_ the stencils s of the calls that return
  /// true, in the tree's order; `only_changed`: only pairs with a node whose u changed since
  /// the last detection. The calls run on several threads (util/threads.hpp) and must only
  /// read shared state. They must return false for every pair that stays `reach` (m) apart or
  /// more along the straight motions from xa to xb: pairs inside regions that culling shows to
  /// hold none are not offered.
  template <class VertexFace, class EdgeEdge>
  void for_each_candidate(const VecX& xa, const VecX& xb, double margin, double reach, bool only_changed,
                          VertexFace&& vertex_face, EdgeEdge&& edge_edge);
  /// Pairs within the thickness at x0 into pairs_. detect and finish_step look at the same
  /// start positions in a step: the second call reuses the first's pairs (proximity_x_ and
  /// proximity_pairs_), only turning the normals of touching pairs to the current u.
  void find_proximities(const VecX& x0);
  /// Pairs that come within their collision distance along x0 -> x0 + dt u into pairs_ (with
  /// `skip_zones`, not those inside one impact zone); their number.
  size_t find_collisions(const VecX& x0, double dt, bool skip_zones);
  Vec3 relative_velocity(const Stencil& s) const;
  /// Changes u so the pair's relative normal velocity is at least `target`, with Coulomb
  /// friction on its tangential part when `with_friction`; true when it changed anything. With
  /// `lever_limit` (the repulsions), a pair one side of which cannot move while the other's
  /// movable nodes carry less than kEdgeHoldWeight of its point is left alone.
  bool apply(const Stencil& s, double target, bool with_friction, bool lever_limit);
  int zone_of(int i) const;
  void merge(int a, int b);
  /// Gives every zone that grew its rigid motion (or stops it: `stop`, a pinned node).
  void rigidify_zones(const VecX& x0, double dt, bool stop);

  /// Triangle pairs per chunk of for_each_candidate's parallel loop.
  static constexpr size_t kCandidateChunk = 64;
  std::vector<std::array<int, 2>> triangle_pairs_;  ///< for_each_candidate's owner pairs
  std::vector<std::vector<std::array<int, 2>>> triangle_pair_pieces_;  ///< collect_self_pairs's scratch
  std::vector<std::vector<Stencil>> chunk_pairs_;    ///< and what each chunk found

  std::vector<std::array<int, 3>> triangles_;
  std::vector<std::array<int, 2>> edges_;
  /// Up to three vertices or edges a triangle owns, stored in place (the candidate loops read
  /// them for every pair of triangles).
  struct Owned {
    std::array<int, 3> item{};
    int count = 0;
    const int* begin() const { return item.data(); }
    const int* end() const { return item.data() + count; }
  };
  std::vector<Owned> owned_vertices_, owned_edges_;  ///< per triangle
  VecX inverse_mass_;                        ///< 0 for pinned nodes
  const std::vector<char>* held_ = nullptr;
  const std::vector<Vec3>* held_normal_ = nullptr;
  std::vector<Vec3> step_held_normal_;  ///< per node this step: its collider's normal (0: free)
  std::vector<double> inward_budget_;   ///< per node this step: the inward speed still allowed
  std::vector<char> scene_held_;  ///< pinned or clamped nodes (held by the scene)
  std::vector<int> group_;  ///< set_vertex_groups; identity by default
  /// Whether triangle f holds v or a vertex of its group.
  bool holds(int f, int v) const;
  /// The groups of each triangle's vertices and of each edge's ends (from group_).
  std::vector<std::array<int, 3>> triangle_group_;
  std::vector<std::array<int, 2>> edge_group_;
  void set_primitive_groups();
  double thickness_, friction_;
  ContactSettings tunables_;
  AabbTree tree_;
  SelfContactStatistics stats_;
  SelfCulling culling_;
  bool culling_on_ = true;
  std::vector<char> culled_;  ///< per tree node: its own pairs passed over (this search)

  // Scratch of one step (rewritten by every call).
  VecX u_, u_start_, x_end_;
  VecX step_inverse_mass_;           ///< inverse_mass_, 0 for held nodes too
  std::vector<Box> vertex_box_, edge_box_;  ///< of the detection under way
  std::vector<char> changed_;        ///< per node: u changed since the last detection
  std::vector<Stencil> pairs_;
  VecX proximity_x_;                        ///< the positions of the last find_proximities
  VecX detected_x_;                         ///< the positions of the last detect (its holds: closest_pair_)
  std::vector<Vec3> hold_normal_;           ///< detect: per node, its hold's normal (0: not held)
  /// finish_step's repulsions: per node held in the solve and at rest, its hold's normal (the
  /// repulsions do not move it along it), else 0; empty outside the repulsions.
  std::vector<Vec3> resting_normal_;
  std::vector<Stencil> proximity_pairs_;    ///< and the pairs it found
  std::vector<int> parent_;          ///< impact zones: union-find over nodes
  std::vector<char> zone_stopped_;   ///< per zone root: stopped
  std::vector<char> zone_dirty_;     ///< per zone root: grew since its motion was set
  std::vector<std::vector<int>> zone_members_;
  std::vector<char> has_contact_;    ///< detect: per node, a contact in `out` already
  std::vector<int> contact_slot_;    ///< detect: per node, its contact's index in `out` (-1: none)
  /// Per node: its collider's hold replaced by a hold against the layer between (detect); the
  /// fail-safe then does not count it as held by the collider.
  std::vector<char> layered_;
  std::vector<int> closest_pair_;    ///< detect: per node, its closest pair or -1
  std::vector<char> closest_side_;   ///< detect: 0, the node is on the pair's first primitive; 1, the second
  std::vector<int> second_pair_;     ///< detect: per node, the pair of its second hold or -1
  std::vector<char> second_side_;    ///< detect: as closest_side_, for second_pair_
};

}  // namespace weft
