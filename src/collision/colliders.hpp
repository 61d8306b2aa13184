#pragma once
// Colliders at run time (docs/collisions.md): each answers the contact response's one question,
// the closest point of its surface to a point, with the outward normal there and how far that
// surface point moves over the step; and draws its surface for the output frames.
#include <functional>
#include <memory>
#include <vector>

#include "collision/aabb_tree.hpp"
#include "integrate/contact.hpp"
#include "weft/collider.hpp"
#include "weft/settings.hpp"

namespace weft {

struct SurfacePoint {
  double distance = 0;                ///< signed: positive on the free side (m)
  Vec3 normal = Vec3::UnitY();        ///< unit, towards the free side
  Vec3 point = Vec3::Zero();          ///< the closest surface point
  Vec3 displacement = Vec3::Zero();   ///< that point's displacement over the step (m)
};

class Collider {
 public:
  explicit Collider(ColliderSpec spec) : spec_(std::move(spec)) {}
  virtual ~Collider() = default;
  const ColliderSpec& spec() const { return spec_; }
  /// Replaces the rigid motion for the steps prepared from now on (Simulation::move_collider).
  void set_motion(const RigidMotion& motion) { spec_.motion = motion; }
  /// Prepares the queries of the step from t0 to t1.
  virtual void prepare(double t0, double t1) = 0;
  /// The surface point closest to p at the step's start (end: at its end); false when p is
  /// farther than `reach` outside the surface as it is then and as it moves over the step (a
  /// collider may also answer farther points). `node` identifies the querying cloth node (open meshes
  /// keep each node's side). Queries for different nodes may run on several threads at once,
  /// for nodes below the count given to reserve_nodes.
  virtual bool closest(const Vec3& p, double reach, bool end, int node, SurfacePoint& out) const = 0;
  /// Makes room for what closest keeps per node, for nodes 0 to n - 1.
  virtual void reserve_nodes(int /*n*/) {}
  /// A lower bound (m) on the distance from p to the surface at the prepared step's start (end:
  /// its end), from what earlier queries of cloth node `node` measured; 0 when none is known.
  /// Holds for any p, not only the node's position.
  virtual double distance_bound(const Vec3& /*p*/, int /*node*/, bool /*end*/) const { return 0; }
  /// How far any point of the surface moves over the prepared step (m); 0 for a collider
  /// whose queries answer at any distance.
  virtual double step_motion() const { return 0; }
  /// Whether closest_to_triangle answers (a round collider or a box).
  virtual bool answers_triangles() const { return false; }
  /// For a round collider (sphere, capsule) or a box: the surface point nearest the triangle (a, b, c)
  /// at the step's end, with the triangle's point nearest it (its barycentric weights in
  /// `weights`); false for other colliders.
  virtual bool closest_to_triangle(const Vec3& /*a*/, const Vec3& /*b*/, const Vec3& /*c*/, SurfacePoint& /*out*/,
                                   Vec3& /*weights*/) const {
    return false;
  }
  /// A mesh collider's surface at the prepared step's end: its tree (refitted there), vertex
  /// positions and unit outward vertex normals (angle-weighted); null (zero) for analytic
  /// colliders.
  virtual const AabbTree* end_tree() const { return nullptr; }
  /// A mesh collider's tree refitted to its triangles' sweep over the prepared step (each box
  /// holds the triangle at the step's start and end); null for analytic colliders. Not for
  /// several threads at once.
  virtual const AabbTree* swept_tree() const { return nullptr; }
  virtual const Points* end_vertices() const { return nullptr; }
  virtual const Points* start_vertices() const { return nullptr; }
  virtual Vec3 end_vertex_normal(int /*v*/) const { return Vec3::Zero(); }
  virtual const std::vector<std::array<int, 3>>* triangle_list() const { return nullptr; }
  /// The surface at time t as triangles (output frames, checks).
  virtual void surface(double t, Points& positions, Triangles& triangles) const = 0;

