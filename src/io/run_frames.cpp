#include "io/run_frames.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>

#include "io/obj_file.hpp"
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
RunFrameMesh read_ply_frame(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string() + ": cannot read");
  const std::string name = path.string();
  std::string line;
  int line_no = 0;
  auto fail = [&](const std::string& what) -> InputError {
    return InputError(name + ":" + std::to_string(line_no) + ": " + what);
  };
  long vertices = -1, faces = -1;
  std::vector<std::string> vertex_properties;
  std::string element;
  bool ascii = false;
  while (true) {
    if (!std::getline(in, line)) throw fail("the header has no end_header line");
    ++line_no;
    std::istringstream words(line);
    std::string word;
    words >> word;
    if (line_no == 1) {
      if (word != "ply") throw fail("not a PLY file (expected 'ply' on the first line, got '" + line + "')");
      continue;
    }
    if (word == "end_header") break;
    if (word == "format") {
      std::string format;
      words >> format;
      ascii = format == "ascii";
    } else if (word == "element") {
      long count = -1;
      words >> element >> count;
      if (count < 0) throw fail("element " + element + " needs a count >= 0");
      if (element == "vertex") vertices = count;
      if (element == "face") faces = count;
    } else if (word == "property" && element == "vertex") {
      std::string type, property;
      words >> type >> property;
      vertex_properties.push_back(property);
    }
  }
  if (!ascii) throw fail("weft reads ASCII PLY frames only (format ascii 1.0)");
  if (vertices < 0 || faces < 0) throw fail("the header needs a vertex and a face element");
  int axis_column[3] = {-1, -1, -1}, viscosity_column = -1;
  for (size_t k = 0; k < vertex_properties.size(); ++k) {
    for (int axis = 0; axis < 3; ++axis)
      if (vertex_properties[k] == std::string(1, "xyz"[axis])) axis_column[axis] = static_cast<int>(k);
    if (vertex_properties[k] == "added_viscosity") viscosity_column = static_cast<int>(k);
  }
  if (axis_column[0] < 0 || axis_column[1] < 0 || axis_column[2] < 0)
    throw fail("the vertex element needs properties x, y and z");
  RunFrameMesh m;
  m.xyz.resize(3 * static_cast<size_t>(vertices));
  if (viscosity_column >= 0) m.added_viscosity.resize(static_cast<size_t>(vertices));
  std::vector<double> values(vertex_properties.size());
  for (long i = 0; i < vertices; ++i) {
    if (!std::getline(in, line))
      throw fail("the file ends after " + std::to_string(i) + " of " + std::to_string(vertices) + " vertices");
    ++line_no;
    std::istringstream words(line);
    for (double& v : values)
      if (!(words >> v) || !std::isfinite(v))
        throw fail("expected " + std::to_string(values.size()) + " numbers, got '" + line + "'");
    for (int axis = 0; axis < 3; ++axis) m.xyz[3 * i + axis] = values[axis_column[axis]];
    if (viscosity_column >= 0) m.added_viscosity[i] = values[viscosity_column];
  }
  for (long f = 0; f < faces; ++f) {
    if (!std::getline(in, line))
      throw fail("the file ends after " + std::to_string(f) + " of " + std::to_string(faces) + " faces");
    ++line_no;
    std::istringstream words(line);
    int n = 0;
    words >> n;
    std::vector<int> corner(n > 0 ? n : 0);
    for (int& c : corner)
      if (!(words >> c) || c < 0 || c >= vertices)
        throw fail("expected a face of vertex indices in [0, " + std::to_string(vertices) + "), got '" + line + "'");
    if (n < 3) throw fail("a face needs at least 3 vertices, got '" + line + "'");
    for (int k = 1; k + 1 < n; ++k) m.triangles.push_back({corner[0], corner[k], corner[k + 1]});
  }
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
  return path.extension() == ".ply" ? read_ply_frame(path) : read_obj_frame(path);
}

}  // namespace weft
