#pragma once
// The walking mannequin (docs/body.md): MakeHuman's CC0 base mesh, a CMU-named rig whose joints
// are computed from the mesh, a BVH motion retargeted onto it, and linear-blend or
// dual-quaternion skinning. Positions in metres, Y up, the body faces +Z; time in seconds.
#include <functional>
#include <iosfwd>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "weft/collider.hpp"
#include "weft/types.hpp"

namespace weft {

// ---------------------------------------------------------------------------------------------
// OBJ files

/// Vertices, faces (fan-triangulated) and, per `g` group, the vertices its faces use.
struct ObjMesh {
  Points positions;                              ///< #V by 3, in the file's units
  Triangles triangles;                           ///< #F by 3, 0-based
  std::vector<std::string> group_names;          ///< in file order
  std::vector<std::vector<int>> group_vertices;  ///< sorted, unique, per group
};

/// Reads vertices, faces (polygons split into triangles) and groups (io/obj_file.hpp); texture
/// and normal indices are ignored, faces before the first `g` line belong to no group. Throws
/// InputError naming the file and line for an unreadable or malformed file, a coordinate that
/// is not a finite number within 1e6, or a face index out of range.
ObjMesh read_obj(const std::string& path);

/// Writes positions and triangles as OBJ, atomically (temporary file, then rename).
void write_obj(const std::string& path, const Points& positions, const Triangles& triangles);

// ---------------------------------------------------------------------------------------------
// Rig and skinning weights

/// A rigid transform x -> rotation * x + translation.
struct BonePose {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Vec3 translation = Vec3::Zero();
  Vec3 apply(const Vec3& x) const { return rotation * x + translation; }
  /// (this * other)(x) = this(other(x)).
  BonePose operator*(const BonePose& other) const {
    return {rotation * other.rotation, rotation * other.translation + translation};
  }
};

/// Up to 4 bone influences per vertex (unused slots have weight 0 and bone 0).
struct SkinWeights {
  static constexpr int kInfluences = 4;
  Eigen::Matrix<int, Eigen::Dynamic, kInfluences, Eigen::RowMajor> bone;
  Eigen::Matrix<double, Eigen::Dynamic, kInfluences, Eigen::RowMajor> weight;  ///< rows sum to 1
};

struct Rig {
  std::vector<std::string> bone_names;
  std::vector<int> parent;  ///< -1 for the root; a parent always precedes its children
  std::vector<double> roll_rad;
  std::vector<Vec3> head_rest, tail_rest;  ///< joints of the A-posed rest mesh
  std::vector<Vec3> head_bind, tail_bind;  ///< joints in the bind pose (T-pose)
  /// Takes the rest (A-pose) mesh to the bind (T-pose) mesh, per bone.
  std::vector<BonePose> rest_to_bind;

  int bone_count() const { return static_cast<int>(bone_names.size()); }
  /// Index of a bone by name, or -1.
  int find(const std::string& name) const;
};

/// Joint positions from the mesh (MakeHuman rig strategies): CUBE = mean of a `joint-*` cube
/// group's vertices (cubes in decimetres, as in MakeHuman's base.obj); MEAN = mean of listed
/// body vertices. `body_m` is the body mesh in metres. Sets rest joints; bind = rest.
Rig build_rig(const nlohmann::json& rig_json, const ObjMesh& joint_cubes_dm, const Points& body_m,
              const std::string& where);

/// Poses the rig with per-bone Euler XYZ angles (radians) given in each bone's local frame as
/// Blender defines it (Y along the bone, rolled by roll_rad; Blender axes are (x, -z, y) of
/// ours). Sets head_bind, tail_bind and rest_to_bind. Bones not named keep their parent's pose.
void apply_bind_pose(Rig& rig, const nlohmann::json& bone_rotations, const std::string& where);
/// apply_bind_pose with the "bone_rotations" of a bind-pose file's JSON (`where` names it).
void apply_bind_pose_file(Rig& rig, const nlohmann::json& pose_json, const std::string& where);

/// Keeps the 4 largest weights per vertex (of the bones the rig has) and renormalises them.
/// Weights of vertices >= vertex_count (helper geometry) are ignored.
/// Throws InputError naming a vertex without any weight.
SkinWeights reduce_weights(const nlohmann::json& weights_json, const Rig& rig, int vertex_count,
                           const std::string& where);

// ---------------------------------------------------------------------------------------------
// Skinning: #V by 3 `rest` to `out` (resized), with one pose per bone.

/// Linear blend skinning: x' = sum_i w_i (R_i x + t_i).
void skin_lbs(const Points& rest, const SkinWeights& weights, const std::vector<BonePose>& poses,
              Points& out);
/// Dual-quaternion skinning (Kavan et al. 2007): blend unit dual quaternions, normalise, apply.
void skin_dqs(const Points& rest, const SkinWeights& weights, const std::vector<BonePose>& poses,
              Points& out);

// ---------------------------------------------------------------------------------------------
// BVH motion capture

struct BvhJoint {
  std::string name;
  int parent = -1;
  Vec3 offset = Vec3::Zero();  ///< from the parent joint, in the file's units
  /// Channel kinds in file order: 0,1,2 = X/Y/Z position, 3,4,5 = X/Y/Z rotation (degrees).
  std::vector<int> channels;
  int first_channel = 0;       ///< column of its first channel in BvhMotion::frames
  bool has_end_site = false;
  Vec3 end_site = Vec3::Zero();
};

struct BvhMotion {
  std::vector<BvhJoint> joints;  ///< parents precede children; joint 0 is the root
  MatX frames;                   ///< #frames by #channels
  double frame_time_s = 0.0;

