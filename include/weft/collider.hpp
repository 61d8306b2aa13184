#pragma once
// Collider descriptions of a scene (docs/scene-format.md, `colliders`): analytic shapes and
// triangle meshes, static or moved rigidly, and the skinned walking body.
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "weft/types.hpp"

namespace weft {

/// A rigid motion: world = rotation(t) * (shape as described) + translation(t), the identity
/// at t = 0 for a constant velocity.
struct RigidMotion {
  enum class Kind { kStatic, kVelocity, kKeyframes };
  Kind kind = Kind::kStatic;
  Vec3 linear_velocity = Vec3::Zero();   ///< m/s (kVelocity)
  Vec3 angular_velocity = Vec3::Zero();  ///< rad/s about `centre` (kVelocity)
  Vec3 centre = Vec3::Zero();            ///< the point the rotation turns about, at t = 0
  /// kKeyframes: the transform at increasing times (translation, then rotation about the
  /// origin by X, then Y, then Z degrees applied first); linear between keys (rotations by
  /// spherical interpolation), held before the first and after the last.
  struct Key {
    double time = 0;
    Vec3 translation = Vec3::Zero();
    Vec3 rotation_deg = Vec3::Zero();
  };
  std::vector<Key> keys;

  /// The transform at time t (s).
  Eigen::Isometry3d at(double t) const;
};

enum class ColliderShape { kPlane, kSphere, kCapsule, kBox, kMesh, kBody };

struct ColliderSpec {
  ColliderShape shape = ColliderShape::kPlane;
  std::string name;          ///< "colliders[k] (sphere)", for messages and summaries
  double thickness = 0.002;  ///< m: the cloth is kept this far from the surface
  double friction = 0.3;     ///< Coulomb coefficient
  // Shapes, in world coordinates at t = 0.
  Vec3 point = Vec3::Zero();          ///< plane: a point on it
  Vec3 normal = Vec3::UnitY();        ///< plane: unit normal, the free side
  Vec3 centre = Vec3::Zero();         ///< sphere, box
  double radius = 0;                  ///< sphere, capsule
  Vec3 end_a = Vec3::Zero(), end_b = Vec3::Zero();  ///< capsule: the axis' ends
  Vec3 half_extents = Vec3::Zero();   ///< box
  /// box: radius of its rounded edges and corners (m, 0: sharp), below the smallest half extent
  double edge_radius = 0;
  Vec3 rotation_deg = Vec3::Zero();   ///< box and mesh: X, then Y, then Z
  std::string obj_path;               ///< mesh: OBJ file (absolute, resolved against the scene)
  double scale = 1.0;                 ///< mesh: metres per OBJ unit
  Vec3 translation = Vec3::Zero();    ///< mesh: placement after scale and rotation
  /// mesh: a closed surface (inside and outside told apart by its outward normals); an open
  /// one keeps each cloth vertex on the side it started.
  bool closed = true;
  RigidMotion motion;
  int body = -1;                      ///< kBody: index into Scene::bodies
};

/// How the body's skin follows its bones (docs/body.md): linear blend or dual quaternions.
enum class Skinning { kLinearBlend, kDualQuaternion };
/// "lbs" or "dqs"; throws InputError naming `where` otherwise.
Skinning parse_skinning(const std::string& name, const std::string& where);

/// The body as a scene collider: {"type": "body", "motion": FILE, "speed": 0.75,
/// "skinning": "lbs"|"dqs", "start_time": 0}; WalkingBody (weft/body.hpp) is the mannequin it
/// describes.
struct BodyColliderSpec {
  std::string motion_file;    ///< "" for the shipped walk (data/motion/35_01.bvh)
  double speed = 0.75;        ///< playback speed scale
  std::string skinning = "lbs";
  double start_time = 0.0;    ///< seconds into the motion at scene time 0
  /// Scene seconds the body stands in its bind pose (the T-pose) before it moves, and the
  /// seconds over which it then blends into the motion's first pose; the motion starts after both.
  double bind_pose_hold = 0.0;
  double blend = 0.0;
  /// AnimationOptions::arm_spread_rad (weft/body.hpp), given in the scene in degrees ("arm_spread_deg").
  double arm_spread_deg = 0.0;
};

/// Validates keys and types; errors name `where` and the key. "type" may be present ("body").
/// A relative "motion" path is taken relative to base_dir (the scene file's folder).
BodyColliderSpec parse_body_collider(const nlohmann::json& j, const std::string& where,
                                     const std::string& base_dir = ".");

/// Rotation by X, then Y, then Z degrees (as scenes give placements).
Mat3 rotation_from_degrees(const Vec3& deg);
/// Angles (X, Y, Z degrees) of a rotation matrix: rotation_from_degrees of the result is R.
Vec3 degrees_from_rotation(const Mat3& R);

}  // namespace weft
