// The scene's words for the body: a body collider's keys (BodyColliderSpec, weft/collider.hpp),
// the skinning names, and the body parts a garment's panels are placed on (weft/placement_spec.hpp).
#include <filesystem>
#include <nlohmann/json.hpp>

#include "weft/collider.hpp"
#include "weft/error.hpp"
#include "weft/placement_spec.hpp"

namespace weft {

namespace {

/// Bounds on a body collider's playback (docs/scene-format.md).
constexpr double kMaxBodySpeed = 100;
constexpr double kMaxBodyStartTime_s = 1e7;

}  // namespace

Skinning parse_skinning(const std::string& name, const std::string& where) {
  if (name == "lbs") return Skinning::kLinearBlend;
  if (name == "dqs") return Skinning::kDualQuaternion;
  throw InputError(where + ": skinning must be \"lbs\" or \"dqs\", got \"" + name + "\"");
}

BodyColliderSpec parse_body_collider(const nlohmann::json& j, const std::string& where,
                                     const std::string& base_dir) {
  if (!j.is_object()) throw InputError(where + ": a body collider must be an object");
  BodyColliderSpec spec;
  for (const auto& [key, value] : j.items()) {
    const std::string at = where + "." + key;
    if (key == "type") {
      if (!value.is_string() || value.get<std::string>() != "body")
        throw InputError(at + ": expected \"body\"");
    } else if (key == "motion") {
      if (!value.is_string()) throw InputError(at + ": expected a file name (string)");
      const std::filesystem::path motion = value.get<std::string>();
      if (motion.empty()) throw InputError(at + ": expected a file name, got \"\"");
      spec.motion_file = (motion.is_absolute() ? motion : std::filesystem::path(base_dir) / motion)
                             .lexically_normal()
                             .string();
    } else if (key == "speed") {
      if (!value.is_number()) throw InputError(at + ": expected a number");
      spec.speed = value.get<double>();
      if (!(spec.speed > 0 && spec.speed <= kMaxBodySpeed))
        throw InputError(at + ": must be in (0, 100], got " + value.dump());
    } else if (key == "skinning") {
      if (!value.is_string()) throw InputError(at + ": expected \"lbs\" or \"dqs\"");
      spec.skinning = value.get<std::string>();
      parse_skinning(spec.skinning, at);
    } else if (key == "start_time") {
      if (!value.is_number()) throw InputError(at + ": expected a number (seconds)");
      spec.start_time = value.get<double>();
      if (!(spec.start_time >= 0 && spec.start_time <= kMaxBodyStartTime_s))
        throw InputError(at + ": must be in [0, 1e7] s, got " + value.dump());
    } else if (key == "bind_pose_hold" || key == "blend") {
      if (!value.is_number()) throw InputError(at + ": expected a number (seconds)");
      const double seconds = value.get<double>();
      if (!(seconds >= 0 && seconds <= kMaxBodyStartTime_s)) throw InputError(at + ": must be in [0, 1e7] s, got " + value.dump());
      (key == "blend" ? spec.blend : spec.bind_pose_hold) = seconds;
    } else if (key == "arm_spread_deg") {
      if (!value.is_number()) throw InputError(at + ": expected a number (degrees)");
      spec.arm_spread_deg = value.get<double>();
      if (!(spec.arm_spread_deg >= -45 && spec.arm_spread_deg <= 45))
        throw InputError(at + ": must be in [-45, 45] degrees, got " + value.dump());
    } else {
      throw InputError(where + ": unknown key \"" + key +
                       "\" (expected type, motion, speed, skinning, start_time, bind_pose_hold, blend, arm_spread_deg, "
                       "thickness, friction)");
    }
  }
  return spec;
}

BodyPart parse_body_part(const std::string& name, const std::string& where) {
  for (BodyPart p : {BodyPart::kTorso, BodyPart::kLeftArm, BodyPart::kRightArm, BodyPart::kLeftLeg,
                     BodyPart::kRightLeg, BodyPart::kHead})
    if (body_part_name(p) == name) return p;
  throw InputError(where + ": unknown body part \"" + name +
                   "\" (expected torso, left_arm, right_arm, left_leg, right_leg or head)");
}

std::string body_part_name(BodyPart part) {
  switch (part) {
    case BodyPart::kTorso: return "torso";
    case BodyPart::kLeftArm: return "left_arm";
    case BodyPart::kRightArm: return "right_arm";
    case BodyPart::kLeftLeg: return "left_leg";
    case BodyPart::kRightLeg: return "right_leg";
    case BodyPart::kHead: return "head";
  }
  return "torso";
}

}  // namespace weft