 private:
  ColliderSpec spec_;
};

/// Whether c never moves: no rigid motion, and not a body (a skinned body moves even where it
/// stands still for a while).
inline bool never_moves(const Collider& c) {
  return c.spec().motion.kind == RigidMotion::Kind::kStatic && c.spec().shape != ColliderShape::kBody;
}

/// A plane, sphere, capsule or box; throws std::invalid_argument for another shape.
std::unique_ptr<Collider> make_analytic_collider(const ColliderSpec& spec);

/// The positions of a triangle mesh's vertices at time t (#V by 3).
using SurfaceMotion = std::function<void(double t, Points& positions)>;
/// A triangle mesh whose vertices move by `motion` (an OBJ moved rigidly, a skinned body).
/// `closed`: inside and outside are told apart by the outward normals (the triangles wound
/// counter-clockwise seen from outside); open: each cloth node keeps the side it is on.
std::unique_ptr<Collider> make_mesh_collider(const ColliderSpec& spec, const Triangles& triangles,
                                             SurfaceMotion motion, bool closed);

/// The distance (in thicknesses) at which the colliders' fail-safe stops a cloth edge short of
/// a mesh collider's edge, and the height (in thicknesses, halved in the fail-safe's later
/// rounds) it then lifts the edge to (docs/collisions.md, "Fail-safe"; smaller heights measured
/// and not kept: docs/notes/collider-fail-safe.md).
constexpr double kEdgeCrossingGap = 0.1;
constexpr double kEdgeLiftHeight = 0.5;

/// Contact handling against colliders (integrate/contact.hpp) for a cloth of the given node
/// masses and pins.
class ColliderContacts : public ContactHandler {
 public:
  /// `triangles`: the cloth's, for keeping mesh colliders' vertices out of its faces.
  ColliderContacts(std::vector<Collider*> colliders, const VecX& mass, const std::vector<char>& scene_held,
                   std::vector<std::array<int, 3>> triangles);
  void detect(const VecX& x, const VecX& v, double t, double dt, std::vector<NodeContact>& out) override;
  void detect_end(const VecX& x0, const VecX& x1, double t, double dt, const std::vector<char>& held,
                  std::vector<NodeContact>& out) override;
  void finish_step(const VecX& x0, VecX& x1, VecX& v1, double t, double dt, ContactReport& report) override;
  /// Per node: held against a collider or moved by the fail-safe in the step last detected
  /// (cloth-cloth contact treats such nodes as immovable, so it cannot push them into a collider).
  const std::vector<char>& touching() const { return touching_; }
  /// Per node: the normal of the collider surface it is held against or was moved off along
  /// (zero where touching() is not set).
  const std::vector<Vec3>& touching_normals() const { return touching_normal_; }
  /// The tunables it reads (ContactSettings::hold_margin); the defaults until set.
  void set_tunables(const ContactSettings& s) { tunables_ = s; }
  const ContactSettings& tunables() const { return tunables_; }

