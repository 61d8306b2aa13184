// Scene files: parsed from the bytes as if they were a file in scenes/ (so "drum.obj" and
// material files resolve), then the cloth mesh is built and the pins resolved when the mesh
// is small enough to build quickly.
#include "fuzz_common.hpp"
#include "weft/scene.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  weft::fuzz::read_or_refuse([&] {
    const weft::Scene scene =
        weft::parse_scene_text(weft::fuzz::text(data, size), "fuzz_scene.json", WEFT_SOURCE_DIR "/scenes");
    const auto& grid = scene.cloth.grid;
    if (grid && static_cast<long>(grid->vertices_u) * grid->vertices_v > 10000) return;
    const weft::TriMesh mesh = weft::build_cloth_mesh(scene.cloth);
    weft::resolve_pins(scene.cloth, mesh);
  });
  return 0;
}
