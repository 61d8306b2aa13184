// The bind-pose JSON ({"bone_rotations": {...}}), applied to the shipped rig.
#include "fuzz_body.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const weft::Rig rest = weft::fuzz::shipped_rest_rig();
  weft::fuzz::read_or_refuse([&] {
    weft::Rig rig = rest;
    weft::apply_bind_pose_file(rig, weft::json_util::parse_json(weft::fuzz::text(data, size), "fuzz_tpose.json"),
                               "fuzz_tpose.json");
  });
  return 0;
}
