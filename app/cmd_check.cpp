// `weft check DIR`: counts, in every frame a run wrote to DIR/frames, the pairs of cloth
// triangles that intersect and the cloth-body pairs that do (docs/collisions.md, "Checking").
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "collision/frame_check.hpp"
#include "command.hpp"
#include "weft/body.hpp"
#include "weft/error.hpp"

namespace fs = std::filesystem;

namespace {

struct CheckArgs {
  std::string dir;
  bool json = false;
  int examples = 3;
};

struct Mesh {
  std::vector<double> xyz;
  std::vector<std::array<int, 3>> triangles;
};

Mesh read_obj_mesh(const fs::path& path) {
  const weft::ObjMesh obj = weft::read_obj(path.string());
  Mesh m;
  m.xyz.assign(obj.positions.data(), obj.positions.data() + obj.positions.size());
  m.triangles = weft::triangle_list(obj.triangles);
  return m;
}

// The ASCII PLY frames of `weft run --frame-format ply`: a vertex element whose properties
// include x, y and z, then a face element of vertex index lists (polygons split as fans).
Mesh read_ply_mesh(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw weft::InputError(path.string() + ": cannot read");
  const std::string name = path.string();
  std::string line;
  int line_no = 0;
  auto fail = [&](const std::string& what) -> weft::InputError {
    return weft::InputError(name + ":" + std::to_string(line_no) + ": " + what);
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
  if (!ascii) throw fail("weft check reads ASCII PLY only (format ascii 1.0)");
  if (vertices < 0 || faces < 0) throw fail("the header needs a vertex and a face element");
  int axis_column[3] = {-1, -1, -1};
  for (size_t k = 0; k < vertex_properties.size(); ++k)
    for (int axis = 0; axis < 3; ++axis)
      if (vertex_properties[k] == std::string(1, "xyz"[axis])) axis_column[axis] = static_cast<int>(k);
  if (axis_column[0] < 0 || axis_column[1] < 0 || axis_column[2] < 0)
    throw fail("the vertex element needs properties x, y and z");
  Mesh m;
  m.xyz.resize(3 * static_cast<size_t>(vertices));
  std::vector<double> values(vertex_properties.size());
  for (long i = 0; i < vertices; ++i) {
    if (!std::getline(in, line)) throw fail("the file ends after " + std::to_string(i) + " of " +
                                            std::to_string(vertices) + " vertices");
    ++line_no;
    std::istringstream words(line);
    for (double& v : values)
      if (!(words >> v) || !std::isfinite(v)) throw fail("expected " + std::to_string(values.size()) + " numbers, got '" + line + "'");
    for (int axis = 0; axis < 3; ++axis) m.xyz[3 * i + axis] = values[axis_column[axis]];
  }
  for (long f = 0; f < faces; ++f) {
    if (!std::getline(in, line)) throw fail("the file ends after " + std::to_string(f) + " of " +
                                            std::to_string(faces) + " faces");
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

struct FrameFiles {
  fs::path cloth;
  std::map<std::string, fs::path> bodies;  ///< the colliders' surfaces, by name ("body0", "collider1")
};

// The frames of DIR/frames by number; an InputError for a folder that holds none.
std::map<long, FrameFiles> find_frames(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw weft::InputError(dir.string() + ": no such folder (expected the output folder of `weft run`)");
  const fs::path frames = dir / "frames";
  if (!fs::is_directory(frames, ec))
    throw weft::InputError(frames.string() + ": no such folder (weft check reads the frames of `weft run`: " +
                           "DIR/frames/frame_NNNNN.obj or .ply, DIR/frames/body<k>_NNNNN.obj and collider<k>_NNNNN.obj)");
  static const std::regex cloth(R"(frame_(\d{5,})\.(obj|ply))"), body(R"(((?:body|collider)\d+)_(\d{5,})\.obj)");
  std::map<long, FrameFiles> found;
  for (const auto& e : fs::directory_iterator(frames)) {
    const std::string name = e.path().filename().string();
    std::smatch m;
    if (std::regex_match(name, m, cloth)) {
      FrameFiles& f = found[std::stol(m[1])];
      if (!f.cloth.empty())
        throw weft::InputError(e.path().string() + ": frame " + m[1].str() + " is also in " + f.cloth.string() +
                               " (expected one file per frame)");
      f.cloth = e.path();
    } else if (std::regex_match(name, m, body)) {
      found[std::stol(m[2])].bodies[m[1].str()] = e.path();
    }
  }
  for (const auto& [number, f] : found)
    if (f.cloth.empty())
      throw weft::InputError(f.bodies.begin()->second.string() + ": a body frame without its cloth frame (expected " +
                             (frames / "frame_").string() + std::to_string(number) + ".obj or .ply)");
  if (found.empty())
    throw weft::InputError(frames.string() + ": no frames (expected frame_NNNNN.obj or frame_NNNNN.ply files)");
  return found;
}

std::string pairs_text(const std::vector<std::array<int, 2>>& pairs, const char* first, const char* second) {
  std::string s;
  for (const auto& [i, j] : pairs)
    s += (s.empty() ? "" : ", ") + std::string(first) + " " + std::to_string(i) + " x " + second + " " + std::to_string(j);
  return s;
}

int run_check(const CheckArgs& a) {
  const auto frames = find_frames(a.dir);
  weft::FrameChecker checker(static_cast<size_t>(std::max(0, a.examples)));
  nlohmann::json per_frame = nlohmann::json::array();
  size_t total = 0, total_self = 0, total_body = 0, total_at_crossings = 0, frames_with = 0, worst_count = 0;
  long worst_frame = -1;
  for (const auto& [number, files] : frames) {
    const Mesh cloth = files.cloth.extension() == ".ply" ? read_ply_mesh(files.cloth) : read_obj_mesh(files.cloth);
    std::vector<Mesh> bodies;
    for (const auto& [k, path] : files.bodies) bodies.push_back(read_obj_mesh(path));
    std::vector<weft::FrameMesh> body_views;
    for (const Mesh& b : bodies) body_views.push_back({b.xyz.data(), &b.triangles});
    const weft::FrameIntersections r = checker.check({cloth.xyz.data(), &cloth.triangles}, body_views);
    const size_t count = r.count();
    size_t body_count = 0, at_crossings = 0;
    for (size_t k = 0; k < bodies.size(); ++k) {
      body_count += r.cloth_body[k].count;
      at_crossings += r.cloth_body_at_body_crossings[k];
    }
    total += count;
    total_self += r.cloth_self.count;
    total_body += body_count;
    total_at_crossings += at_crossings;
    frames_with += count > 0;
    if (count > worst_count) worst_count = count, worst_frame = number;
    nlohmann::json j;
    j["frame"] = number;
    j["cloth_self"] = r.cloth_self.count;
    j["cloth_self_examples"] = r.cloth_self.examples;
    j["cloth_body"] = body_count;
    j["cloth_body_at_body_crossings"] = at_crossings;
    nlohmann::json body_examples = nlohmann::json::array();
    for (size_t k = 0; k < bodies.size(); ++k)
      for (const auto& [c, b] : r.cloth_body[k].examples)
        body_examples.push_back({{"collider", std::next(files.bodies.begin(), static_cast<long>(k))->first},
                                 {"cloth_triangle", c}, {"body_triangle", b}});
    j["cloth_body_examples"] = body_examples;
    per_frame.push_back(j);
    if (!a.json) {
      char line[160];
      std::snprintf(line, sizeof line, "frame %05ld: %zu cloth self-intersections, %zu cloth-body", number,
                    r.cloth_self.count, body_count);
      std::cout << line;
      if (at_crossings > 0) std::cout << " (and " << at_crossings << " at the body's own crossings)";
      if (!r.cloth_self.examples.empty())
        std::cout << "; e.g. " << pairs_text(r.cloth_self.examples, "cloth", "cloth");
      for (size_t k = 0; k < bodies.size(); ++k)
        if (!r.cloth_body[k].examples.empty())
          std::cout << "; e.g. " << pairs_text(r.cloth_body[k].examples, "cloth", std::next(files.bodies.begin(), static_cast<long>(k))->first.c_str());
      std::cout << "\n";
    }
  }
  if (a.json) {
    nlohmann::json j;
    j["frames"] = frames.size();
    j["per_frame"] = per_frame;
    j["total"] = total;
    j["cloth_self_total"] = total_self;
    j["cloth_body_total"] = total_body;
    j["cloth_body_at_body_crossings_total"] = total_at_crossings;
    j["frames_with_intersections"] = frames_with;
    j["worst_frame"] = worst_frame >= 0 ? nlohmann::json(worst_frame) : nlohmann::json(nullptr);
    j["worst_count"] = worst_count;
    std::cout << j.dump(2) << "\n";
  } else if (total == 0) {
    std::cout << "no intersections in " << frames.size() << " frames";
    if (total_at_crossings > 0) std::cout << " (" << total_at_crossings << " cloth-body pairs at the body's own crossings)";
    std::cout << "\n";
  } else {
    std::cout << "total: " << total << " intersecting pairs (" << total_self << " cloth self, " << total_body
              << " cloth-body) in " << frames_with << " of " << frames.size() << " frames; worst frame " << worst_frame
              << " with " << worst_count << "\n";
  }
  return total == 0 ? weft::app::kExitOk : weft::app::kExitIntersections;
}

weft::app::RegisterCommand reg{{"", "check", "Count intersecting triangle pairs in every frame of a run's output folder",
  [](CLI::App& sub) {
    auto a = std::make_shared<CheckArgs>();
    sub.add_option("dir", a->dir, "Output folder of `weft run` (reads DIR/frames)")->required();
    sub.add_flag("--json", a->json, "Print the counts as JSON instead of text");
    sub.add_option("--examples", a->examples, "Intersecting pairs listed per frame and kind (default 3)")
        ->check(CLI::NonNegativeNumber);
    sub.footer(
        "Reads DIR/frames/frame_NNNNN.obj (or .ply) and the body frames DIR/frames/body<k>_NNNNN.obj, and counts\n"
        "per frame the pairs of cloth triangles that intersect and share no vertex, and the pairs of a cloth and a\n"
        "body triangle that intersect (touching counts). Cloth-body pairs at triangles where the body crosses itself\n"
        "(or next to them) are reported apart and not counted: no cloth can avoid those. Triangles are numbered\n"
        "from 0 in file order.\n"
        "Exit status: 0 no frame has an intersection, 5 some frame has one, 2 a missing folder, no frames or a\n"
        "frame that cannot be read (the message names the file and line).");
    return std::function<int()>([a] { return run_check(*a); });
  }, 20}};

}  // namespace
