// `weft run SCENE --out DIR`: simulate a scene and write frames, energies and a summary;
// `weft run --resume DIR`: continue a run from its checkpoint.
#include <csignal>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numeric>
#include <regex>
#include <sstream>

#include <unistd.h>

#include "weft/frame_check.hpp"
#include "command.hpp"
#include "weft/exports.hpp"
#include "weft/recording.hpp"
#include "progress.hpp"
#include "weft/atomic_file.hpp"
#include "weft/body.hpp"
#include "weft/error.hpp"
#include "weft/simulation.hpp"

namespace fs = std::filesystem;

namespace {

constexpr const char* kCheckpointName = "checkpoint.weft";
// Beside the checkpoint when the run writes animations: the frames they hold so far.
constexpr const char* kRecordedFramesName = "checkpoint_frames.weft";

struct RunArgs {
  std::string scene, out, method, preconditioner, resume;
  std::optional<std::string> frame_format, format_list;
  std::vector<std::string> formats;  ///< resolved (resolve_formats); what a checkpoint keeps
  std::optional<double> alpha, dt, duration, tolerance, damping_ratio, checkpoint_every, newton;
  bool no_frames = false, quiet = false;
};

// The settings a checkpoint keeps so that --resume rebuilds the same simulation.
nlohmann::json options_json(const RunArgs& a) {
  nlohmann::json j;
  j["method"] = a.method;
  j["preconditioner"] = a.preconditioner;
  j["frame_format"] = a.frame_format.value_or("obj");
  j["formats"] = a.formats;
  j["no_frames"] = a.no_frames;
  const std::pair<const char*, const std::optional<double>*> numbers[] = {
      {"alpha", &a.alpha}, {"dt", &a.dt}, {"duration", &a.duration}, {"tolerance", &a.tolerance},
      {"damping_ratio", &a.damping_ratio}, {"checkpoint_every", &a.checkpoint_every}, {"newton", &a.newton}};
  for (const auto& [key, value] : numbers)
    if (*value) j[key] = **value;
  return j;
}

RunArgs options_from_json(const nlohmann::json& j) {
  RunArgs a;
  a.method = j.at("method").get<std::string>();
  a.preconditioner = j.at("preconditioner").get<std::string>();
  a.frame_format = j.at("frame_format").get<std::string>();
  // Checkpoints from before --format keep only the frame format.
  a.formats = j.contains("formats") ? j.at("formats").get<std::vector<std::string>>()
                                    : std::vector<std::string>{*a.frame_format};
  a.no_frames = j.at("no_frames").get<bool>();
  const std::pair<const char*, std::optional<double>*> numbers[] = {
      {"alpha", &a.alpha}, {"dt", &a.dt}, {"duration", &a.duration}, {"tolerance", &a.tolerance},
      {"damping_ratio", &a.damping_ratio}, {"checkpoint_every", &a.checkpoint_every}, {"newton", &a.newton}};
  for (const auto& [key, value] : numbers)
    if (j.contains(key)) *value = j.at(key).get<double>();
  return a;
}

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw weft::InputError(path.string() + ": cannot read");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string hash_hex(const std::string& bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(weft::fnv1a(bytes.data(), bytes.size())));
  return buf;
}

weft::Scene build_scene(const RunArgs& a) {
  using namespace weft;
  Scene scene = load_scene(a.scene);
  const std::string where = "command line";
  SceneOverrides o;
  o.method = a.method;
  o.alpha = a.alpha;
  o.dt = a.dt;
  o.duration = a.duration;
  o.tolerance = a.tolerance;
  o.damping_ratio = a.damping_ratio;
  o.newton = a.newton;
  o.preconditioner = a.preconditioner;
  apply_overrides(scene, o, where);
  if (a.frame_format && a.format_list)
    throw InputError(where + ": --frame-format cannot be combined with --format (--frame-format " + *a.frame_format +
                     " is the per-frame format within --format's list)");
  if (a.checkpoint_every && !(*a.checkpoint_every >= 0 && std::isfinite(*a.checkpoint_every)))
    throw InputError(where + ": --checkpoint-every must be a number of seconds >= 0, got " +
                     std::to_string(*a.checkpoint_every));
  return scene;
}

// What a run writes: --format's list, else the scene's output.formats with --frame-format
// taking the place of its per-frame format, else OBJ frames.
std::vector<std::string> resolve_formats(const RunArgs& a, const weft::Scene& scene) {
  if (a.format_list) return weft::checked_output_formats(weft::split_format_list(*a.format_list), "command line: --format");
  std::vector<std::string> formats = scene.output_formats.empty() ? std::vector<std::string>{"obj"} : scene.output_formats;
  if (a.frame_format) {
    std::erase_if(formats, [](const std::string& f) { return f == "obj" || f == "ply"; });
    formats.insert(formats.begin(), *a.frame_format);
  }
  return formats;
}