  int frame_count() const { return static_cast<int>(frames.rows()); }
  int find(const std::string& name) const;
  /// Local rotation of a joint at a frame: the product of its rotation channels in file order.
  Eigen::Quaterniond local_rotation(int frame, int joint) const;
  /// Position channels of a joint at a frame (offset if the joint has none).
  Vec3 local_translation(int frame, int joint) const;
};

/// Throws InputError "FILE:LINE: message" for malformed or truncated files.
BvhMotion read_bvh(const std::string& path);
BvhMotion parse_bvh(std::istream& in, const std::string& name);

// ---------------------------------------------------------------------------------------------
// Retargeted animation

/// Height (y, metres) of a body's lowest point given bind -> posed bone transforms.
using LowestPoint = std::function<double(const std::vector<BonePose>& poses)>;

struct AnimationOptions {
  double speed_scale = 0.75;  ///< 0.75 plays the walk at three quarters of its recorded speed
  double start_time_s = 0.0;  ///< seconds into the motion (after the reference frame) at play time 0
  /// What touches the floor; by default the rig's lowest joint. WalkingBody uses its skinned mesh.
  LowestPoint lowest_point;
  /// Turn the limb segments (upper/lower arm and leg) of the bind pose onto the performer's
  /// reference-pose directions, so that joint angles are the performer's.
  bool align_limbs = true;
  /// Extra abduction of the upper arms (radians) in every frame of the motion: each arm turns
  /// away from the body about the torso's forward axis at the shoulder, the forearm and hand
  /// following. Garments need room between arm and side that a performer's arms swinging
  /// close to the hips do not leave.
  double arm_spread_rad = 0.0;
};

/// A BVH motion retargeted by joint name onto a rig. Frame 0 of the BVH is its reference pose
/// and corresponds to the rig's bind pose; play time 0 is frame 1. Each bone's world rotation is
/// G(t) G(0)^-1 A with G the BVH joint's world rotation and A a fixed alignment of limb segments
/// (see AnimationOptions::align_limbs); joints follow the rig's own bone vectors;
/// the root translation is scaled by the ratio of hip heights, and lifted per frame so that the
/// body's lowest point follows the performer's lowest joint (feet stay on the floor although the
/// rig's legs are not the performer's).
class Animation {
 public:
  Animation(const Rig& rig, const BvhMotion& motion, const AnimationOptions& options = {});

  /// Play time covered by the motion (frames 1..last).
  double duration_s() const { return duration_s_; }
  /// Bind pose -> posed transform of each bone at play time t (clamped to [0, duration]).
  void bone_poses(double t, std::vector<BonePose>& poses) const;
  /// Scale from BVH units to metres.
  double length_scale() const { return length_scale_; }

 private:
  Rig rig_;  ///< a copy (31 bones), so an Animation never dangles
  /// Poses at fractional frame f0 + a (0 <= a <= 1) with the root lifted by lift_m.
  void frame_poses(int f0, double a, double lift_m, std::vector<BonePose>& poses) const;

  std::vector<int> joint_of_bone_;  ///< BVH joint per rig bone (-1: follows its parent)
  std::vector<int> bvh_parent_;
  std::vector<std::vector<Eigen::Quaterniond>> local_;  ///< [frame][joint]
  std::vector<Vec3> root_position_;                     ///< per frame, BVH units
  std::vector<double> ground_lift_m_;                   ///< per frame, see the constructor
  std::vector<Eigen::Quaterniond> reference_world_inverse_;
  std::vector<Eigen::Quaterniond> reference_to_bind_;  ///< per rig bone, see the constructor
  std::vector<Eigen::Quaterniond> spread_;             ///< per BVH joint, AnimationOptions::arm_spread_rad
  double frame_time_s_ = 0.0, speed_scale_ = 1.0, start_time_s_ = 0.0;
  double duration_s_ = 0.0, length_scale_ = 1.0;
};

// ---------------------------------------------------------------------------------------------
// The mannequin (its collider description, BodyColliderSpec, is in weft/collider.hpp)

/// The skinned, walking mannequin.
class WalkingBody {
 public:
  /// Loads mesh, rig, weights and bind pose from data_dir()/body and the motion file.
  explicit WalkingBody(const BodyColliderSpec& spec);

  const Triangles& triangles() const { return triangles_; }
  const Points& rest_positions() const { return rest_; }  ///< A-pose, as in the OBJ
  const Points& bind_positions() const { return bind_; }  ///< T-pose
  const Rig& rig() const { return rig_; }
  const SkinWeights& weights() const { return weights_; }
  const Animation& animation() const { return *animation_; }
  double duration_s() const { return animation_->duration_s(); }
  int vertex_count() const { return static_cast<int>(rest_.rows()); }

  /// Rest -> posed transform per bone at play time t (composition of bind pose and motion).
  void bone_poses(double t, std::vector<BonePose>& poses) const;
  /// Skinned vertex positions at play time t (#V by 3).
  void positions(double t, Points& out) const;
  /// Vertex velocities (m/s) at play time t: central difference of the skinned positions over
  /// a step kept inside one motion frame interval, where the motion is smooth.
  void velocities(double t, Points& out) const;
  void skin(const std::vector<BonePose>& poses, Points& out) const;

 private:
  Points rest_, bind_;
  Triangles triangles_;
  Rig rig_;
  SkinWeights weights_;
  BvhMotion motion_;
  std::unique_ptr<Animation> animation_;
  Skinning skinning_ = Skinning::kLinearBlend;
  double motion_interval_s_ = 0.0;  ///< play time between two motion frames
  double start_time_s_ = 0.0;
  double hold_s_ = 0.0, blend_s_ = 0.0;  ///< BodyColliderSpec::bind_pose_hold and blend
};

/// The shipped walk: data_dir()/motion/35_01.bvh.
std::string default_motion_file();

}  // namespace weft
