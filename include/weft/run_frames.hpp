#pragma once
// Reading back the per-frame files of `weft run` (docs/exports.md): DIR/frames/frame_NNNNN.obj
// or .ply (the cloth) and DIR/frames/body<k>_NNNNN.obj, collider<k>_NNNNN.obj (the colliders'
// surfaces). `weft check` and `weft render` read them.
#include <array>
#include <filesystem>
#include <map>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

namespace weft {

struct RunFrameFiles {
  std::filesystem::path cloth;                              ///< frame_NNNNN.obj or .ply
  std::map<std::string, std::filesystem::path> colliders;  ///< the colliders' surfaces, by name ("body0", "collider1")
};

/// The frames of DIR/frames by number. `command` names the reader in messages ("weft check").
/// Throws InputError for a missing folder, a folder without frames, a frame number given twice
/// (as .obj and .ply) and a collider's frame without its cloth frame.
std::map<long, RunFrameFiles> find_run_frames(const std::filesystem::path& dir, const std::string& command);

/// One frame's triangle mesh as a frame file holds it.
struct RunFrameMesh {
  std::vector<double> xyz;                     ///< 3 per vertex, metres
  std::vector<std::array<int, 3>> triangles;  ///< 0-based vertex indices
  std::vector<double> corner_texcoords;        ///< OBJ: (u, v) of each triangle's corners, 6 per triangle; empty when a corner has none
  std::vector<double> added_viscosity;         ///< PLY: per vertex (N s/m); empty when the file has no such property
  int vertex_count() const { return static_cast<int>(xyz.size() / 3); }
};

/// Reads an OBJ (io/obj_file.hpp) or an ASCII PLY frame (a vertex element with x, y, z and
/// optionally added_viscosity; a face element of index lists, polygons split as fans), by the
/// file's extension. Throws InputError naming the file and line.
RunFrameMesh read_frame_mesh(const std::filesystem::path& path);

/// The metres per unit of a run's texture coordinates: `uv_scale` of its summary.json (the
/// scene's cloth mesh.uv_scale, which `weft run` records), or 1 for a summary without it (runs
/// of weft before it was recorded). Throws InputError naming `summary_path` and the key when
/// the value is not a number > 0.
double run_uv_scale(const nlohmann::json& summary, const std::string& summary_path);

}  // namespace weft