bool has_format(const std::vector<std::string>& formats, const char* name) {
  return std::find(formats.begin(), formats.end(), name) != formats.end();
}

// An output that could not be written: the file and why.
struct OutputFailure {
  std::string path, reason;
};

std::string failure_reason(const std::exception& e) {
  std::string reason = e.what();
  // The streams do not say why a write failed; errno still does for the usual causes.
  const int err = errno;
  if (err == ENOSPC || err == EFBIG || err == EDQUOT || err == EROFS || err == EIO || err == EACCES)
    reason += std::string(" (") + std::strerror(err) + ")";
  return reason;
}

// The files a run writes into its folder; never touches anything else there.
class OutputFolder {
 public:
  explicit OutputFolder(fs::path dir) : dir_(std::move(dir)) {}
  const fs::path& dir() const { return dir_; }
  fs::path frames() const { return dir_ / "frames"; }
  fs::path checkpoint() const { return dir_ / kCheckpointName; }
  fs::path recorded_frames() const { return dir_ / kRecordedFramesName; }

  /// Removes the outputs of an earlier run (and temporaries of interrupted writes): frames
  /// and body frames from frame `first_frame` on, energy.csv, summary.json and the checkpoint
  /// unless `keep_checkpoint`. Files of other names are left alone.
  void clear(long first_frame, bool keep_checkpoint) const {
    static const std::regex frame(R"((frame_|body\d+_|collider\d+_)(\d{5,})\.(obj|ply)((\.\d+)?\.tmp)?)");
    static const std::regex top(
        R"((energy\.csv|summary\.json|checkpoint\.weft|checkpoint_frames\.weft|animation\.glb|animation\.pc2|animation_rest\.obj|animation\.usda)(\.\d+\.tmp)?)");
    std::error_code ec;
    if (fs::is_directory(frames(), ec)) {
      for (const auto& e : fs::directory_iterator(frames())) {
        std::smatch m;
        const std::string name = e.path().filename().string();
        if (std::regex_match(name, m, frame) && (m[4].matched || std::stol(m[2]) >= first_frame)) fs::remove(e.path());
      }
      fs::remove(frames(), ec);  // only when empty
    }
    for (const auto& e : fs::directory_iterator(dir_)) {
      std::smatch m;
      const std::string name = e.path().filename().string();
      if (std::regex_match(name, m, top) &&
          !(keep_checkpoint && (name == kCheckpointName || name == kRecordedFramesName)))
        fs::remove(e.path());
    }
  }

  /// Runs `write` (which writes `path` atomically, throwing when it cannot); false, and the
  /// failure noted, when it throws.
  bool attempt(const fs::path& path, const std::function<void()>& write) {
    try {
      write();
      return true;
    } catch (const std::exception& e) {
      failures.push_back({path.string(), failure_reason(e)});
      return false;
    }
  }
  bool write(const fs::path& path, const std::function<void(std::ostream&)>& content) {
    return attempt(path, [&] { weft::write_file_atomically(path.string(), content); });
  }
  bool write_bytes(const fs::path& path, const std::string& bytes) {
    return write(path, [&](std::ostream& o) { o.write(bytes.data(), static_cast<std::streamsize>(bytes.size())); });
  }

  std::vector<OutputFailure> failures;

 private:
  fs::path dir_;
};

// The changes that could stabilise a run, leaving out those already in force.
std::string stability_advice(const weft::Scene& sc) {
  using weft::Method;
  std::vector<std::string> items;
  char buf[160];
  std::snprintf(buf, sizeof buf, "a smaller time step than the current %g s (e.g. --dt %g)", sc.integrator.dt,
                sc.integrator.dt / 2);
  items.push_back(buf);
  // An unguarded step with a guarded form: the guard keeps its method's motion wherever the
  // step does not put energy in (docs/guarded-midpoint.md).
  if (!sc.integrator.guard && sc.integrator.method == Method::kAlphaFamily && sc.integrator.alpha == 0.5) {
    items.push_back("the guarded step (--method implicit-midpoint)");
  } else if (!sc.integrator.guard && sc.integrator.method == Method::kBdf2 && sc.integrator.alpha > 0 &&
             sc.integrator.alpha < 1) {
    std::snprintf(buf, sizeof buf, "the guarded step (--method bdf2-alpha-guarded --alpha %g)", sc.integrator.alpha);
    items.push_back(buf);
  }
  if (!(sc.integrator.method == Method::kAlphaFamily && sc.integrator.alpha == 1.0))
    items.push_back("a more implicit method (--method backward-euler)");
  // A semi-implicit step linearised once: on a fabric that stiffens, Newton iterations follow
  // the curve within the step (docs/results.md, "Stiffening fabric").
  const bool semi_implicit = (sc.integrator.method == Method::kAlphaFamily && sc.integrator.alpha > 0) ||
                             sc.integrator.method == Method::kBdf2;
  if (semi_implicit && sc.integrator.newton_iterations < 4)
    items.push_back("Newton iterations within each step, for a fabric that stiffens (e.g. --newton 4)");
  const double zeta = sc.effective_damping_ratio();
  if (zeta < 1.0) {
    const double more = zeta > 0 ? std::min(1.0, 2 * zeta) : 0.05;
    if (zeta > 0)
      std::snprintf(buf, sizeof buf, "more damping than the current ratio of %g (e.g. --damping-ratio %g)", zeta, more);
    else
      std::snprintf(buf, sizeof buf, "adaptive damping, off now (e.g. --damping-ratio %g)", more);
    items.push_back(buf);
  }
  std::string s = "Try ";
  for (size_t i = 0; i < items.size(); ++i)
    s += (i == 0 ? "" : i + 1 == items.size() ? " or " : ", ") + items[i];
  return s + ".";
}

