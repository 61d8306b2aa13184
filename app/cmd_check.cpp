// `weft check DIR`: counts, in every frame a run wrote to DIR/frames, the pairs of cloth
// triangles that intersect and the cloth-body pairs that do (docs/collision-geometry.md,
// "Checking").
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>

#include "weft/frame_check.hpp"
#include "command.hpp"
#include "weft/run_frames.hpp"
#include "weft/error.hpp"

namespace fs = std::filesystem;

namespace {

struct CheckArgs {
  std::string dir;
  bool json = false;
  int examples = 3;
};

std::string pairs_text(const std::vector<std::array<int, 2>>& pairs, const char* first, const char* second) {
  std::string s;
  for (const auto& [i, j] : pairs)
    s += (s.empty() ? "" : ", ") + std::string(first) + " " + std::to_string(i) + " x " + second + " " + std::to_string(j);
  return s;
}

int run_check(const CheckArgs& a) {
  const auto frames = weft::find_run_frames(a.dir, "weft check");
  weft::FrameChecker checker(static_cast<size_t>(std::max(0, a.examples)));
  nlohmann::json per_frame = nlohmann::json::array();
  size_t total = 0, total_self = 0, total_body = 0, total_at_crossings = 0, frames_with = 0, worst_count = 0;
  long worst_frame = -1;
  for (const auto& [number, files] : frames) {
    const weft::RunFrameMesh cloth = weft::read_frame_mesh(files.cloth);
    std::vector<weft::RunFrameMesh> bodies;
    for (const auto& [k, path] : files.colliders) bodies.push_back(weft::read_frame_mesh(path));
    std::vector<weft::FrameMesh> body_views;
    for (const weft::RunFrameMesh& b : bodies) body_views.push_back({b.xyz.data(), &b.triangles});
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
        body_examples.push_back({{"collider", std::next(files.colliders.begin(), static_cast<long>(k))->first},
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
          std::cout << "; e.g. " << pairs_text(r.cloth_body[k].examples, "cloth", std::next(files.colliders.begin(), static_cast<long>(k))->first.c_str());
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
