// OBJ files: parsed, then turned into a cloth mesh (texture coordinates or projection).
#include "fuzz_common.hpp"
#include "io/obj_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  weft::fuzz::read_or_refuse([&] {
    const weft::ObjData obj = weft::parse_obj(weft::fuzz::text(data, size), "fuzz.obj");
    weft::cloth_mesh_from_obj(obj, 1.0, "fuzz.obj");
  });
  return 0;
}
