// `weft render DIR --out IMG_DIR`: pictures of a run without a screen (docs/render.md). Reads
// the frames `weft run` wrote to DIR/frames, draws them with the software rasteriser of
// src/render/ and writes PNG stills, or with --video an MP4 through ffmpeg.
#include <signal.h>
#include <sys/wait.h>

#include <array>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <unistd.h>

#include "command.hpp"
#include "weft/run_frames.hpp"
#include "progress.hpp"
#include "weft/render/picture.hpp"
#include "weft/atomic_file.hpp"
#include "weft/error.hpp"

namespace fs = std::filesystem;
using weft::InputError;
using weft::Vec2;
using weft::Vec3;
namespace render = weft::render;

namespace {

struct RenderArgs {
  std::string dir, out, frames, size = "960x720", camera, color = "none";
  std::string beside;  ///< a second run drawn to the right of the first, frame by frame
  std::string labels;  ///< "LEFT,RIGHT" over the two halves (default: the folders' names)
  bool video = false, no_ground = false, no_caption = false, follow = false;
  std::optional<double> fps;
  int samples = 3;
  std::optional<double> uv_scale;  ///< default: the run's, from summary.json
};

constexpr int kDefaultStills = 4;
constexpr int kColourBarSteps = 16;  // the colour bar's samples of a ramp, interpolated between

// "WxH", each in [16, 8192].
std::pair<int, int> parse_size(const std::string& text, bool video) {
  int w = 0, h = 0;
  char x = 0, extra = 0;
  std::istringstream in(text);
  if (!(in >> w >> x >> h) || x != 'x' || (in >> extra) || w < 16 || h < 16 || w > 8192 || h > 8192)
    throw InputError("--size '" + text + "': expected WIDTHxHEIGHT in pixels, each from 16 to 8192 (e.g. 960x720)");
  if (video && (w % 2 || h % 2))
    throw InputError("--size '" + text + "': a video (H.264, yuv420p) needs an even width and height");
  return {w, h};
}

// "ex,ey,ez,tx,ty,tz[,fov]".
render::Camera parse_camera(const std::string& text) {
  std::vector<double> v;
  std::stringstream in(text);
  std::string item;
  const std::string expected =
      "expected eye_x,eye_y,eye_z,target_x,target_y,target_z[,fov_deg] in metres and degrees (e.g. 1.2,1.5,2.5,0,0.8,0,30)";
  while (std::getline(in, item, ',')) {
    size_t used = 0;
    double value = 0;
    try {
      value = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || item.find_first_not_of(" \t", used) != std::string::npos || !std::isfinite(value))
      throw InputError("--camera '" + text + "': '" + item + "' is not a number; " + expected);
    v.push_back(value);
  }
  if (v.size() != 6 && v.size() != 7)
    throw InputError("--camera '" + text + "': " + std::to_string(v.size()) + " numbers; " + expected);
  render::Camera c;
  c.eye = Vec3(v[0], v[1], v[2]);
  c.target = Vec3(v[3], v[4], v[5]);
  if (v.size() == 7) c.fov_deg = v[6];
  if (!(c.fov_deg >= 1 && c.fov_deg <= 170))
    throw InputError("--camera '" + text + "': field of view " + std::to_string(c.fov_deg) + " degrees; expected 1 to 170");
  const Vec3 d = c.target - c.eye;
  if (!(d.norm() > 0)) throw InputError("--camera '" + text + "': the eye and the target are the same point");
  if (d.normalized().cross(Vec3::UnitY()).norm() < 1e-6)
    throw InputError("--camera '" + text + "': the view is straight up or down (Y is the picture's up); tilt it a little");
  return c;
}

// "all", or a comma-separated list of frame numbers N and ranges A-B, each a frame the run has.
std::vector<long> parse_frames(const std::string& text, const std::map<long, weft::RunFrameFiles>& have) {
  const long first = have.begin()->first, last = have.rbegin()->first;
  const std::string range = "the run has frames " + std::to_string(first) + " to " + std::to_string(last);
  std::vector<long> out;
  if (text == "all") {
    for (const auto& [n, f] : have) out.push_back(n);
    return out;
  }
  auto number = [&](const std::string& item, const std::string& s) {
    size_t used = 0;
    long value = -1;
    try {
      value = std::stol(s, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (s.empty() || used != s.size() || value < 0)
      throw InputError("--frames '" + text + "': '" + item + "' is not a frame number or a range A-B (expected a " +
                       "comma-separated list such as 0,50,100 or 0-20, or all)");
    return value;
  };
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    const size_t dash = item.find('-');
    const long a = number(item, item.substr(0, dash));
    const long b = dash == std::string::npos ? a : number(item, item.substr(dash + 1));
    if (b < a) throw InputError("--frames '" + text + "': the range '" + item + "' runs backwards");
    for (long n = a; n <= b; ++n) {
      if (!have.count(n)) throw InputError("--frames '" + text + "': no frame " + std::to_string(n) + " (" + range + ")");
      out.push_back(n);
    }
  }
  if (out.empty()) throw InputError("--frames '" + text + "': no frames listed (" + range + ")");
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

// kDefaultStills frames spread evenly from the first to the last.
std::vector<long> spread_frames(const std::map<long, weft::RunFrameFiles>& have) {
  std::vector<long> all;
  for (const auto& [n, f] : have) all.push_back(n);
  std::vector<long> out;
  for (int k = 0; k < kDefaultStills; ++k) {
    const size_t i = static_cast<size_t>(std::lround(static_cast<double>(k) * static_cast<double>(all.size() - 1) / (kDefaultStills - 1)));
    if (out.empty() || out.back() != all[i]) out.push_back(all[i]);
  }
  return out;
}

// A plane collider's surface: a flat quad (4 vertices, 2 triangles).
bool is_plane(const weft::RunFrameMesh& m) {
  if (m.vertex_count() != 4 || m.triangles.size() != 2) return false;
  const Vec3 p0(m.xyz[0], m.xyz[1], m.xyz[2]);
  auto p = [&](int i) -> Vec3 { return Vec3(m.xyz[3 * i], m.xyz[3 * i + 1], m.xyz[3 * i + 2]) - p0; };
  const Vec3 n = p(1).cross(p(2));
  return n.norm() > 0 && std::abs(n.normalized().dot(p(3))) < 1e-9 * (1 + p(3).norm());
}
bool is_horizontal_plane(const weft::RunFrameMesh& m) {
  if (!is_plane(m)) return false;
  for (int i = 1; i < 4; ++i)
    if (std::abs(m.xyz[3 * i + 1] - m.xyz[1]) > 1e-9) return false;
  return true;
}

std::string format_number(const char* format, double value) {
  char text[64];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

bool ffmpeg_on_path() { return std::system("command -v ffmpeg > /dev/null 2>&1") == 0; }

// What the first pass over the frames learns: the framing, the ground, the colour maps' range.
struct RunSurvey {
  render::Bounds framed;  ///< the cloth and the colliders other than planes, over every frame
  std::map<long, render::Bounds> framed_per_frame;  ///< the same for each frame (--follow)
  render::Bounds all;
  std::optional<double> horizontal_plane_y;
  double viscosity_peak = 0;
  std::optional<render::StrainScaleSampler> strain;  ///< every frame's vertex strain (render::vertex_strain)
  double strain_scale = 0;                           ///< render::strain_scale over them
};

// The frames to draw: DIR's, and with --beside a second run's, with the two runs' labels.
struct RenderFrames {
  std::map<long, weft::RunFrameFiles> files, beside_files;
  std::vector<long> selected;
  std::array<std::string, 2> labels;
  int panels = 1;
};

RenderFrames choose_frames(const RenderArgs& a) {
  RenderFrames r;
  r.files = weft::find_run_frames(fs::path(a.dir), "weft render");
  r.selected = !a.frames.empty() ? parse_frames(a.frames, r.files)
               : a.video         ? parse_frames("all", r.files)
                                 : spread_frames(r.files);
  // A second run beside the first: the same frames, framed and coloured alike.
  if (!a.beside.empty()) {
    r.beside_files = weft::find_run_frames(fs::path(a.beside), "weft render --beside");
    for (long number : r.selected)
      if (!r.beside_files.count(number))
        throw InputError("--beside " + a.beside + ": no frame " + std::to_string(number) + " (it has frames " +
                         std::to_string(r.beside_files.begin()->first) + " to " +
                         std::to_string(r.beside_files.rbegin()->first) + "; choose frames both runs have with --frames)");
    auto name = [](const std::string& d) {
      const fs::path p = fs::path(d).lexically_normal();
      return (p.has_filename() ? p.filename() : p.parent_path().filename()).string();
    };
    r.labels = {name(a.dir), name(a.beside)};
    if (!a.labels.empty()) {
      const size_t comma = a.labels.find(',');
      if (comma == std::string::npos || a.labels.find(',', comma + 1) != std::string::npos)
        throw InputError("--labels '" + a.labels + "': expected LEFT,RIGHT (two labels, one comma)");
      r.labels = {a.labels.substr(0, comma), a.labels.substr(comma + 1)};
    }
    // The bitmap font has lowercase letters only.
    for (std::string& text : r.labels)
      for (char& ch : text) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  } else if (!a.labels.empty()) {
    throw InputError("--labels: only with --beside (they name the two runs drawn side by side)");
  }
  r.panels = a.beside.empty() ? 1 : 2;
  return r;
}

// What the run's summary.json gives: its frame interval, for the captions' times and the
// video's rate, and the metres per unit of its texture coordinates, for the strain.
struct RunTiming {
  std::optional<double> frame_interval, fps;
  double uv_scale = 1;
};

RunTiming read_run_timing(const RenderArgs& a) {
  RunTiming t;
  t.uv_scale = a.uv_scale.value_or(1.0);
  const fs::path summary_path = fs::path(a.dir) / "summary.json";
  if (std::ifstream in(summary_path); in) {
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(in);
    } catch (const nlohmann::json::exception& e) {
      throw InputError(summary_path.string() + ": not JSON (" + e.what() + ")");
    }
    if (j.contains("frame_interval") && j["frame_interval"].is_number() && j["frame_interval"].get<double>() > 0)
      t.frame_interval = j["frame_interval"].get<double>();
    if (!a.uv_scale && a.color == "strain") t.uv_scale = weft::run_uv_scale(j, summary_path.string());
  }
  t.fps = a.fps;
  if (!t.fps && t.frame_interval) t.fps = 1 / *t.frame_interval;
  if (a.video && !t.fps)
    throw InputError(summary_path.string() + ": missing or without frame_interval; give the video's rate with --fps");
  if (a.video && !ffmpeg_on_path())
    throw InputError("ffmpeg not found on the PATH: weft render --video pipes its frames into ffmpeg (Debian: apt-get "
                     "install ffmpeg, or make deps)");
  return t;
}

// The progress over both passes: every frame read once, then every panel drawn.
struct RenderProgress {
  weft::app::Progress bar{"render"};
  size_t done = 0, work = 0;
  void step() { bar.update(static_cast<double>(++done) / static_cast<double>(work)); }
};

// First pass: every frame is read (so that a bad one stops the command before anything is
// written) for the framing over the whole run and the colour maps' range.
RunSurvey survey_frames(const RenderArgs& a, const RenderFrames& frames, double uv_scale, RenderProgress& progress) {
  RunSurvey survey;
  std::vector<std::pair<long, const weft::RunFrameFiles*>> surveyed;
  for (const auto& [number, f] : frames.files) surveyed.emplace_back(number, &f);
  for (const auto& [number, f] : frames.beside_files) surveyed.emplace_back(number, &f);
  // The strain's percentile sampler is sized for the frames of both runs.
  const size_t frames_surveyed = surveyed.size();
  for (const auto& [number, fp] : surveyed) {
    const weft::RunFrameFiles& f = *fp;
    const weft::RunFrameMesh cloth = weft::read_frame_mesh(f.cloth);
    const render::Bounds cb = render::bounds_of(cloth.xyz);
    survey.framed.add(cb);
    survey.framed_per_frame[number].add(cb);
    survey.all.add(cb);
    if (a.color == "viscosity") {
      if (cloth.added_viscosity.empty())
        throw InputError(f.cloth.string() + ": --color viscosity reads the added viscosity of PLY frames " +
                         "(weft run --format ply); this frame has none");
      for (double v : cloth.added_viscosity) survey.viscosity_peak = std::max(survey.viscosity_peak, v);
    }
    if (a.color == "strain") {
      if (cloth.corner_texcoords.empty())
        throw InputError(f.cloth.string() + ": --color strain needs the pattern coordinates of OBJ frames' texture " +
                         "coordinates (weft run --format obj); this frame has none");
      const std::vector<double> strain = render::vertex_strain(cloth.xyz, cloth.triangles, cloth.corner_texcoords, uv_scale);
      // As many values in all as the viewer's (frames x vertices), so that it samples the same ones.
      if (!survey.strain) survey.strain.emplace(frames_surveyed * strain.size());
      survey.strain->add(strain);
    }
    for (const auto& [name, path] : f.colliders) {
      const weft::RunFrameMesh body = weft::read_frame_mesh(path);
      const render::Bounds bb = render::bounds_of(body.xyz);
      survey.all.add(bb);
      if (is_horizontal_plane(body)) {
        survey.horizontal_plane_y = survey.horizontal_plane_y ? std::min(*survey.horizontal_plane_y, body.xyz[1]) : body.xyz[1];
      } else if (!is_plane(body)) {
        survey.framed.add(bb);
        survey.framed_per_frame[number].add(bb);
      }
    }
    progress.step();
  }
  return survey;
}

// The pictures' camera, ground and size; with --follow, where the camera moves each frame.
struct Framing {
  render::PictureOptions options;
  std::map<long, Vec3> follow_centre;  ///< per frame, with --follow: the centre its camera frames
  render::Camera base_camera;          ///< the camera at follow_origin
  Vec3 follow_origin = Vec3::Zero();

  /// Moves the camera to frame `number`'s place (--follow).
  void follow(long number) {
    if (!follow_centre.count(number)) return;
    const Vec3 shift = follow_centre.at(number) - follow_origin;
    options.camera.eye = base_camera.eye + shift;
    options.camera.target = base_camera.target + shift;
  }
};

Framing frame_pictures(const RenderArgs& a, const RunSurvey& survey, int width, int height,
                       const std::optional<render::Camera>& given_camera, long first_frame) {
  Framing fr;
  render::PictureOptions& options = fr.options;
  options.width = width;
  options.height = height;
  options.samples_per_side = a.samples;
  // The ground: a horizontal plane collider where there is one, else y = 0 or below everything.
  if (!a.no_ground)
    options.ground_y = survey.horizontal_plane_y ? *survey.horizontal_plane_y : std::min(0.0, survey.framed.lo.y());
  // The framing reaches down towards the ground (by at most half the objects' height), so
  // that the cloth is seen above it.
  const auto towards_ground = [&](render::Bounds b) {
    if (options.ground_y) {
      const double reach = std::max(*options.ground_y, b.lo.y() - 0.5 * (b.hi.y() - b.lo.y()));
      b.add(Vec3(b.centre().x(), reach, b.centre().z()));
    }
    return b;
  };
  const render::Bounds framed = towards_ground(survey.framed);
  options.camera = given_camera ? *given_camera : render::frame_camera(framed, width, height);
  // --follow: the camera keeps its view and moves with the objects, framing the largest of the
  // frames' boxes (each reaching towards the ground as above) about its own centre.
  if (a.follow) {
    render::Bounds extent;
    for (const auto& [number, box] : survey.framed_per_frame) {
      if (box.empty()) continue;
      const render::Bounds b = towards_ground(box);
      fr.follow_centre[number] = b.centre();
      extent.add(b.lo - b.centre());
      extent.add(b.hi - b.centre());
    }
    if (!given_camera && !extent.empty()) options.camera = render::frame_camera(extent, width, height);
  }
  // A camera given is where it is at the first frame drawn; the framing one is about the origin.
  fr.base_camera = options.camera;
  fr.follow_origin =
      given_camera && fr.follow_centre.count(first_frame) ? fr.follow_centre.at(first_frame) : Vec3(Vec3::Zero());
  options.scene_bounds = survey.framed;
  return fr;
}

// The colour map's bar (--color viscosity or strain), its range printed; sets the strain's
// scale in the survey.
void add_colour_bar(const RenderArgs& a, RunSurvey& survey, double uv_scale, render::PictureOptions& options) {
  if (a.color == "viscosity") {
    render::ColourBar bar{"added viscosity N s/m", "0", format_number("%.3g", survey.viscosity_peak), {}};
    for (int k = 0; k <= kColourBarSteps; ++k) bar.stops.push_back(render::sequential_colour(static_cast<double>(k) / kColourBarSteps));
    options.colour_bar = bar;
    std::printf("colour scale: added viscosity 0 to %.6g N s/m\n", survey.viscosity_peak);
  } else if (a.color == "strain") {
    // The viewer's scale: a percentile of |strain| over every vertex and frame, so that a few
    // vertices stretched far (a pinned corner) do not wash out the rest.
    survey.strain_scale = survey.strain ? survey.strain->scale() : 0;
    const double m = survey.strain_scale;
    render::ColourBar bar{"strain: largest principal stretch - 1 (%)", format_number("%.3g", -100 * m),
                          "+" + format_number("%.3g", 100 * m), {}};
    for (int k = 0; k <= kColourBarSteps; ++k)
      bar.stops.push_back(render::diverging_colour(2.0 * static_cast<double>(k) / kColourBarSteps - 1));
    options.colour_bar = bar;
    std::printf("colour scale: strain -%.6g%% to +%.6g%% (texture coordinates times uv_scale %.6g)\n", 100 * m, 100 * m, uv_scale);
  }
}

// One run's frame `number` as a picture: the cloth (in the colour map chosen) and the colliders,
// the ground standing for a horizontal plane collider; the caption set in `options`.
weft::RgbImage draw_frame(const RenderArgs& a, const weft::RunFrameFiles& f, long number, const RunSurvey& survey,
                          const RunTiming& timing, render::PictureOptions& options) {
  const weft::RunFrameMesh cloth = weft::read_frame_mesh(f.cloth);
  std::vector<weft::RunFrameMesh> colliders;
  for (const auto& [name, path] : f.colliders) {
    weft::RunFrameMesh body = weft::read_frame_mesh(path);
    // The ground stands for a horizontal plane collider.
    if (!(options.ground_y && is_horizontal_plane(body))) colliders.push_back(std::move(body));
  }
  std::vector<render::PictureMesh> meshes;
  render::PictureMesh cloth_mesh{&cloth.xyz, &cloth.triangles, render::Surface::kCloth, {}, {}};
  if (a.color == "viscosity") {
    for (double v : cloth.added_viscosity)
      cloth_mesh.vertex_colours.push_back(render::sequential_colour(survey.viscosity_peak > 0 ? v / survey.viscosity_peak : 0));
  } else if (a.color == "strain") {
    const double scale = survey.strain_scale > 0 ? 1 / survey.strain_scale : 0;
    for (double s : render::vertex_strain(cloth.xyz, cloth.triangles, cloth.corner_texcoords, timing.uv_scale))
      cloth_mesh.vertex_colours.push_back(render::diverging_colour(s * scale));
  }
  meshes.push_back(std::move(cloth_mesh));
  for (const auto& body : colliders) meshes.push_back({&body.xyz, &body.triangles, render::Surface::kCollider, {}, {}});
  if (!a.no_caption)
    options.caption = (timing.frame_interval
                           ? "t = " + format_number("%.2f", static_cast<double>(number) * *timing.frame_interval) + " s   "
                           : "") +
                      "frame " + std::to_string(number);
  return render::render_picture(meshes, options);
}

// The two runs side by side, each labelled at its top left.
weft::RgbImage side_by_side(const weft::RgbImage& left, const weft::RgbImage& right, int width, int height,
                            const std::array<std::string, 2>& labels) {
  weft::RgbImage both(2 * width, height);
  for (int y = 0; y < height; ++y) {
    std::memcpy(both.at(0, y), left.at(0, y), 3 * static_cast<size_t>(width));
    std::memcpy(both.at(width, y), right.at(0, y), 3 * static_cast<size_t>(width));
  }
  const int scale = std::max(2, height / 240);
  for (int k = 0; k < 2; ++k) render::draw_label(both, k * width + 4 * scale, 4 * scale, labels[k], scale, {40, 40, 40});
  return both;
}

// Where the pictures go: PNG files (frame_NNNNN.png), or ffmpeg's input, which writes a
// temporary file renamed into place. Each step returns an exit status, kExitOk to go on; a
// failure is said on stderr.
class PictureOutput {
 public:
  explicit PictureOutput(fs::path out) : out_(std::move(out)) {}
  fs::path video_path() const { return out_ / "render.mp4"; }

  int open(const RenderArgs& a, int width, int height, double fps) {
    std::error_code ec;
    fs::create_directories(out_, ec);
    if (ec) {
      std::cerr << "weft: error: cannot create " << out_.string() << ": " << ec.message() << "\n";
      return weft::app::kExitOutputFailed;
    }
    if (!a.video) return weft::app::kExitOk;
    const std::string command = "ffmpeg -hide_banner -loglevel error -y -f rawvideo -pix_fmt rgb24 -s " +
                                std::to_string(width) + "x" + std::to_string(height) + " -framerate " +
                                format_number("%.6g", fps) + " -i - -an -c:v libx264 -preset medium -crf 20 " +
                                "-pix_fmt yuv420p -movflags +faststart -f mp4 " + shell_quote(video_temporary_.string());
    ::signal(SIGPIPE, SIG_IGN);  // a failed ffmpeg is reported by a failed write, not a signal
    pipe_ = ::popen(command.c_str(), "w");
    if (!pipe_) {
      std::cerr << "weft: error: cannot start ffmpeg (" << command << ")\n";
      return weft::app::kExitOutputFailed;
    }
    return weft::app::kExitOk;
  }

  int add(const weft::RgbImage& image, long number) {
    std::error_code ec;
    if (pipe_) {
      if (std::fwrite(image.pixels.data(), 1, image.pixels.size(), pipe_) != image.pixels.size()) {
        ::pclose(pipe_);
        pipe_ = nullptr;
        fs::remove(video_temporary_, ec);
        std::cerr << "weft: error: ffmpeg stopped taking frames at frame " << number << "; no video written\n";
        return weft::app::kExitOutputFailed;
      }
      return weft::app::kExitOk;
    }
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05ld.png", number);
    const fs::path path = out_ / name;
    try {
      weft::write_files_atomically({{path, [&](const fs::path& temporary) { weft::write_png(image, temporary); }}});
    } catch (const std::exception& e) {
      std::cerr << "weft: error: " << e.what() << "; kept " << written_ << " pictures written before it\n";
      return weft::app::kExitOutputFailed;
    }
    ++written_;
    return weft::app::kExitOk;
  }

  /// The video finished and renamed into place (nothing to do for PNGs).
  int close() {
    if (!pipe_) return weft::app::kExitOk;
    std::error_code ec;
    const int status = ::pclose(pipe_);
    pipe_ = nullptr;
    if (status == -1 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
      fs::remove(video_temporary_, ec);
      std::cerr << "weft: error: ffmpeg failed (exit status " << (WIFEXITED(status) ? WEXITSTATUS(status) : -1)
                << "); no video written\n";
      return weft::app::kExitOutputFailed;
    }
    fs::rename(video_temporary_, video_path(), ec);
    if (ec) {
      fs::remove(video_temporary_, ec);
      std::cerr << "weft: error: cannot write " << video_path().string() << "\n";
      return weft::app::kExitOutputFailed;
    }
    return weft::app::kExitOk;
  }

 private:
  fs::path out_;
  fs::path video_temporary_ = out_ / (".render.mp4.tmp-" + std::to_string(::getpid()));
  FILE* pipe_ = nullptr;
  size_t written_ = 0;  ///< PNGs written
};

int run_render(const RenderArgs& a) {
  const auto started = std::chrono::steady_clock::now();
  if (a.color != "none" && a.color != "viscosity" && a.color != "strain")
    throw InputError("--color '" + a.color + "': expected none, viscosity or strain");
  const auto [width, height] = parse_size(a.size, a.video);
  std::optional<render::Camera> given_camera;
  if (!a.camera.empty()) given_camera = parse_camera(a.camera);
  if (a.samples < 1 || a.samples > 8) throw InputError("--samples " + std::to_string(a.samples) + ": expected 1 to 8");
  if (a.uv_scale && (!(*a.uv_scale > 0) || !std::isfinite(*a.uv_scale)))
    throw InputError("--uv-scale " + format_number("%g", *a.uv_scale) + ": expected a number > 0");
  if (a.fps && !(*a.fps > 0 && *a.fps <= 1000)) throw InputError("--fps: expected a rate in (0, 1000]");
  const RenderFrames frames = choose_frames(a);
  const RunTiming timing = read_run_timing(a);

  RenderProgress progress;
  progress.bar.quiet_for(1.0);
  progress.work = frames.files.size() + frames.beside_files.size() + frames.panels * frames.selected.size();
  RunSurvey survey = survey_frames(a, frames, timing.uv_scale, progress);
  Framing framing = frame_pictures(a, survey, width, height, given_camera, frames.selected.front());
  add_colour_bar(a, survey, timing.uv_scale, framing.options);

  PictureOutput output{fs::path(a.out)};
  if (const int status = output.open(a, frames.panels * width, height, timing.fps.value_or(0)); status != weft::app::kExitOk)
    return status;
  std::vector<double> seconds_per_frame;
  for (long number : frames.selected) {
    const auto frame_start = std::chrono::steady_clock::now();
    if (a.follow) framing.follow(number);
    weft::RgbImage image = draw_frame(a, frames.files.at(number), number, survey, timing, framing.options);
    progress.step();
    if (frames.panels == 2) {
      const weft::RgbImage right = draw_frame(a, frames.beside_files.at(number), number, survey, timing, framing.options);
      progress.step();
      image = side_by_side(image, right, width, height, frames.labels);
    }
    if (const int status = output.add(image, number); status != weft::app::kExitOk) return status;
    seconds_per_frame.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - frame_start).count());
  }
  progress.bar.finish();
  if (const int status = output.close(); status != weft::app::kExitOk) return status;
  std::vector<double> sorted = seconds_per_frame;
  std::sort(sorted.begin(), sorted.end());
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  std::printf("%s %zu frame%s (%dx%d) in %.1f s, %.3f s per frame (median): %s\n", a.video ? "video of" : "rendered",
              frames.selected.size(), frames.selected.size() == 1 ? "" : "s", frames.panels * width, height, total,
              sorted[sorted.size() / 2], a.video ? output.video_path().c_str() : (fs::path(a.out) / "frame_NNNNN.png").c_str());
  return weft::app::kExitOk;
}

weft::app::RegisterCommand reg{{"", "render", "Draw a run's frames as PNG pictures (or an MP4 video) without a screen",
  [](CLI::App& sub) {
    auto a = std::make_shared<RenderArgs>();
    sub.add_option("dir", a->dir, "Output folder of `weft run` (reads DIR/frames and DIR/summary.json)")->required();
    sub.add_option("--out", a->out, "Folder for the pictures (frame_NNNNN.png) or the video (render.mp4)")->required();
    sub.add_option("--frames", a->frames,
                   "Frames to draw: a comma-separated list of numbers and ranges A-B (0,50,100 or 0-20), or all "
                   "(default: 4 spread over the run; with --video, all)");
    sub.add_option("--size", a->size, "Picture size WIDTHxHEIGHT in pixels (default 960x720)");
    sub.add_option("--camera", a->camera,
                   "eye_x,eye_y,eye_z,target_x,target_y,target_z[,fov_deg] in metres, Y up (default: a 3/4 view from "
                   "the front framing the cloth and bodies over the whole run, field of view 30)");
    sub.add_option("--color", a->color,
                   "none (the cloth in a fabric colour), viscosity (added viscosity per vertex, from PLY frames) or "
                   "strain (largest principal stretch - 1, averaged to the vertices, from OBJ frames); the colour "
                   "maps and shading are the viewer's (weft view)");
    sub.add_option("--uv-scale", a->uv_scale,
                   "Metres per unit of the frames' texture coordinates, for --color strain (default: uv_scale of "
                   "DIR/summary.json, the scene's cloth mesh.uv_scale; 1 for a run that did not record it)");
    sub.add_flag("--video", a->video, "Write render.mp4 (H.264, through ffmpeg) at the run's frame rate instead of PNGs");
    sub.add_option("--fps", a->fps, "The video's frame rate (default 1 / frame_interval of summary.json: real time)");
    sub.add_option("--samples", a->samples, "Anti-aliasing: samples per pixel along each side, 1 to 8 (default 3)");
    sub.add_flag("--no-ground", a->no_ground, "Leave out the ground and the shadows");
    sub.add_flag("--no-caption", a->no_caption, "Leave out the caption (time and frame)");
    sub.add_flag("--follow", a->follow,
                 "Move the camera with the cloth and bodies from frame to frame (the same view, framing the largest "
                 "frame): for a body that walks away from where it started. A --camera given is where it is at the first "
                 "frame drawn, and moves along");
    sub.add_option("--beside", a->beside,
                   "A second run's output folder, drawn to the right of DIR's frame by frame (the same frames, "
                   "camera, ground and colour scale): two methods side by side");
    sub.add_option("--labels", a->labels, "With --beside: LEFT,RIGHT, the names drawn over the two halves, in "
                   "lowercase (default: the two folders' names)");
    sub.footer(
        "Draws the cloth (two-sided, a fabric colour or a colour map) and the colliders (grey) of each chosen frame\n"
        "with a software rasteriser (no GPU or display needed), over a ground at y = 0 (or the lowest point, or a\n"
        "horizontal plane collider) with the key light's shadows, and writes IMG_DIR/frame_NNNNN.png; with --video\n"
        "the frames go through ffmpeg into IMG_DIR/render.mp4 (ffmpeg must be on the PATH). Every file is written\n"
        "under a temporary name and renamed into place. With --beside, each picture (or the video) is twice as\n"
        "wide: DIR's frame on the left, the other run's on the right. The colour maps, colours and shading are the viewer's; the\n"
        "strain's scale reaches the 99th percentile of |strain| over the run, and the command prints it.\n"
        "Exit status: 0 done, 2 bad input (a missing folder, an unreadable frame, a bad option; nothing written),\n"
        "4 a picture or the video could not be written.");
    return std::function<int()>([a] { return run_render(*a); });
  }, 25}};

}  // namespace
