// Material files, as if in data/materials (so "file" references resolve beside the presets).
#include "fuzz_common.hpp"
#include "weft/material.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  weft::fuzz::read_or_refuse([&] {
    weft::parse_material_text(weft::fuzz::text(data, size), WEFT_SOURCE_DIR "/data/materials/fuzz.json");
  });
  return 0;
}
