// `weft body`: writes the walking mannequin as OBJ frames and a summary.
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "command.hpp"
#include "weft/body.hpp"
#include "weft/error.hpp"

namespace {

struct BodyOptions {
  std::string motion_file;
  double speed_scale = 0.75;
  double fps = 30.0;
  std::string skinning = "lbs";
  double start_time_s = 0.0;
  std::string out_dir;
};

void write_text_atomically(const std::filesystem::path& path, const std::string& text) {
  const std::filesystem::path temporary = path.string() + ".tmp";
  {
    std::ofstream out(temporary);
    out << text;
    if (!out) throw weft::InputError(path.string() + ": cannot write");
  }
  std::filesystem::rename(temporary, path);
}

void show_progress(int done, int total) {
  constexpr int kWidth = 40;
  const int filled = total > 0 ? done * kWidth / total : kWidth;
  std::fprintf(stderr, "\r[%s%s] %d/%d frames", std::string(filled, '#').c_str(),
               std::string(kWidth - filled, ' ').c_str(), done, total);
  if (done == total) std::fprintf(stderr, "\n");
  std::fflush(stderr);
}

int run_body(const BodyOptions& o) {
  using Clock = std::chrono::steady_clock;
  if (!(o.fps > 0) || !std::isfinite(o.fps))
    throw weft::InputError("--fps must be positive, got " + std::to_string(o.fps));
  if (!(o.speed_scale > 0) || !std::isfinite(o.speed_scale))
    throw weft::InputError("--speed must be positive, got " + std::to_string(o.speed_scale));
  if (o.start_time_s < 0) throw weft::InputError("--start-time must be >= 0");
  weft::BodyColliderSpec spec;
  spec.motion_file = o.motion_file;
  spec.speed = o.speed_scale;
  spec.skinning = o.skinning;
  spec.start_time = o.start_time_s;
  // Everything is loaded and checked before the first file is written.
  const weft::WalkingBody body(spec);

  const std::filesystem::path out_dir(o.out_dir);
  const std::filesystem::path frames_dir = out_dir / "frames";
  std::error_code ec;
  std::filesystem::create_directories(frames_dir, ec);
  if (ec) throw weft::InputError(frames_dir.string() + ": cannot create folder: " + ec.message());

  const int frame_count = static_cast<int>(std::floor(body.duration_s() * o.fps + 1e-9)) + 1;
  const bool bar = isatty(fileno(stderr));
  const int root = 0;
  std::vector<weft::BonePose> poses;
  weft::Points positions;
  double skinning_s = 0.0, lowest_m = INFINITY, highest_m = -INFINITY;
  weft::Vec3 root_first = weft::Vec3::Zero(), root_last = weft::Vec3::Zero();
  const auto start = Clock::now();
  for (int f = 0; f < frame_count; ++f) {
    const double t = f / o.fps;
    body.bone_poses(t, poses);
    const auto skin_start = Clock::now();
    body.skin(poses, positions);
    skinning_s += std::chrono::duration<double>(Clock::now() - skin_start).count();
    lowest_m = std::min(lowest_m, positions.col(1).minCoeff());
    highest_m = std::max(highest_m, positions.col(1).maxCoeff());
    const weft::Vec3 hips = poses[root].apply(body.rig().head_rest[root]);
    if (f == 0) root_first = hips;
    root_last = hips;
    char name[64];
    std::snprintf(name, sizeof name, "body_%05d.obj", f);
    weft::write_obj((frames_dir / name).string(), positions, body.triangles());
    if (bar)
      show_progress(f + 1, frame_count);
    else if ((f + 1) * 4 / frame_count != f * 4 / frame_count)
      std::fprintf(stderr, "weft body: %d/%d frames\n", f + 1, frame_count);
  }
  const double wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  const weft::Vec3 travel = root_last - root_first;

  nlohmann::json summary = {
      {"frames", frame_count},
      {"fps", o.fps},
      {"duration_s", (frame_count - 1) / o.fps},
      {"motion_duration_s", body.duration_s()},
      {"motion", o.motion_file.empty() ? weft::default_motion_file() : o.motion_file},
      {"speed_scale", o.speed_scale},
      {"start_time_s", o.start_time_s},
      {"skinning", o.skinning},
      {"vertices", body.vertex_count()},
      {"triangles", body.triangles().rows()},
      {"distance_walked_m", std::hypot(travel.x(), travel.z())},
      {"travel_m", {travel.x(), travel.y(), travel.z()}},
      {"lowest_point_m", lowest_m},
      {"highest_point_m", highest_m},
      {"skinning_ms_per_frame", 1e3 * skinning_s / frame_count},
      {"wall_time_s", wall_s},
  };
  write_text_atomically(out_dir / "summary.json", summary.dump(2) + "\n");
  std::printf("weft body: %d frames (%.2f s at %.3gx, %s) in %s/frames; walked %.2f m; "
              "skinning %.3f ms/frame; wall %.2f s\n",
              frame_count, (frame_count - 1) / o.fps, o.speed_scale, o.skinning.c_str(),
              o.out_dir.c_str(), summary["distance_walked_m"].get<double>(),
              summary["skinning_ms_per_frame"].get<double>(), wall_s);
  return weft::app::kExitOk;
}

weft::app::RegisterCommand reg{
    {"", "body", "Write the walking mannequin as OBJ frames",
     [](CLI::App& sub) {
       auto o = std::make_shared<BodyOptions>();
       sub.add_option("--motion", o->motion_file, "BVH motion file (default: the shipped CMU walk)");
       sub.add_option("--speed", o->speed_scale, "Playback speed scale")->capture_default_str();
       sub.add_option("--fps", o->fps, "Frames written per second")->capture_default_str();
       sub.add_option("--skinning", o->skinning, "lbs (linear blend) or dqs (dual quaternion)")
           ->capture_default_str();
       sub.add_option("--start-time", o->start_time_s, "Seconds into the motion to start at")
           ->capture_default_str();
       sub.add_option("--out", o->out_dir, "Output folder")->required();
       return std::function<int()>([o] { return run_body(*o); });
     },
     50}};

}  // namespace
