// BVH motion files: parsed, then retargeted onto the shipped rig (as a body collider does).
#include <sstream>

#include "fuzz_body.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const weft::Rig rig = weft::fuzz::shipped_bind_rig();
  weft::fuzz::read_or_refuse([&] {
    std::istringstream in{std::string(weft::fuzz::text(data, size))};
    const weft::BvhMotion motion = weft::parse_bvh(in, "fuzz.bvh");
    if (motion.frame_count() > 2000) return;  // retargeting is linear in frames; keep runs fast
    weft::Animation animation(rig, motion);
    std::vector<weft::BonePose> poses;
    animation.bone_poses(0.5 * animation.duration_s(), poses);
  });
  return 0;
}
