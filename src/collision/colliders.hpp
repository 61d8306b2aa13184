#pragma once
// Colliders at run time (docs/collisions.md): each answers the contact response's one question,
// the closest point of its surface to a point, with the outward normal there and how far that
// surface point moves over the step; and draws its surface for the output frames.
#include <functional>
#include <memory>
#include <vector>

#include "integrate/contact.hpp"
#include "weft/collider.hpp"

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
  /// Prepares the queries of the step from t0 to t1.
  virtual void prepare(double t0, double t1) = 0;
  /// The surface point closest to p at the step's start (end: at its end); false when p is
  /// farther than `reach` outside the surface as it is then and as it moves over the step (a
  /// collider may also answer farther points). `node` identifies the querying cloth node (open meshes
  /// keep each node's side).
  virtual bool closest(const Vec3& p, double reach, bool end, int node, SurfacePoint& out) const = 0;
  /// How far any point of the surface moves over the prepared step (m); 0 for a collider
  /// whose queries answer at any distance.
  virtual double step_motion() const { return 0; }
  /// The surface at time t as triangles (output frames, checks).
  virtual void surface(double t, Points& positions, Triangles& triangles) const = 0;

 private:
  ColliderSpec spec_;
};

/// A plane, sphere, capsule or box; throws std::invalid_argument for another shape.
std::unique_ptr<Collider> make_analytic_collider(const ColliderSpec& spec);

/// The positions of a triangle mesh's vertices at time t (#V by 3).
using SurfaceMotion = std::function<void(double t, Points& positions)>;
/// A triangle mesh whose vertices move by `motion` (an OBJ moved rigidly, a skinned body).
/// `closed`: inside and outside are told apart by the outward normals (the triangles wound
/// counter-clockwise seen from outside); open: each cloth node keeps the side it is on.
std::unique_ptr<Collider> make_mesh_collider(const ColliderSpec& spec, const Triangles& triangles,
                                             SurfaceMotion motion, bool closed);

/// Contact handling against colliders (integrate/contact.hpp) for a cloth of the given node
/// masses and pins.
class ColliderContacts : public ContactHandler {
 public:
  ColliderContacts(std::vector<Collider*> colliders, const VecX& mass, const std::vector<char>& fixed);
  void detect(const VecX& x, const VecX& v, double t, double dt, std::vector<NodeContact>& out) override;
  void detect_end(const VecX& x0, const VecX& x1, double t, double dt, const std::vector<char>& held,
                  std::vector<NodeContact>& out) override;
  void finish_step(const VecX& x0, VecX& x1, VecX& v1, double t, double dt, ContactReport& report) override;
  /// Per node: held against a collider or moved by the fail-safe in the step last detected
  /// (cloth-cloth contact treats such nodes as immovable, so it cannot push them into a collider).
  const std::vector<char>& touching() const { return touching_; }

 private:
  std::vector<Collider*> colliders_;
  const VecX& mass_;
  const std::vector<char>& fixed_;
  std::vector<double> best_gap_;  ///< per node: the gap of its contact so far
  std::vector<int> slot_;         ///< per node: its contact's index in the output, or -1
  std::vector<char> touching_;    ///< touching()
  double prepared_t_ = -1, prepared_dt_ = -1;  ///< the step the colliders are prepared for
};

}  // namespace weft