// Ctrl-C (SIGINT) and SIGTERM ask the run to stop at the next frame boundary; the handler
// resets itself, so a second signal ends the process at once.
volatile std::sig_atomic_t g_stop_signal = 0;

extern "C" void on_stop_signal(int sig) {
  g_stop_signal = sig;
  static const char note[] = "\nweft: stopping at the next frame boundary (again to quit at once)\n";
  const ssize_t ignored = ::write(2, note, sizeof note - 1);
  (void)ignored;
}

void install_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESETHAND;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  // A file-size limit then fails the write (reported, exit status 4) instead of killing weft.
  std::signal(SIGXFSZ, SIG_IGN);
}

// The intersections counted on each frame of a run, for summary.json. A checkpoint keeps
// them (state()), so a resumed run reports every frame as an uninterrupted one does.
struct IntersectionTally {
  long first_frame = 0;  ///< the frame per_frame[0] counts (a resume from an older checkpoint starts later)
  std::vector<size_t> per_frame, cloth_self, cloth_body;
  size_t at_body_crossings = 0;
  double seconds = 0;

  void add(const weft::FrameIntersections& r) {
    size_t body = 0;
    for (const auto& b : r.cloth_body) body += b.count;
    for (size_t n : r.cloth_body_at_body_crossings) at_body_crossings += n;
    per_frame.push_back(r.count());
    cloth_self.push_back(r.cloth_self.count);
    cloth_body.push_back(body);
  }
  nlohmann::json state() const {
    return {{"first_frame", first_frame}, {"per_frame", per_frame}, {"cloth_self", cloth_self},
            {"cloth_body", cloth_body}, {"at_body_crossings", at_body_crossings}, {"seconds", seconds}};
  }
  void restore(const nlohmann::json& j) {
    first_frame = j.at("first_frame").get<long>();
    per_frame = j.at("per_frame").get<std::vector<size_t>>();
    cloth_self = j.at("cloth_self").get<std::vector<size_t>>();
    cloth_body = j.at("cloth_body").get<std::vector<size_t>>();
    at_body_crossings = j.at("at_body_crossings").get<size_t>();
    seconds = j.at("seconds").get<double>();
  }
  nlohmann::json summary() const {
    nlohmann::json j;
    j["first_frame"] = first_frame;
    j["per_frame"] = per_frame;
    size_t total = 0, worst = 0;
    long worst_frame = -1;
    for (size_t k = 0; k < per_frame.size(); ++k) {
      total += per_frame[k];
      if (per_frame[k] > worst) worst = per_frame[k], worst_frame = first_frame + static_cast<long>(k);
    }
    j["worst_frame"] = worst_frame >= 0 ? nlohmann::json(worst_frame) : nlohmann::json(nullptr);
    j["worst_count"] = worst;
    j["total"] = total;
    j["cloth_self_per_frame"] = cloth_self;
    j["cloth_body_per_frame"] = cloth_body;
    j["cloth_body_at_body_crossings"] = at_body_crossings;
    return j;
  }
};

std::string count_of(size_t n, const char* what) { return std::to_string(n) + " " + what + (n == 1 ? "" : "s"); }

// A checkpoint to resume from: the file, its bytes and its header.
struct Resumption {
  fs::path file;
  std::string bytes;
  nlohmann::json header;
};

