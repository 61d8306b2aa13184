// The rig JSON: bones, parents and joint strategies, on the shipped body and joint cubes.
#include "fuzz_body.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const weft::ObjMesh& body = weft::fuzz::shipped_body();
  const weft::ObjMesh& cubes = weft::fuzz::shipped_joint_cubes();
  weft::fuzz::read_or_refuse([&] {
    const nlohmann::json j = weft::json_util::parse_json(weft::fuzz::text(data, size), "fuzz_rig.json");
    weft::build_rig(j, cubes, body.positions, "fuzz_rig.json");
  });
  return 0;
}
