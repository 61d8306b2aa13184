#include "weft/run_folder.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <thread>

#include "weft/input_file.hpp"
#include "io/obj_file.hpp"
#include "weft/error.hpp"

namespace fs = std::filesystem;

namespace weft {

namespace {

// The numbers of one line, separated by spaces or tabs, parsed with from_chars (a frame has
// tens of thousands of lines; streams would take most of the viewer's start). False when a
// word is not a number or is not finite.
template <typename T>
bool parse_numbers(std::string_view line, std::vector<T>& out) {
  out.clear();
  const char* p = line.data();
  const char* end = p + line.size();
  while (true) {
    while (p < end && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
    if (p == end) return true;
    T value{};
    const auto [next, error] = std::from_chars(p, end, value);
    if (error != std::errc() || next == p) return false;
    if constexpr (std::is_floating_point_v<T>)
      if (!std::isfinite(value)) return false;
    out.push_back(value);
    p = next;
  }
}

}  // namespace

PlyFrame read_ply_frame(const fs::path& path) {
  const std::string text = read_input_file(path.string(), "PLY file");
  const std::string name = path.string();
  size_t at = 0;
  std::string_view line;
  int line_no = 0;
  auto next_line = [&]() {
    if (at >= text.size()) return false;
    size_t end = text.find('\n', at);
    if (end == std::string::npos) end = text.size();
    line = std::string_view(text).substr(at, end - at);
    at = end + 1;
    ++line_no;
    return true;
  };
  auto fail = [&](const std::string& what) -> InputError { return InputError(name + ":" + std::to_string(line_no) + ": " + what); };
  long vertices = -1, faces = -1;
  std::vector<std::string> vertex_properties;
  std::string element;
  bool ascii = false;
  while (true) {
    if (!next_line()) throw fail("the header has no end_header line");
    std::istringstream words{std::string(line)};
    std::string word;
    words >> word;
    if (line_no == 1) {
      if (word != "ply") throw fail("not a PLY file (expected 'ply' on the first line, got '" + std::string(line) + "')");
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
  if (!ascii) throw fail("only ASCII PLY is read (format ascii 1.0)");
  if (vertices < 0 || faces < 0) throw fail("the header needs a vertex and a face element");
  int axis_column[3] = {-1, -1, -1}, viscosity_column = -1;
  for (size_t k = 0; k < vertex_properties.size(); ++k) {
    for (int axis = 0; axis < 3; ++axis)
      if (vertex_properties[k] == std::string(1, "xyz"[axis])) axis_column[axis] = static_cast<int>(k);
    if (vertex_properties[k] == "added_viscosity") viscosity_column = static_cast<int>(k);
  }
  if (axis_column[0] < 0 || axis_column[1] < 0 || axis_column[2] < 0) throw fail("the vertex element needs properties x, y and z");
  PlyFrame frame;
  frame.xyz.resize(3 * static_cast<size_t>(vertices));
  if (viscosity_column >= 0) frame.added_viscosity.resize(static_cast<size_t>(vertices));
  std::vector<double> values;
  for (long i = 0; i < vertices; ++i) {
    if (!next_line()) throw fail("the file ends after " + std::to_string(i) + " of " + std::to_string(vertices) + " vertices");
    if (!parse_numbers(line, values) || values.size() < vertex_properties.size())
      throw fail("expected " + std::to_string(vertex_properties.size()) + " numbers, got '" + std::string(line) + "'");
    for (int axis = 0; axis < 3; ++axis) frame.xyz[3 * i + axis] = values[axis_column[axis]];
    if (viscosity_column >= 0) frame.added_viscosity[i] = values[viscosity_column];
  }
  std::vector<long> corner;
  for (long f = 0; f < faces; ++f) {
    if (!next_line()) throw fail("the file ends after " + std::to_string(f) + " of " + std::to_string(faces) + " faces");
    const bool parsed = parse_numbers(line, corner);
    const long n = corner.empty() ? 0 : corner[0];
    bool in_range = parsed && n >= 0 && static_cast<long>(corner.size()) >= n + 1;
    for (long k = 1; in_range && k <= n; ++k) in_range = corner[k] >= 0 && corner[k] < vertices;
    if (!in_range)
      throw fail("expected a face of vertex indices in [0, " + std::to_string(vertices) + "), got '" + std::string(line) + "'");
    if (n < 3) throw fail("a face needs at least 3 vertices, got '" + std::string(line) + "'");
    for (long k = 2; k < n; ++k)
      frame.triangles.push_back({static_cast<int>(corner[1]), static_cast<int>(corner[k]), static_cast<int>(corner[k + 1])});
  }
  return frame;
}

namespace {

// One frame's mesh as read from a file, before it joins its mesh's frames.
struct FrameMesh {
  std::vector<double> xyz;
  std::vector<std::uint32_t> indices;
  std::vector<float> texcoords;  // 2 per vertex, or empty
  std::vector<double> viscosity;
};

FrameMesh read_frame_mesh(const fs::path& path) {
  FrameMesh m;
  if (path.extension() == ".ply") {
    PlyFrame ply = read_ply_frame(path);
    m.xyz = std::move(ply.xyz);
    m.viscosity = std::move(ply.added_viscosity);
    for (const auto& t : ply.triangles)
      for (int c : t) m.indices.push_back(static_cast<std::uint32_t>(c));
    return m;
  }
  ObjData obj = read_obj_file(path.string());
  m.xyz = std::move(obj.positions);
  const size_t n = m.xyz.size() / 3;
  bool every_corner_textured = !obj.triangles.empty() && !obj.texcoords.empty();
  std::vector<float> uv(2 * n, 0.0f);
  for (const auto& t : obj.triangles)
    for (const ObjData::Corner& c : t) {
      m.indices.push_back(static_cast<std::uint32_t>(c.vertex));
      if (c.texcoord < 0) {
        every_corner_textured = false;
        continue;
      }
      uv[2 * c.vertex] = static_cast<float>(obj.texcoords[2 * c.texcoord]);
      uv[2 * c.vertex + 1] = static_cast<float>(obj.texcoords[2 * c.texcoord + 1]);
    }
  if (every_corner_textured) m.texcoords = std::move(uv);
  return m;
}

// Reads `paths` (one per frame) on a few threads into one mesh; every frame must have the
// first's triangles.
RunMesh read_mesh_frames(const std::string& name, const std::vector<fs::path>& paths) {
  std::vector<FrameMesh> frames(paths.size());
  std::vector<std::string> errors(paths.size());
  const size_t workers = std::clamp<size_t>(std::thread::hardware_concurrency(), 1, 8);
  std::vector<std::thread> threads;
  for (size_t w = 0; w < std::min(workers, paths.size()); ++w)
    threads.emplace_back([&, w] {
      for (size_t f = w; f < paths.size(); f += workers) try {
          frames[f] = read_frame_mesh(paths[f]);
        } catch (const std::exception& e) {
          errors[f] = e.what();
        }
    });
  for (auto& t : threads) t.join();
  for (const std::string& e : errors)
    if (!e.empty()) throw InputError(e);
  RunMesh mesh;
  mesh.name = name;
  mesh.vertex_count = static_cast<int>(frames.front().xyz.size() / 3);
  mesh.indices = frames.front().indices;
  mesh.texcoords = frames.front().texcoords;
  mesh.frames = static_cast<int>(frames.size());
  const size_t coordinates = frames.front().xyz.size();
  mesh.positions.reserve(frames.size() * coordinates);
  const bool viscosity = frames.front().viscosity.size() == static_cast<size_t>(mesh.vertex_count);
  for (size_t f = 0; f < frames.size(); ++f) {
    if (frames[f].xyz.size() != coordinates || frames[f].indices != mesh.indices)
      throw InputError(paths[f].string() + ": " + std::to_string(frames[f].xyz.size() / 3) + " vertices and " +
                       std::to_string(frames[f].indices.size() / 3) + " triangles, not the mesh of " + paths.front().string() +
                       " (" + std::to_string(mesh.vertex_count) + " vertices and " + std::to_string(mesh.indices.size() / 3) +
                       " triangles)");
    for (double x : frames[f].xyz) mesh.positions.push_back(static_cast<float>(x));
    if (viscosity) {
      if (frames[f].viscosity.size() != static_cast<size_t>(mesh.vertex_count))
        throw InputError(paths[f].string() + ": no added_viscosity per vertex, which " + paths.front().string() + " has");
      for (double v : frames[f].viscosity) mesh.viscosity.push_back(static_cast<float>(v));
    }
    frames[f] = FrameMesh();  // its memory back as the run's frames pile up
  }
  if (viscosity) mesh.viscosity_frames = mesh.frames;
  return mesh;
}

// The glb that `weft run --format glb` writes (weft/exports.hpp, write_glb): each node's mesh,
// its first frame as vertices and each later frame as a morph target, keyed by one animation.
class GlbReader {
 public:
  explicit GlbReader(const fs::path& path) : file_(path.string()), bytes_(read_input_file(file_, "glb file")) {
    if (bytes_.size() < 20 || u32(0) != 0x46546C67 || u32(4) != 2) fail("not a glTF 2.0 binary (.glb)");
    const size_t json_length = u32(12);
    if (u32(16) != 0x4E4F534A || 20 + json_length > bytes_.size()) fail("its first chunk is not JSON");
    try {
      json_ = nlohmann::json::parse(bytes_.begin() + 20, bytes_.begin() + 20 + static_cast<long>(json_length));
    } catch (const nlohmann::json::exception& e) {
      fail(std::string("its JSON chunk does not parse: ") + e.what());
    }
    const size_t bin = 20 + json_length;
    if (bin + 8 > bytes_.size() || u32(bin + 4) != 0x004E4942) fail("no binary chunk after the JSON chunk");
    bin_offset_ = bin + 8;
    bin_length_ = std::min<size_t>(u32(bin), bytes_.size() - bin_offset_);
  }

  const nlohmann::json& json() const { return json_; }
  [[noreturn]] void fail(const std::string& what) const { throw InputError(file_ + ": " + what); }

  // Accessor `index` as `components` numbers per element (floats or, with `integers`, unsigned
  // 32-bit integers converted to float exactly up to 2^24).
  template <typename T>
  std::vector<T> read(const nlohmann::json& index, int components) const {
    try {
      const nlohmann::json& a = json_.at("accessors").at(index.get<size_t>());
      const nlohmann::json& view = json_.at("bufferViews").at(a.at("bufferView").get<size_t>());
      const int expected_type = std::is_same_v<T, float> ? 5126 : 5125;
      if (a.at("componentType").get<int>() != expected_type)
        fail("accessor " + index.dump() + " has component type " + a.at("componentType").dump() + ", expected " +
             std::to_string(expected_type));
      static const std::map<std::string, int> sizes = {{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4}};
      const auto type = sizes.find(a.at("type").get<std::string>());
      if (type == sizes.end() || type->second != components)
        fail("accessor " + index.dump() + " is " + a.at("type").dump() + ", expected " + std::to_string(components) +
             " components");
      const size_t count = a.at("count").get<size_t>(), stride = view.value("byteStride", size_t{0});
      if (stride != 0 && stride != components * sizeof(T)) fail("accessor " + index.dump() + " is interleaved");
      const size_t begin = view.value("byteOffset", size_t{0}) + a.value("byteOffset", size_t{0});
      const size_t length = count * components * sizeof(T);
      if (begin + length > bin_length_ || length > view.at("byteLength").get<size_t>())
        fail("accessor " + index.dump() + " runs past its buffer");
      std::vector<T> out(count * components);
      std::memcpy(out.data(), bytes_.data() + bin_offset_ + begin, length);
      return out;
    } catch (const nlohmann::json::exception& e) {
      fail(std::string("accessor ") + index.dump() + ": " + e.what());
    }
  }

 private:
  std::uint32_t u32(size_t at) const {
    std::uint32_t v = 0;
    std::memcpy(&v, bytes_.data() + at, 4);
    return v;
  }
  std::string file_, bytes_;
  nlohmann::json json_;
  size_t bin_offset_ = 0, bin_length_ = 0;
};

// Meshes and frame times from the glb; a mesh's viscosity is its peak per vertex, recovered
// from COLOR_0 (1, 1 - 0.85 s, 1 - 0.9 s) with s the peak over the mesh's largest one.
std::vector<RunMesh> read_glb_meshes(const fs::path& path, std::vector<double>& times) {
  GlbReader glb(path);
  std::vector<RunMesh> meshes;
  try {
    const nlohmann::json& j = glb.json();
    times.clear();
    if (j.contains("animations") && !j["animations"].empty()) {
      const nlohmann::json& samplers = j["animations"][0].at("samplers");
      if (!samplers.empty())
        for (float t : glb.read<float>(samplers[0].at("input"), 1)) times.push_back(t);
    }
    if (times.empty()) times.push_back(0.0);
    const size_t frames = times.size();
    for (const nlohmann::json& node : j.at("nodes")) {
      if (!node.contains("mesh")) continue;
      const nlohmann::json& gm = j.at("meshes").at(node["mesh"].get<size_t>());
      const nlohmann::json& primitive = gm.at("primitives").at(0);
      const nlohmann::json& attributes = primitive.at("attributes");
      RunMesh m;
      m.name = node.value("name", gm.value("name", "mesh" + std::to_string(meshes.size())));
      std::vector<float> base = glb.read<float>(attributes.at("POSITION"), 3);
      m.vertex_count = static_cast<int>(base.size() / 3);
      const size_t n = base.size();
      m.indices = glb.read<std::uint32_t>(primitive.at("indices"), 1);
      for (std::uint32_t i : m.indices)
        if (i >= static_cast<std::uint32_t>(m.vertex_count))
          glb.fail("mesh " + m.name + ": index " + std::to_string(i) + " beyond its " + std::to_string(m.vertex_count) + " vertices");
      if (attributes.contains("TEXCOORD_0")) {
        m.texcoords = glb.read<float>(attributes["TEXCOORD_0"], 2);
        for (size_t i = 1; i < m.texcoords.size(); i += 2) m.texcoords[i] = 1.0f - m.texcoords[i];  // back to v up
      }
      const nlohmann::json targets = primitive.value("targets", nlohmann::json::array());
      if (!targets.empty() && targets.size() + 1 != frames)
        glb.fail("mesh " + m.name + " has " + std::to_string(targets.size()) + " morph targets for " + std::to_string(frames) +
                 " keyed times (expected one per frame after the first)");
      m.frames = targets.empty() ? 1 : static_cast<int>(frames);
      m.positions.reserve(n * m.frames);
      m.positions.insert(m.positions.end(), base.begin(), base.end());
      for (const nlohmann::json& target : targets) {
        const std::vector<float> delta = glb.read<float>(target.at("POSITION"), 3);
        if (delta.size() != n) glb.fail("mesh " + m.name + ": a morph target's size differs from its vertices'");
        for (size_t k = 0; k < n; ++k) m.positions.push_back(base[k] + delta[k]);
      }
      if (attributes.contains("COLOR_0") && gm.contains("extras") && gm["extras"].contains("added_viscosity_peak_N_s_per_m")) {
        const float peak = gm["extras"]["added_viscosity_peak_N_s_per_m"].get<float>();
        const std::vector<float> colour = glb.read<float>(attributes["COLOR_0"], 3);
        m.viscosity.resize(static_cast<size_t>(m.vertex_count));
        for (size_t i = 0; i < m.viscosity.size(); ++i) m.viscosity[i] = std::max(0.0f, (1.0f - colour[3 * i + 1]) / 0.85f * peak);
        m.viscosity_frames = 1;
      }
      meshes.push_back(std::move(m));
    }
  } catch (const nlohmann::json::exception& e) {
    glb.fail(std::string("not laid out as weft writes it: ") + e.what());
  }
  if (meshes.empty()) glb.fail("holds no mesh");
  return meshes;
}

// The time column of energy.csv (one row per frame), or empty when it cannot be read.
std::vector<double> energy_times(const fs::path& path) {
  std::ifstream in(path);
  std::vector<double> times;
  std::string line;
  if (!std::getline(in, line) || line.rfind("time,", 0) != 0) return {};
  while (std::getline(in, line)) {
    char* end = nullptr;
    const double t = std::strtod(line.c_str(), &end);
    if (end == line.c_str() || !std::isfinite(t)) return {};
    times.push_back(t);
  }
  return times;
}

}  // namespace

RunRecording read_run_folder(const std::string& dir_name) {
  const fs::path dir(dir_name);
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw InputError(dir_name + ": no such folder (expected the output folder of `weft run`)");
  const fs::path summary_path = dir / "summary.json";
  if (!fs::is_regular_file(summary_path, ec))
    throw InputError(dir_name + ": not the output folder of a run (no summary.json; `weft run SCENE --out " + dir_name +
                     "` writes one)");
  nlohmann::json summary;
  try {
    summary = nlohmann::json::parse(read_input_file(summary_path.string(), "summary file"));
  } catch (const nlohmann::json::exception& e) {
    throw InputError(summary_path.string() + ": does not parse as JSON: " + e.what());
  }
  const fs::path glb = dir / "animation.glb";
  const bool has_glb = fs::is_regular_file(glb, ec);
  const bool has_frames = fs::is_directory(dir / "frames", ec);
  if (!has_glb && !has_frames)
    throw InputError(dir_name + ": no frames to play (expected animation.glb or frames/frame_NNNNN.obj or .ply; " +
                     "weft run writes them with --format obj, ply or glb)");

  RunRecording rec;
  rec.uv_scale = run_uv_scale(summary, summary_path.string());
  std::vector<double> glb_times;
  if (has_glb) {
    rec.meshes = read_glb_meshes(glb, glb_times);
    rec.positions_source = "glb";
    if (!rec.meshes.front().viscosity.empty()) rec.viscosity_source = "glb";
  }
  if (has_frames) {
    const auto frames = find_run_frames(dir, "weft view");
    if (frames.begin()->first != 0 || frames.rbegin()->first != static_cast<long>(frames.size()) - 1)
      throw InputError((dir / "frames").string() + ": frames numbered " + std::to_string(frames.begin()->first) + " to " +
                       std::to_string(frames.rbegin()->first) + " for " + std::to_string(frames.size()) +
                       " files (expected 0, 1, 2, ... without gaps)");
    const bool ply = frames.begin()->second.cloth.extension() == ".ply";
    std::vector<fs::path> cloth_paths;
    std::map<std::string, std::vector<fs::path>> collider_paths;
    for (const auto& [number, files] : frames) {
      cloth_paths.push_back(files.cloth);
      if (files.colliders.size() != frames.begin()->second.colliders.size())
        throw InputError(files.cloth.string() + ": frame " + std::to_string(number) + " has " +
                         std::to_string(files.colliders.size()) + " colliders' files, frame 0 has " +
                         std::to_string(frames.begin()->second.colliders.size()));
      for (const auto& [name, path] : files.colliders) collider_paths[name].push_back(path);
    }
    if (!has_glb || ply) {
      RunMesh cloth = read_mesh_frames("cloth", cloth_paths);
      if (!has_glb) {
        rec.positions_source = ply ? "ply" : "obj";
        rec.meshes.push_back(std::move(cloth));
        for (const auto& [name, paths] : collider_paths) {
          if (paths.size() != cloth_paths.size())
            throw InputError(paths.front().string() + ": " + name + " has " + std::to_string(paths.size()) + " frames, the cloth " +
                             std::to_string(cloth_paths.size()));
          rec.meshes.push_back(read_mesh_frames(name, paths));
        }
      } else {
        // Positions from the glb, the added viscosity frame by frame from the PLY frames.
        RunMesh& from_glb = rec.meshes.front();
        if (cloth.vertex_count != from_glb.vertex_count || cloth.frames != static_cast<int>(glb_times.size()))
          throw InputError((dir / "frames").string() + ": " + std::to_string(cloth.frames) + " frames of " +
                           std::to_string(cloth.vertex_count) + " vertices, but " + glb.string() + " holds " +
                           std::to_string(glb_times.size()) + " frames of " + std::to_string(from_glb.vertex_count) +
                           " (expected the same run)");
        from_glb.viscosity = std::move(cloth.viscosity);
        from_glb.viscosity_frames = cloth.viscosity_frames;
      }
      if (ply && rec.meshes.front().viscosity_frames > 1) rec.viscosity_source = "ply";
    }
  }

  const size_t frame_count = static_cast<size_t>(rec.meshes.front().frames);
  rec.times = energy_times(dir / "energy.csv");  // in double precision, where the glb's are single
  if (rec.times.size() != frame_count && glb_times.size() == frame_count) rec.times = glb_times;
  if (rec.times.size() != frame_count) {
    const double interval = summary.value("frame_interval", 0.0);
    if (!(interval > 0))
      throw InputError(summary_path.string() + ": no frame_interval > 0, and neither energy.csv nor the glb gives the " +
                       std::to_string(frame_count) + " frames' times");
    rec.times.resize(frame_count);
    for (size_t k = 0; k < frame_count; ++k) rec.times[k] = interval * static_cast<double>(k);
  }
  return rec;
}

}  // namespace weft
