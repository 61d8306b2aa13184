#include "weft/run_frames.hpp"

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <regex>

#include "io/obj_file.hpp"
#include "weft/run_folder.hpp"
#include "weft/error.hpp"

namespace fs = std::filesystem;

namespace weft {
namespace {

RunFrameMesh read_obj_frame(const fs::path& path) {
  const ObjData obj = read_obj_file(path.string());
  RunFrameMesh m;
  m.xyz = obj.positions;
  m.triangles.reserve(obj.triangles.size());
  bool textured = !obj.texcoords.empty();
  for (const auto& t : obj.triangles) {
    m.triangles.push_back({t[0].vertex, t[1].vertex, t[2].vertex});
    for (const auto& c : t) textured = textured && c.texcoord >= 0;
  }
  if (textured) {
    m.corner_texcoords.reserve(6 * obj.triangles.size());
    for (const auto& t : obj.triangles)
      for (const auto& c : t)
        for (int k = 0; k < 2; ++k) m.corner_texcoords.push_back(obj.texcoords[2 * static_cast<size_t>(c.texcoord) + k]);
  }
  return m;
}

// The ASCII PLY frames of `weft run --frame-format ply`.
/// A PLY frame through the run-folder reader (weft/run_folder.hpp), which the viewer uses too.
RunFrameMesh read_ply_mesh(const fs::path& path) {
  PlyFrame ply = read_ply_frame(path);
  RunFrameMesh m;
  m.xyz = std::move(ply.xyz);
  m.triangles = std::move(ply.triangles);
  m.added_viscosity = std::move(ply.added_viscosity);
  return m;
}

}  // namespace

std::map<long, RunFrameFiles> find_run_frames(const fs::path& dir, const std::string& command) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw InputError(dir.string() + ": no such folder (expected the output folder of `weft run`)");
  const fs::path frames = dir / "frames";
  if (!fs::is_directory(frames, ec))
    throw InputError(frames.string() + ": no such folder (" + command + " reads the frames of `weft run`: " +
                     "DIR/frames/frame_NNNNN.obj or .ply, DIR/frames/body<k>_NNNNN.obj and collider<k>_NNNNN.obj)");
  static const std::regex cloth(R"(frame_(\d{5,})\.(obj|ply))"), body(R"(((?:body|collider)\d+)_(\d{5,})\.obj)");
  std::map<long, RunFrameFiles> found;
  for (const auto& e : fs::directory_iterator(frames)) {
    const std::string name = e.path().filename().string();
    std::smatch m;
    if (std::regex_match(name, m, cloth)) {
      RunFrameFiles& f = found[std::stol(m[1])];
      if (!f.cloth.empty())
        throw InputError(e.path().string() + ": frame " + m[1].str() + " is also in " + f.cloth.string() +
                         " (expected one file per frame)");
      f.cloth = e.path();
    } else if (std::regex_match(name, m, body)) {
      found[std::stol(m[2])].colliders[m[1].str()] = e.path();
    }
  }
  for (const auto& [number, f] : found)
    if (f.cloth.empty()) {
      char cloth_name[32];
      std::snprintf(cloth_name, sizeof cloth_name, "frame_%05ld", number);
      throw InputError(f.colliders.begin()->second.string() + ": a body frame without its cloth frame (expected " +
                       (frames / cloth_name).string() + ".obj or .ply)");
    }
  if (found.empty()) throw InputError(frames.string() + ": no frames (expected frame_NNNNN.obj or frame_NNNNN.ply files)");
  return found;
}

RunFrameMesh read_frame_mesh(const fs::path& path) {
  return path.extension() == ".ply" ? read_ply_mesh(path) : read_obj_frame(path);
}

double run_uv_scale(const nlohmann::json& summary, const std::string& summary_path) {
  if (!summary.is_object() || !summary.contains("uv_scale")) return 1.0;
  const nlohmann::json& v = summary["uv_scale"];
  if (!v.is_number() || !(v.get<double>() > 0) || !std::isfinite(v.get<double>()))
    throw InputError(summary_path + ": uv_scale " + v.dump() + ": expected a number > 0 (metres per texture unit)");
  return v.get<double>();
}

}  // namespace weft