// --resume DIR: reads DIR's checkpoint and puts the settings the run started with into `a`
// (keeping --quiet and a new --checkpoint-every); refuses the options a resume cannot change
// and a scene changed since.
Resumption read_resumption(RunArgs& a, const std::function<bool(const char*)>& given) {
  using weft::InputError;
  for (const char* option : {"scene", "--out", "--method", "--alpha", "--dt", "--duration", "--tolerance",
                             "--preconditioner", "--damping-ratio", "--newton", "--frame-format", "--format", "--no-frames"})
    if (given(option))
      throw InputError(std::string("command line: ") + option +
                       " cannot be combined with --resume: the run goes on with the settings it started with");
  Resumption r;
  r.file = fs::path(a.resume) / kCheckpointName;
  if (!fs::exists(r.file))
    throw InputError(r.file.string() + ": no checkpoint to resume from (a run writes one when interrupted, and "
                                       "every --checkpoint-every seconds)");
  r.bytes = read_bytes(r.file);
  r.header = weft::checkpoint_header(r.bytes, r.file.string());
  RunArgs stored;
  try {
    stored = options_from_json(r.header.at("options"));
    stored.scene = r.header.at("scene").get<std::string>();
    const std::string hash = r.header.at("scene_hash").get<std::string>();
    if (hash_hex(read_bytes(stored.scene)) != hash)
      throw InputError(stored.scene + ": the scene changed since the checkpoint " + r.file.string() +
                       " was written (its hash was " + hash + "); resume needs the same scene");
  } catch (const nlohmann::json::exception& e) {
    throw InputError(r.file.string() + ": checkpoint header is damaged: " + e.what());
  }
  stored.out = a.resume;
  stored.quiet = a.quiet;
  if (a.checkpoint_every) stored.checkpoint_every = a.checkpoint_every;
  a = stored;
  return r;
}

using Clock = std::chrono::steady_clock;

// What a run writes into its folder while it runs and at its end: the frames, the colliders'
// surfaces, the recorded animations, the checkpoint, energy.csv and summary.json, and the
// intersections counted on every frame.
class RunWriter {
 public:
  /// Makes the folder (and frames/) and clears an earlier run's outputs (a resumed run's past
  /// its checkpoint); throws InputError when it cannot.
  RunWriter(const RunArgs& a, const weft::Scene& scene, const weft::Simulation& sim, const Resumption* resumed,
            long first_frame)
      : a_(a), sim_(sim), out_(a.out), first_frame_(first_frame), frames_complete_(first_frame),
        frame_checker_(0), cloth_mesh_(sim.mesh()) {
    using namespace weft;
    std::error_code ec;
    fs::create_directories(out_.dir(), ec);
    if (ec) throw InputError(a.out + ": cannot create output folder: " + ec.message());
    // Every frame's intersections (docs/collision-geometry.md, "Checking"), counted whether or
    // not it is written; a resumed run takes over the counts of the frames before its
    // checkpoint.
    tally_.first_frame = first_frame;
    if (resumed && resumed->header.contains("intersections")) {
      try {
        tally_.restore(resumed->header.at("intersections"));
      } catch (const nlohmann::json::exception& e) {
        throw InputError(resumed->file.string() + ": checkpoint header is damaged: " + e.what());
      }
    }
    // A fresh run replaces an earlier run's outputs; a resumed one those past its checkpoint.
    out_.clear(first_frame, resumed != nullptr);
    write_glb_ = has_format(a.formats, "glb");
    write_pc2_ = has_format(a.formats, "pc2");
    write_usda_ = has_format(a.formats, "usda");
    animate_ = write_glb_ || write_pc2_ || write_usda_;  // frames recorded for the animations
    frame_format_ = has_format(a.formats, "ply") ? "ply" : has_format(a.formats, "obj") ? "obj" : "";
    frame_files_ = !a.no_frames && !frame_format_.empty();
    if (frame_files_) {
      fs::create_directories(out_.frames(), ec);
      if (ec) throw InputError(out_.frames().string() + ": cannot create output folder: " + ec.message());
    }
    checkpoint_header_["weft_version"] = WEFT_VERSION;
    checkpoint_header_["scene"] = fs::absolute(a.scene).string();
    checkpoint_header_["scene_hash"] = hash_hex(read_bytes(a.scene));
    checkpoint_header_["options"] = options_json(a);
    checkpoint_frame_ = resumed ? first_frame - 1 : -1;
    // The colliders' surfaces in file order: a walking body's skinned mesh, another collider's
    // surface as Collider::surface draws it.
    collider_count_ = sim.collider_count();
    collider_positions_.resize(collider_count_);
    collider_triangles_.resize(collider_count_);
    collider_triangle_lists_.resize(collider_count_);
    // Texture coordinates: the pattern coordinates in the units of the cloth's OBJ texture
    // coordinates (metres on a grid), so an OBJ cloth's own come back.
    cloth_texcoords_ = pattern_texcoords(cloth_mesh_.pattern, scene.cloth.uv_scale);
  }

  /// The animations (glb, pc2, usda) are written at the end from the frames recorded here; a
  /// resumed run reads those recorded before its checkpoint.
  void start_recording(bool resume) {
    using namespace weft;
    if (animate_) recording_.emplace(sim_, write_glb_ || write_usda_, write_glb_);
    if (resume && animate_) {
      const fs::path file = out_.recorded_frames();
      if (!fs::exists(file))
        throw InputError(file.string() + ": missing; the animations (glb, pc2, usda) of a resumed run need the frames "
                                         "recorded before its checkpoint");
      recording_->read_frames(read_bytes(file), file.string(), static_cast<size_t>(first_frame_));
    }
  }

