#pragma once
// What the integrators need from contact handling (docs/collisions.md): per-node contact
// constraints for the linear solve, and a fail-safe that corrects the end of a step. The
// integrators know nothing about colliders; collision/ provides the handler.
#include <vector>

#include "weft/types.hpp"

namespace weft {

/// A node held against a surface over one step: the node moves freely in the tangent plane
/// while its displacement along `normal` is prescribed, and friction acts against its sliding
/// relative to the surface.
struct NodeContact {
  int node = 0;
  Vec3 normal = Vec3::UnitY();         ///< unit, from the surface towards the node
  double normal_displacement = 0;      ///< the node's prescribed dx . normal over the step (m)
  Vec3 surface_velocity = Vec3::Zero();///< velocity of the surface point it touches (m/s)
  double friction = 0;                 ///< Coulomb coefficient
  /// The node is inside the surface itself (not only within the thickness): held even when
  /// the constraint pulled at the previous step.
  bool penetrating = false;
  /// A node moved by a prescribed motion (a clamp): its whole displacement over the step is
  /// `displacement` and it leaves the step at `surface_velocity`; never let go, no friction.
  bool kinematic = false;
  Vec3 displacement = Vec3::Zero();    ///< kinematic: the node's prescribed dx over the step (m)
  /// A second surface the node is held against (a node between two layers, or in the crease
  /// of a fold): unit and orthogonal to `normal`, or zero for none. The node's displacement
  /// along it is prescribed as well (normal_displacement2), so the node moves freely only
  /// along the direction orthogonal to both; a second direction that pulls is let go alone.
  Vec3 normal2 = Vec3::Zero();
  double normal_displacement2 = 0;     ///< the node's prescribed dx . normal2 over the step (m)
  /// Held against a collider that never moves (no rigid motion, not a body): cloth lying on
  /// this node at rest is held against it in the solve (collision/self_contact.hpp).
  bool still_surface = false;
  bool has_normal2() const { return normal2.squaredNorm() > 0; }
};

/// Per-step figures of contact handling (accumulated in StepStatistics).
struct ContactReport {
  long fail_safe_moves = 0;   ///< nodes the fail-safe moved after the solve
  double work = 0;            ///< work the fail-safe's changes did on the cloth (J)
  bool ok = true;             ///< false: the step could not be made valid (retry it smaller)
  /// In: the round of the fail-safes within the step (0: the first). Where several handlers
  /// correct the step, each later round gives the first handler the positions it left the
  /// nodes at in its last call (`left`), and it corrects only what the others undid since.
  int round = 0;
  const VecX* left = nullptr;
};

class ContactHandler {
 public:
  virtual ~ContactHandler() = default;
  /// The contacts of the step from (x, v) at time t to t + dt, at most one per node.
  virtual void detect(const VecX& x, const VecX& v, double t, double dt, std::vector<NodeContact>& out) = 0;
  /// Nodes not `held` that would end the step (from x0 at time t to x1 at t + dt) within a
  /// collider's thickness, appended to `out` as contacts whose prescribed displacement puts
  /// them at the thickness.
  virtual void detect_end(const VecX& x0, const VecX& x1, double t, double dt, const std::vector<char>& held,
                          std::vector<NodeContact>& out) = 0;
  /// After the step from x0 (time t) to x1, v1 (time t + dt): moves nodes that ended inside a
  /// collider's thickness (or tangled with the cloth) back to valid positions, adjusting v1.
  virtual void finish_step(const VecX& x0, VecX& x1, VecX& v1, double t, double dt, ContactReport& report) = 0;
  /// True for a handler whose finish_step puts vertices where a prescribed motion wants them
  /// (clamps): it runs after the fail-safes, and its work is done on the cloth, not a
  /// correction's.
  virtual bool prescribes_motion() const { return false; }
};

}  // namespace weft
