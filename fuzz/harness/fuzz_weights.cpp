// The skinning weights JSON, for the shipped rig; for speed only the first 64 vertices need
// weights (the reader ignores weights of vertices beyond the count, as for helper geometry).
#include "fuzz_body.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const weft::Rig rig = weft::fuzz::shipped_rest_rig();
  const int vertices = 64;
  weft::fuzz::read_or_refuse([&] {
    const nlohmann::json j = weft::json_util::parse_json(weft::fuzz::text(data, size), "fuzz_weights.json");
    weft::reduce_weights(j, rig, vertices, "fuzz_weights.json");
  });
  return 0;
}