  /// Frame f: counts its intersections, records it for the animations and writes its files.
  void on_frame(int f, const weft::Simulation& s) {
    using namespace weft;
    const auto check_start = Clock::now();
    std::vector<FrameMesh> body_meshes;
    for (size_t k = 0; k < collider_count_; ++k) {
      collider_surface(s, k);
      body_meshes.push_back({collider_positions_[k].data(), &collider_triangle_lists_[k]});
    }
    tally_.add(frame_checker_.check({s.positions().data(), &s.mesh().triangles}, body_meshes));
    tally_.seconds += std::chrono::duration<double>(Clock::now() - check_start).count();
    if (!out_.failures.empty()) return;
    const auto export_start = Clock::now();
    if (animate_) recording_->add_frame(s, &collider_positions_);
    if (!frame_files_) {
      export_seconds_.push_back(std::chrono::duration<double>(Clock::now() - export_start).count());
      return;
    }
    char name[64];
    std::snprintf(name, sizeof name, "frame_%05d.%s", f, frame_format_.c_str());
    const fs::path path = out_.frames() / name;
    bool ok = frame_format_ == "ply"
                  ? out_.write(path, [&](std::ostream& o) {
                      const VecX eta = s.added_viscosity_per_vertex();
                      write_ply_frame(o, s.positions().data(), s.vertex_count(), eta.data(), cloth_mesh_.triangles);
                    })
                  : out_.write(path, [&](std::ostream& o) {
                      write_textured_obj(o, s.positions().data(), s.vertex_count(), cloth_texcoords_,
                                         vertex_normals(s.positions().data(), s.vertex_count(), cloth_mesh_.triangles),
                                         cloth_mesh_.triangles);
                    });
    // The colliders' surfaces: body<k> for the k-th walking body, collider<k> for the k-th
    // collider of another kind.
    for (size_t k = 0; ok && k < collider_count_; ++k) {
      std::snprintf(name, sizeof name, "%s_%05d.obj", collider_output_name(s.collider(k), k).c_str(), f);
      const fs::path collider_path = out_.frames() / name;
      ok = out_.attempt(collider_path,
                        [&] { write_obj(collider_path.string(), collider_positions_[k], collider_triangles_[k]); });
    }
    if (ok) frames_complete_ = f + 1;
    export_seconds_.push_back(std::chrono::duration<double>(Clock::now() - export_start).count());
  }

  /// The checkpoint (and, for the animations, the frames recorded so far) as of r's last frame.
  void write_checkpoint(const weft::RunResult& r) {
    checkpoint_header_["intersections"] = tally_.state();
    if (animate_ && !out_.write(out_.recorded_frames(), [&](std::ostream& o) { recording_->write_frames(o); }))
      return;
    if (out_.write_bytes(out_.checkpoint(), weft::checkpoint_bytes(checkpoint_header_, sim_, r)))
      checkpoint_frame_ = static_cast<long>(r.energy.size()) - 1;
  }

  /// The end of the run: the checkpoint kept or removed, the animations, energy.csv and
  /// summary.json. Returns the summary.
  nlohmann::json finish(const weft::RunResult& r) {
    const bool failed = !out_.failures.empty();
    const bool interrupted = !failed && r.status == "interrupted";
    // Interrupted: where to go on from. Finished with --checkpoint-every: the exact final state.
    // Unstable: none (going on would repeat the blow-up).
    const bool keep_checkpoint = interrupted || (r.status == "ok" && a_.checkpoint_every);
    if (!failed && keep_checkpoint) write_checkpoint(r);
    if (!failed && !keep_checkpoint) {
      std::error_code ec;
      fs::remove(out_.checkpoint(), ec);
      fs::remove(out_.recorded_frames(), ec);
    }
    // The animations hold the frames of a finished (or unstable) run; an interrupted one writes
    // them when resumed to the end.
    double animation_seconds = 0;
    if (!failed && !interrupted && recording_ && recording_->frame_count() > 0) {
      const auto start = Clock::now();
      if (write_glb_) out_.write(out_.dir() / "animation.glb", [&](std::ostream& o) { recording_->write_glb(o); });
      if (write_usda_) out_.write(out_.dir() / "animation.usda", [&](std::ostream& o) { recording_->write_usda(o); });
      if (write_pc2_) {
        out_.write(out_.dir() / "animation.pc2", [&](std::ostream& o) { recording_->write_pc2(o); });
        out_.write(out_.dir() / "animation_rest.obj", [&](std::ostream& o) { recording_->write_rest_obj(o); });
      }
      animation_seconds = std::chrono::duration<double>(Clock::now() - start).count();
    }
    energy_written_ = out_.write(out_.dir() / "energy.csv", [&](std::ostream& o) { o << weft::energy_csv(r.energy); });
    nlohmann::json summary = weft::summary_json(sim_, r);
    summary["intersections"] = tally_.summary();
    summary["intersection_seconds"] = tally_.seconds;
    summary["formats"] = a_.formats;
    if (!export_seconds_.empty()) {
      // Frames' exports (files and recording) in this process, and the animations at the end.
      std::vector<double> sorted = export_seconds_;
      std::sort(sorted.begin(), sorted.end());
      summary["export_seconds"] = {{"per_frame_median", sorted[sorted.size() / 2]},
                                   {"frames_total", std::accumulate(sorted.begin(), sorted.end(), 0.0)},
                                   {"animations", animation_seconds}};
    }
    if (!out_.failures.empty()) {
      summary["status"] = "output_failed";
      summary["message"] = "could not write " + out_.failures.front().path + ": " + out_.failures.front().reason;
    }
    summary_written_ = out_.write(out_.dir() / "summary.json", [&](std::ostream& o) { o << summary.dump(2) << "\n"; });
    return summary;
  }