 private:
  ContactSettings tunables_;
  std::vector<Collider*> colliders_;
  const VecX& mass_;
  std::vector<char> scene_held_;  ///< nodes the scene holds (pinned or clamped): contacts leave them alone
  std::vector<double> best_gap_;  ///< per node: the gap of its contact so far
  std::vector<int> slot_;         ///< per node: its contact's index in the output, or -1
  std::vector<char> touching_;    ///< touching()
  std::vector<Vec3> touching_normal_;  ///< touching_normals()
  /// Per node, the last query_nodes: whether it found a surface point, and the point.
  std::vector<char> found_;
  /// Per node, detect's last collider: its predicted distance at the step's end (inf: none).
  std::vector<double> node_gap_;
  std::vector<SurfacePoint> surface_;
  /// Runs `query(i, surface_[i])` for the free nodes i on every thread, its result in found_[i].
  template <class Query>
  void query_nodes(const Query& query);
  double prepared_t_ = -1, prepared_dt_ = -1;  ///< the step the colliders are prepared for
  /// finish_step's round: the nodes it looks at in a later round (empty: all free nodes), and
  /// the fractions of the thickness below which a node or face is moved (`trigger_`) and to
  /// which (`target_`).
  std::vector<char> moved_;
  double trigger_ = 0.5, target_ = 1.0;
  bool looks_at(int i) const { return !scene_held_[i] && (moved_.empty() || moved_[i]); }
  bool looks_at(const std::array<int, 3>& t) const { return looks_at(t[0]) || looks_at(t[1]) || looks_at(t[2]); }
  /// Moves cloth faces that a mesh collider's vertex (a nose, a finger) came within the
  /// thickness of, or poked through, back out along the poke's normal (FacePoke).
  void push_faces_off_vertices(const Collider& c, VecX& x1, VecX& v1, double dt, ContactReport& report);
  /// A cloth face above a mesh collider's vertex: the face's closest point to the vertex lies
  /// inside the face or on one of its edges (right over the vertex), `height` above the vertex
  /// along `normal`: the vertex's normal, or, for a vertex right under the face's inside
  /// where the face's vertices lie on another side of the collider than that normal says (a
  /// nose's tip finer than the face), the face's own normal turned to the side they lie on.
  struct FacePoke {
    int face = 0, vertex = 0;
    Vec3 weights = Vec3::Zero();
    double height = 0;
    Vec3 normal = Vec3::Zero();
    bool on_edge = false;  ///< the closest point lies on one of the face's edges
  };
  /// The pokes of collider c's vertices at the step's end into the cloth at x lower than
  /// `limit`, at most kMaxPokeDepth behind the face, the face on the vertex's side of the
  /// collider (its own vertices' nearest surface normals facing the same way as the vertex's
  /// normal, or else leaning together to one side of the face, which the vertex faces).
  void face_pokes(const Collider& c, const VecX& x, double limit, std::vector<FacePoke>& out);
  /// Whether face t at x is shown by c's distance bounds to give face_pokes nothing.
  bool clear_of(const Collider& c, const VecX& x, const std::array<int, 3>& t, double thickness, double limit) const;
  std::vector<FacePoke> pokes_;
  /// Holds the vertices of cloth faces that sag over collider c's vertices (step start).
  void hold_faces_over_vertices(const Collider& c, const VecX& x, double dt, std::vector<NodeContact>& out);
  VecX predicted_;                        ///< x + dt v at the step's start
  std::vector<double> face_held_height_;  ///< per node: the lowest poke holding it (inf: none)
  /// A candidate's geometry, measured both ways.
  struct PokeTest {
    FacePoke poke;                 ///< measured along the vertex's normal
    bool by_vertex_normal = false;  ///< its height is within the limits
    Vec3 face_normal = Vec3::Zero();
    double face_height = 0;        ///< the height along face_normal (either side)
    bool by_face_normal = false;   ///< under the face's inside, within the limits on one side
  };
  /// Per chunk of cloth faces in face_pokes: the candidates whose geometry qualifies (before
  /// the side check).
  std::vector<std::vector<PokeTest>> chunk_tests_;
  /// Keeps cloth edges from passing across mesh collider `c`'s edges over the step (a cloth
  /// edge over a ridge of the body, both its ends outside, neither's vertex in the other's
  /// face): continuous detection of each cloth edge near the collider against the collider's
  /// edges, both moving on straight lines from x0 to x1 and from the collider's start to its
  /// end; a pair that comes within kEdgeCrossingGap thicknesses has the cloth edge's point
  /// moved out along the pair's normal at that time to kEdgeLiftHeight thicknesses (half that
  /// in later rounds), its normal velocity no slower than the collider's edge.
  void keep_edges_off_edges(size_t collider, const Collider& c, const VecX& x0, VecX& x1, VecX& v1, double dt,
                            ContactReport& report);
  std::vector<std::array<int, 2>> cloth_edges_;  ///< each edge of the cloth's triangles once
  /// Per collider with a triangle list, per triangle: a bit per edge k it owns (each edge of
  /// the collider's surface owned by one of its triangles).
  std::vector<std::vector<unsigned char>> owned_edges_;
  std::vector<std::array<int, 2>> edge_candidates_;  ///< keep_edges_off_edges' scratch
  /// Puts node i's contact into `out` (replacing the one it has there) and marks it touching.
  void place(std::vector<NodeContact>& out, int i, const Vec3& normal, double displacement,
             const Vec3& surface_velocity, const Collider& c);
  /// Holds the vertices of cloth faces that dip between them towards a round collider (or a
  /// box's rounded edge) within the hold margin at their predicted end (step start).
  void hold_faces_off_round(const Collider& c, const VecX& v, double dt, std::vector<NodeContact>& out);
  /// Lifts cloth faces that sag between their vertices to within half the thickness of a
  /// round collider (sphere, capsule) back to the thickness.
  void lift_faces_off_round(const Collider& c, VecX& x1, VecX& v1, ContactReport& report);
  /// Moves face t's point with barycentric `weights` by `lift` along n (its free vertices in
  /// proportion to their weights), no vertex then moving towards -n.
  /// `surface_speed`: the least velocity along n a moved vertex keeps (the collider's there).
  void lift_face(const std::array<int, 3>& t, const Vec3& weights, double lift, const Vec3& n, VecX& x1, VecX& v1,
                 ContactReport& report, double surface_speed = 0);
  std::vector<std::array<int, 3>> triangles_;
  std::vector<char> side_normal_known_;  ///< per node, this step: side_normal_ computed
  std::vector<Vec3> side_normal_;        ///< the collider's normal nearest the node (0: none near)
  std::vector<int> side_nodes_;          ///< face_pokes on several threads: the nodes whose side normals it finds first
};

}  // namespace weft
