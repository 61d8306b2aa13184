// The walking mannequin: shipped body data + a motion, skinned at any time (its collider
// description for scenes is read in io/body_specs.cpp).
#include <numbers>
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "io/json_util.hpp"
#include "weft/body.hpp"
#include "weft/error.hpp"
#include "weft/material.hpp"

namespace weft {

namespace {

nlohmann::json read_json(const std::string& path) { return json_util::load_json_file(path, "body data file"); }

}  // namespace

std::string default_motion_file() { return data_dir() + "/motion/35_01.bvh"; }

WalkingBody::WalkingBody(const BodyColliderSpec& spec)
    : skinning_(parse_skinning(spec.skinning, "skinning")) {
  const std::string dir = data_dir() + "/body/";
  ObjMesh body = read_obj(dir + "body_tri_m.obj");
  rest_ = std::move(body.positions);
  triangles_ = std::move(body.triangles);
  rig_ = build_rig(read_json(dir + "rig.cmu_mb.json"), read_obj(dir + "joint_cubes.obj"), rest_,
                   dir + "rig.cmu_mb.json");
  const std::string tpose = dir + "t-pose.cmu_mb.json";
  apply_bind_pose_file(rig_, read_json(tpose), tpose);
  weights_ = reduce_weights(read_json(dir + "weights.cmu_mb.json"), rig_,
                            static_cast<int>(rest_.rows()), dir + "weights.cmu_mb.json");
  skin_lbs(rest_, weights_, rig_.rest_to_bind, bind_);

  const std::string motion_file = spec.motion_file.empty() ? default_motion_file() : spec.motion_file;
  motion_ = read_bvh(motion_file);
  try {
    AnimationOptions options{spec.speed, spec.start_time, {}, true};
    options.arm_spread_rad = spec.arm_spread_deg * std::numbers::pi / 180;
    // The skinned mesh's lowest point touches the floor; the poses it gets are bind -> posed.
    options.lowest_point = [this](const std::vector<BonePose>& poses) {
      std::vector<BonePose> from_rest(poses.size());
      for (size_t b = 0; b < poses.size(); ++b) from_rest[b] = poses[b] * rig_.rest_to_bind[b];
      Points posed;
      skin(from_rest, posed);
      return posed.col(1).minCoeff();
    };
    animation_ = std::make_unique<Animation>(rig_, motion_, options);
  } catch (const InputError& e) {
    throw InputError(motion_file + ": " + e.what());
  }
  motion_interval_s_ = motion_.frame_time_s / spec.speed;
  start_time_s_ = spec.start_time;
  hold_s_ = spec.bind_pose_hold;
  blend_s_ = spec.blend;
}

void WalkingBody::bone_poses(double t, std::vector<BonePose>& poses) const {
  const double moving = t - hold_s_ - blend_s_;  // play time of the motion
  animation_->bone_poses(std::max(moving, 0.0), poses);
  if (moving < 0) {
    // Standing in the bind pose moved to where the motion starts (its hips where the first
    // pose has them), then blending each bone's transform into the first pose (smoothstep in
    // time, rotations by slerp).
    const Vec3 hips = rig_.head_bind[0];
    const Vec3 shift = poses[0].apply(hips) - hips;
    const double a = blend_s_ > 0 ? std::clamp((t - hold_s_) / blend_s_, 0.0, 1.0) : 0.0;
    const double s = a * a * (3 - 2 * a);
    for (BonePose& p : poses) {
      p.rotation = Eigen::Quaterniond::Identity().slerp(s, p.rotation);
      p.translation = (1 - s) * shift + s * p.translation;
    }
  }
  for (int b = 0; b < rig_.bone_count(); ++b) poses[b] = poses[b] * rig_.rest_to_bind[b];
}

void WalkingBody::skin(const std::vector<BonePose>& poses, Points& out) const {
  if (skinning_ == Skinning::kDualQuaternion)
    skin_dqs(rest_, weights_, poses, out);
  else
    skin_lbs(rest_, weights_, poses, out);
}

void WalkingBody::positions(double t, Points& out) const {
  std::vector<BonePose> poses;
  bone_poses(t, poses);
  skin(poses, out);
}

void WalkingBody::velocities(double t, Points& out) const {
  // The motion interpolates between frames, so it is smooth inside a frame interval and kinked
  // at its ends: difference inside the interval that holds t.
  const double offset_s = start_time_s_ * (motion_interval_s_ / motion_.frame_time_s) - hold_s_ - blend_s_;
  const double phase = (t + offset_s) / motion_interval_s_;
  double lo = (std::floor(phase) * motion_interval_s_) - offset_s;
  double hi = lo + motion_interval_s_;
  if (t < hold_s_ + blend_s_) {  // standing or blending: smooth between the hold's ends
    lo = t < hold_s_ ? 0.0 : hold_s_;
    hi = t < hold_s_ ? hold_s_ : hold_s_ + blend_s_;
  }
  const double h = 1e-4 * motion_interval_s_;
  const double centre = std::clamp(t, std::max(lo + h, h), std::max(hi - h, h));
  Points ahead, behind;
  positions(centre + h, ahead);
  positions(centre - h, behind);
  out = (ahead - behind) / (2 * h);
}

}  // namespace weft