  /// Says on stderr what the run left and returns its exit status.
  int report(const weft::RunResult& r, const weft::Scene& scene, const nlohmann::json& summary) const {
    using namespace weft;
    const std::string frames_kept =
        a_.no_frames          ? std::string("no frames (--no-frames)")
        : !frame_files_         ? std::string("no frame files (formats without obj or ply)")
        : frames_complete_ == 0 ? std::string("no frames")
                                : "frames " + (frames_complete_ == 1 ? std::string("0") : "0 to " + std::to_string(frames_complete_ - 1)) +
                                      " in " + out_.frames().string();
    const bool interrupted = out_.failures.empty() && r.status == "interrupted";
    if (!out_.failures.empty()) {
      std::string kept = frames_kept;
      if (energy_written_) kept += ", energy.csv (" + count_of(r.energy.size(), "row") + ")";
      if (summary_written_) kept += ", summary.json (status output_failed)";
      std::fprintf(stderr, "weft: error: could not write %s: %s.\nStopped at t = %.4f s. Kept: %s.\n",
                   out_.failures.front().path.c_str(), out_.failures.front().reason.c_str(), sim_.time(), kept.c_str());
      for (size_t k = 1; k < out_.failures.size(); ++k)
        std::fprintf(stderr, "weft: could not write %s either: %s\n", out_.failures[k].path.c_str(),
                     out_.failures[k].reason.c_str());
      if (checkpoint_frame_ >= 0 && fs::exists(out_.checkpoint()))
        std::fprintf(stderr, "The checkpoint %s holds frame %ld: once there is room, `weft run --resume %s` continues "
                             "from there.\n", out_.checkpoint().c_str(), checkpoint_frame_, a_.out.c_str());
      return app::kExitOutputFailed;
    }
    if (interrupted) {
      std::fprintf(stderr, "weft: interrupted at t = %.4f s. Kept: %s, energy.csv, summary.json (status interrupted) "
                           "and %s. Continue with `weft run --resume %s`.\n",
                   sim_.time(), frames_kept.c_str(), out_.checkpoint().c_str(), a_.out.c_str());
      return app::kExitInterrupted;
    }
    if (!a_.quiet) {
      std::fprintf(stderr, "%s: %ld steps in %.2f s (%.3f ms/step), CG %.1f iterations/step, kappa %.3g..%.3g, damping %.3g\n",
                   summary["status"].get<std::string>().c_str(), r.steps.steps, r.wall_seconds,
                   1e3 * r.wall_seconds / std::max(1L, r.steps.steps), summary["solver_iterations_mean"].get<double>(),
                   r.damping.membrane_kappa.min(), r.damping.membrane_kappa.max(), r.damping_ratio);
      std::string files = frame_files_ ? "frames/, " : "";
      if (write_glb_) files += "animation.glb, ";
      if (write_pc2_) files += "animation.pc2, animation_rest.obj, ";
      if (write_usda_) files += "animation.usda, ";
      std::fprintf(stderr, "results in %s (%senergy.csv, summary.json)\n", a_.out.c_str(), files.c_str());
    }
    if (r.steps.cg_failures > 0)
      std::fprintf(stderr,
                   "weft: warning: %ld of %ld linear solves stopped at the iteration cap of %d (the scene's "
                   "integrator.max_iterations) before reaching the tolerance %g: the motion is less accurate than asked. "
                   "summary.json's status is %s.\n",
                   r.steps.cg_failures, r.steps.cg_solves, scene.integrator.cg_max_iterations,
                   scene.integrator.cg_tolerance, summary["status"].get<std::string>().c_str());
    if (r.steps.newton_automatic_steps > 0)
      std::fprintf(stderr,
                   "weft: note: %ld of %ld backward Euler steps put energy in (its linearisation's error on a "
                   "stiffening fabric) and were taken again with %d Newton iterations (summary.json: "
                   "newton.automatic_steps; --newton N iterates every step).\n",
                   r.steps.newton_automatic_steps, r.steps.steps,
                   summary["newton"].value("automatic_max_iterations", 0));
    // Collisions the fail-safes could not clear, and frames that came out crossed: not what a run
    // is asked for, so said on stderr, and a crossed frame gives `weft check`'s exit status.
    if (summary.contains("contacts")) {
      const nlohmann::json& c = summary["contacts"];
      const long colliders = c.value("failed_steps", 0L), self = c.contains("self") ? c["self"].value("failed_steps", 0L) : 0L;
      if (colliders + self > 0)
        std::fprintf(stderr,
                     "weft: warning: the collision fail-safes could not clear %ld step(s) (summary.json: "
                     "contacts.failed_steps %ld, contacts.self.failed_steps %ld).\n",
                     colliders + self, colliders, self);
    }
    const nlohmann::json& crossed = summary["intersections"];
    long crossed_frames = 0;
    for (const auto& n : crossed["per_frame"]) crossed_frames += n.get<size_t>() > 0 ? 1 : 0;
    if (crossed_frames > 0) {
      const long worst = crossed["worst_frame"].get<long>();
      std::fprintf(stderr,
                   "weft: warning: %ld of %zu frames have intersecting triangle pairs (%zu in all; the worst, frame %ld, "
                   "%zu); `weft check %s` lists them.\n",
                   crossed_frames, crossed["per_frame"].size(), crossed["total"].get<size_t>(), worst,
                   crossed["worst_count"].get<size_t>(), a_.out.c_str());
    }
    if (r.status == "unstable") {
      std::fprintf(stderr, "weft: simulation became unstable at t = %.4f s: %s.\nKept %zu frames. %s\n", r.unstable_time,
                   r.message.c_str(), r.energy.size(), stability_advice(scene).c_str());
      return app::kExitUnstable;
    }
    return crossed_frames > 0 ? app::kExitIntersections : app::kExitOk;
  }

