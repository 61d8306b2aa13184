// Retargeting a BVH motion onto the rig, and sampling it at any time.
#include <algorithm>
#include <cmath>

#include "weft/body.hpp"
#include "weft/error.hpp"

namespace weft {

namespace {

// Rig bone names that differ from the CMU BVH joint names.
std::string bvh_name(const std::string& bone) {
  if (bone == "LeftHandFinger1") return "LeftHandIndex1";
  if (bone == "RightHandFinger1") return "RightHandIndex1";
  return bone;
}

// World rotations of all BVH joints from local ones (parents precede children).
void compose(const std::vector<int>& parent, const std::vector<Eigen::Quaterniond>& local,
             std::vector<Eigen::Quaterniond>& world) {
  world.resize(local.size());
  for (size_t j = 0; j < local.size(); ++j)
    world[j] = parent[j] < 0 ? local[j] : world[parent[j]] * local[j];
}

// Joint positions (then end sites) of a BVH skeleton from world rotations and root position.
std::vector<Vec3> skeleton_points(const BvhMotion& motion,
                                  const std::vector<Eigen::Quaterniond>& world, const Vec3& root) {
  const size_t joints = motion.joints.size();
  std::vector<Vec3> points(joints);
  for (size_t j = 0; j < joints; ++j) {
    const int p = motion.joints[j].parent;
    points[j] = p < 0 ? root : Vec3(points[p] + world[p] * motion.joints[j].offset);
  }
  for (size_t j = 0; j < joints; ++j)
    if (motion.joints[j].has_end_site)
      points.push_back(points[j] + world[j] * motion.joints[j].end_site);
  return points;
}

double lowest(const std::vector<Vec3>& points) {
  double y = points.front().y();
  for (const Vec3& p : points) y = std::min(y, p.y());
  return y;
}

// Height of joint `top` above the lowest joint or end site of a skeleton.
double height_above_lowest(const std::vector<Vec3>& points, int top) {
  return points[top].y() - lowest(points);
}

}  // namespace

Animation::Animation(const Rig& rig, const BvhMotion& motion, const AnimationOptions& options)
    : rig_(rig),
      frame_time_s_(motion.frame_time_s),
      speed_scale_(options.speed_scale),
      start_time_s_(options.start_time_s) {
  if (!(speed_scale_ > 0) || !std::isfinite(speed_scale_))
    throw InputError("speed scale must be positive");
  if (motion.frame_count() < 2)
    throw InputError("motion needs a reference frame and at least one more frame");
  const int root = 0;
  if (motion.find(bvh_name(rig.bone_names[root])) != root)
    throw InputError("motion's root joint must be '" + rig.bone_names[root] + "'");
  joint_of_bone_.resize(rig.bone_names.size());
  for (int b = 0; b < rig.bone_count(); ++b) joint_of_bone_[b] = motion.find(bvh_name(rig.bone_names[b]));
  for (const auto& j : motion.joints) bvh_parent_.push_back(j.parent);

  const int frames = motion.frame_count();
  const int joints = static_cast<int>(motion.joints.size());
  local_.assign(frames, std::vector<Eigen::Quaterniond>(joints));
  root_position_.resize(frames);
  for (int f = 0; f < frames; ++f) {
    for (int j = 0; j < joints; ++j) local_[f][j] = motion.local_rotation(f, j);
    root_position_[f] = motion.local_translation(f, root);
  }
  // Frame 0 is the reference pose (the T-pose that matches the rig's bind pose).
  std::vector<Eigen::Quaterniond> reference;
  compose(bvh_parent_, local_[0], reference);
  // A bone's world rotation is G(t) G(0)^-1 A: A turns the rig's bind direction of a limb
  // segment onto the performer's reference direction of it (the rig's T-pose keeps the elbows
  // bent by about 15 degrees, the performer's are straight); other bones keep A = I, since their
  // directions differ by skeleton design (spine curve, hip and shoulder girdles, hand shape).
  reference_to_bind_.assign(rig.bone_names.size(), Eigen::Quaterniond::Identity());
  for (int b = 0; b < rig.bone_count() && options.align_limbs; ++b) {
    const std::string& name = rig.bone_names[b];
    const bool limb = name.ends_with("Leg") || name.ends_with("Arm");  // UpLeg, Leg, Arm, ForeArm
    const int j = joint_of_bone_[b];
    if (!limb || j < 0) continue;
    Vec3 segment = Vec3::Zero();  // the joint's longest child offset
    for (int c = 0; c < joints; ++c)
      if (motion.joints[c].parent == j && motion.joints[c].offset.norm() > segment.norm())
        segment = motion.joints[c].offset;
    if (segment.norm() == 0) continue;
    reference_to_bind_[b] = Eigen::Quaterniond::FromTwoVectors(
        rig.tail_bind[b] - rig.head_bind[b], reference[j] * segment);
  }
  // Arm spread: the upper arm's local rotation is preceded by a turn about the torso's forward
  // axis, expressed in the parent (shoulder) frame of the reference pose; in any frame it then
  // turns the arm about the posed torso's forward axis, away from the side. The forward axis is
  // the arm's reference (T-pose) direction crossed with up, so the turn by a positive angle
  // takes a hanging arm outwards on either side.
  spread_.assign(joints, Eigen::Quaterniond::Identity());
  if (!std::isfinite(options.arm_spread_rad) || std::abs(options.arm_spread_rad) > 1.0)
    throw InputError("arm spread must lie in [-1, 1] rad");
  for (const char* name : {"LeftArm", "RightArm"}) {
    const int j = motion.find(name);
    if (options.arm_spread_rad == 0 || j < 0 || motion.joints[j].parent < 0) continue;
    Vec3 segment = Vec3::Zero();
    for (int c = 0; c < joints; ++c)
      if (motion.joints[c].parent == j && motion.joints[c].offset.norm() > segment.norm())
        segment = motion.joints[c].offset;
    const Vec3 direction = reference[j] * segment;
    const Vec3 axis = direction.cross(Vec3::UnitY());
    if (axis.norm() < 1e-9 * std::max(direction.norm(), 1e-300)) continue;
    const int p = motion.joints[j].parent;
    spread_[j] = Eigen::Quaterniond(
        Eigen::AngleAxisd(options.arm_spread_rad, reference[p].conjugate() * axis.normalized()));
  }
  reference_world_inverse_.resize(joints);
  for (int j = 0; j < joints; ++j) reference_world_inverse_[j] = reference[j].conjugate();

  // Ratio of hip heights (above each skeleton's lowest joint) in the reference pose.
  const std::vector<Vec3> bvh_points = skeleton_points(motion, reference, root_position_[0]);
  std::vector<Vec3> rig_points = rig.head_bind;
  rig_points.insert(rig_points.end(), rig.tail_bind.begin(), rig.tail_bind.end());
  const double bvh_hip = height_above_lowest(bvh_points, root);
  const double rig_hip = height_above_lowest(rig_points, root);
  if (!(bvh_hip > 0)) throw InputError("motion's reference pose has its root at the lowest point");
  length_scale_ = rig_hip / bvh_hip;
  // A motion in millimetres has a scale of 1e-3 m per unit, one in inches 0.025; far outside
  // these the offsets are not a human skeleton, and the retargeted root would leave the scene.
  if (!(length_scale_ >= 1e-4 && length_scale_ <= 1e4))
    throw InputError("motion's reference-pose hip height " + std::to_string(bvh_hip) +
                     " (file units) gives a scale of " + std::to_string(length_scale_) +
                     " m per unit, outside [1e-4, 1e4]");

  // Grounding: the rig's legs are not the performer's, so scaling the root alone lets the feet
  // sink or float. The performer's floor is the lowest its lowest joint gets during the motion;
  // per frame, the root is lifted so that the body's lowest point is as high above the bind
  // pose's lowest point as the performer's lowest joint is above its floor (scaled). Between
  // frames the lift is interpolated like the rest of the motion.
  LowestPoint lowest_point = options.lowest_point;
  if (!lowest_point) {
    lowest_point = [&rig](const std::vector<BonePose>& poses) {
      std::vector<Vec3> posed;
      for (int b = 0; b < rig.bone_count(); ++b) {
        posed.push_back(poses[b].apply(rig.head_bind[b]));
        posed.push_back(poses[b].apply(rig.tail_bind[b]));
      }
      return lowest(posed);
    };
  }
  std::vector<double> performer_lowest(frames, 0.0);
  for (int f = 1; f < frames; ++f) {
    std::vector<Eigen::Quaterniond> world;
    compose(bvh_parent_, local_[f], world);
    performer_lowest[f] = lowest(skeleton_points(motion, world, root_position_[f]));
  }
  const double performer_floor =
      *std::min_element(performer_lowest.begin() + 1, performer_lowest.end());
  std::vector<BonePose> poses(rig.bone_names.size());
  const double bind_lowest = lowest_point(poses);
  ground_lift_m_.assign(frames, 0.0);
  for (int f = 1; f < frames; ++f) {
    if (f + 1 < frames)
      frame_poses(f, 0.0, 0.0, poses);
    else
      frame_poses(f - 1, 1.0, 0.0, poses);
    ground_lift_m_[f] = bind_lowest + length_scale_ * (performer_lowest[f] - performer_floor) -
                        lowest_point(poses);
  }
  ground_lift_m_[0] = ground_lift_m_[1];

  duration_s_ = ((frames - 2) * frame_time_s_ - start_time_s_) / speed_scale_;
  if (!(duration_s_ > 0) || start_time_s_ < 0)
    throw InputError("start time must lie in [0, " + std::to_string((frames - 2) * frame_time_s_) +
                     ") s of the motion");
}

void Animation::bone_poses(double t, std::vector<BonePose>& poses) const {
  // Play time -> fractional frame index; frame 1 is the first frame of the motion.
  const double last = static_cast<double>(local_.size() - 1);
  const double u = std::clamp(1.0 + (start_time_s_ + speed_scale_ * t) / frame_time_s_, 1.0, last);
  const int f0 = std::min(static_cast<int>(std::floor(u)), static_cast<int>(last) - 1);
  const double a = u - f0;
  const double lift_m = (1 - a) * ground_lift_m_[f0] + a * ground_lift_m_[f0 + 1];
  frame_poses(f0, a, lift_m, poses);
}

void Animation::frame_poses(int f0, double a, double lift_m, std::vector<BonePose>& poses) const {
  const Rig& rig = rig_;
  const size_t joints = bvh_parent_.size();
  std::vector<Eigen::Quaterniond> local(joints), world;
  for (size_t j = 0; j < joints; ++j) local[j] = spread_[j] * local_[f0][j].slerp(a, local_[f0 + 1][j]);
  compose(bvh_parent_, local, world);
  const Vec3 root = (1 - a) * root_position_[f0] + a * root_position_[f0 + 1];

  poses.resize(rig.bone_names.size());
  std::vector<Vec3> head(rig.bone_names.size());
  for (int b = 0; b < rig.bone_count(); ++b) {
    const int p = rig.parent[b];
    const int j = joint_of_bone_[b];
    Eigen::Quaterniond rotation =
        j >= 0 ? world[j] * reference_world_inverse_[j] * reference_to_bind_[b]
               : (p >= 0 ? poses[p].rotation : Eigen::Quaterniond::Identity());
    rotation.normalize();
    if (p < 0) {
      head[b] = rig.head_bind[b] + length_scale_ * (root - root_position_[0]) + lift_m * Vec3::UnitY();
    } else {
      head[b] = head[p] + poses[p].rotation * (rig.head_bind[b] - rig.head_bind[p]);
    }
    poses[b] = {rotation, head[b] - rotation * rig.head_bind[b]};
  }
}

}  // namespace weft