  bool failed() const { return !out_.failures.empty(); }

 private:
  void collider_surface(const weft::Simulation& s, size_t k) {
    s.collider_surface(k, s.time(), collider_positions_[k], collider_triangles_[k]);
    if (collider_triangle_lists_[k].empty()) collider_triangle_lists_[k] = weft::triangle_list(collider_triangles_[k]);
  }

  const RunArgs& a_;
  const weft::Simulation& sim_;
  OutputFolder out_;
  long first_frame_;
  long frames_complete_;  ///< frames 0 .. frames_complete_ - 1 are on disk
  IntersectionTally tally_;
  bool write_glb_ = false, write_pc2_ = false, write_usda_ = false, animate_ = false, frame_files_ = false;
  std::string frame_format_;
  nlohmann::json checkpoint_header_;
  long checkpoint_frame_ = -1;  ///< the last frame a checkpoint on disk holds
  weft::FrameChecker frame_checker_;  ///< its trees are built on the first frame and refitted after
  size_t collider_count_ = 0;
  std::vector<weft::Points> collider_positions_;
  std::vector<weft::Triangles> collider_triangles_;
  std::vector<std::vector<std::array<int, 3>>> collider_triangle_lists_;
  const weft::TriMesh& cloth_mesh_;
  std::vector<float> cloth_texcoords_;
  std::optional<weft::FrameRecording> recording_;
  std::vector<double> export_seconds_;  ///< per frame: writing its files and recording it
  bool energy_written_ = false, summary_written_ = false;
};

int run(RunArgs a, const std::function<bool(const char*)>& given) {
  using namespace weft;
  const bool resume = !a.resume.empty();
  std::optional<Resumption> resumed;
  if (resume) {
    resumed = read_resumption(a, given);
  } else if (a.scene.empty() || a.out.empty()) {
    throw InputError("command line: give a scene and --out DIR, or --resume DIR");
  }
  const Scene scene = build_scene(a);
  if (!resume) a.formats = resolve_formats(a, scene);
  // Set-up is usually a fraction of a second; large meshes and bodies show its stages.
  app::Progress setup_progress("weft run set-up", !a.quiet);
  setup_progress.quiet_for(0.5);
  // Validates the mesh, material, pins and colliders before anything is written.
  Simulation sim(scene, [&](const std::string& stage, double fraction) {
    if (stage != "done") setup_progress.update(fraction, stage);
  });
  RunResult so_far;
  if (resume) so_far = restore_checkpoint(resumed->bytes, resumed->file.string(), sim);
  setup_progress.update(1.0, "done");

  RunWriter writer(a, scene, sim, resumed ? &*resumed : nullptr, static_cast<long>(so_far.energy.size()));
  install_signal_handlers();
  app::Progress progress("weft run " + scene.method_name, !a.quiet);
  auto last_checkpoint = Clock::now();
  writer.start_recording(resume);
  RunCallbacks cb;
  cb.on_frame = [&](int f, const Simulation& s) { writer.on_frame(f, s); };
  cb.on_progress = [&](double fr) { progress.update(fr); };
  cb.after_frame = [&](const RunResult& r) {
    if (writer.failed() || g_stop_signal) return true;
    if (a.checkpoint_every &&
        std::chrono::duration<double>(Clock::now() - last_checkpoint).count() >= *a.checkpoint_every) {
      writer.write_checkpoint(r);
      last_checkpoint = Clock::now();
    }
    return writer.failed();
  };
  const RunResult r = run_simulation(sim, cb, resume ? &so_far : nullptr);
  progress.finish();
  const nlohmann::json summary = writer.finish(r);
  return writer.report(r, scene, summary);
}

weft::app::RegisterCommand reg{{"", "run", "Simulate a scene file and write frames, energy.csv and summary.json",
  [](CLI::App& sub) {
    auto a = std::make_shared<RunArgs>();
    sub.add_option("scene", a->scene, "Scene file (JSON, see docs/scene-format.md)");
    sub.add_option("--out,-o", a->out, "Output folder (created; frames/, energy.csv, summary.json)");
    sub.add_option("--resume", a->resume,
                   "Continue the interrupted run in this folder from its checkpoint, with its settings");
    sub.add_option("--checkpoint-every", a->checkpoint_every,
                   "Write DIR/checkpoint.weft at the first frame boundary after every SECONDS of wall-clock time "
                   "(0: every frame)");
    sub.add_option("--method,-m", a->method,
                   "Integrator: " + weft::method_names() + " (default: the scene's)");
    sub.add_option("--alpha", a->alpha, "Implicitness in [0, 1] for methods 'alpha', 'bdf2-alpha' and 'bdf2-alpha-guarded'");
    sub.add_option("--dt", a->dt, "Time step in seconds (for rk45: the largest step)");
    sub.add_option("--duration", a->duration, "Simulated time in seconds");
    sub.add_option("--tolerance", a->tolerance,
                   "Conjugate-gradient relative residual (semi-implicit methods) or local error tolerance (rk45)");
    sub.add_option("--preconditioner", a->preconditioner,
                   "Conjugate-gradient preconditioner: auto (multigrid from " +
                       std::to_string(weft::kMultigridMinFreeNodes) + " free vertices, ssor below), "
                       "block-jacobi, ssor or multigrid (default: the scene's, else auto)")
        ->check(CLI::IsMember({"auto", "block-jacobi", "ssor", "multigrid"}));
    sub.add_option("--damping-ratio", a->damping_ratio,
                   "Adaptive damping target as a fraction of critical (0 turns it off; default 0.05 for "
                   "Implicit Midpoint and BDF-2, 0 for the others)");
    sub.add_option("--newton", a->newton,
                   "Newton iterations a semi-implicit step may add to its linearised solve, re-linearising the "
                   "forces where the step ends up (0: one linearisation per step; default: the scene's "
                   "integrator.newton_iterations, else 0)")
        ->type_name("INT");
    sub.add_option("--format", a->format_list,
                   "What to write, comma-separated, any of obj, ply (frames), glb, pc2, usda (animations); "
                   "default: the scene's output.formats, else obj (docs/exports.md)");
    sub.add_option("--frame-format", a->frame_format,
                   "The per-frame format, obj or ply (with per-vertex added viscosity), in place of the "
                   "scene's; --format ply is the same")
        ->check(CLI::IsMember({"obj", "ply"}));
    sub.add_flag("--no-frames", a->no_frames,
                 "Do not write the per-frame files (the glb, pc2 and usda animations are still written when chosen)");
    sub.add_flag("--quiet,-q", a->quiet, "No progress bar or summary line");
    sub.footer(
        "Writes DIR/frames/frame_00000.obj ... (one per output frame, the first at time 0), DIR/energy.csv\n"
        "(time,kinetic,elastic,gravity,viscous_dissipated,numerical_dissipated,contact_work,total in J; guarded methods\n"
        "add guard_parts,guard_alpha) and DIR/summary.json\n"
        "(with --format glb also DIR/animation.glb; pc2: DIR/animation.pc2 and DIR/animation_rest.obj;\n"
        "usda: DIR/animation.usda), after removing those of an earlier run in DIR. Ctrl-C stops at the next\n"
        "frame boundary and writes "
        "DIR/checkpoint.weft; `weft run --resume DIR` continues with the same result as an\n"
        "uninterrupted run.\n"
        "Exit status: 0 ok (also when solves hit the iteration cap: a warning, summary status solver_capped),\n"
        "2 bad input (nothing written), 3 unstable (frames so far kept), 4 an output could not be written\n"
        "(the message says what was kept), 5 finished, but some frame has intersecting triangle pairs (as\n"
        "weft check; summary.json's intersections), 6 the scene's garment pattern does not sew (stitches left open or\n"
        "intersections: named; nothing written; cloth.mesh.pattern.allow_open_seams runs it), 130 interrupted\n"
        "(checkpoint written).");
    CLI::App* app = &sub;
    return std::function<int()>([a, app] {
      return run(*a, [app](const char* name) { return app->count(name) > 0; });
    });
  }, 10}};

}  // namespace
