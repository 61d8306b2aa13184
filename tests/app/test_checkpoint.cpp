// `weft run --checkpoint-every` and `--resume`, Ctrl-C: a run stopped anywhere and resumed
// must give the same bytes as a run never stopped (the same binary on the same machine
// repeats its arithmetic exactly, so any difference means a checkpoint missed some state).
#include <signal.h>
#include <sys/wait.h>
#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <map>
#include <nlohmann/json.hpp>
#include <thread>

#include "support/command.hpp"
#include "sim/simulation_core.hpp"

using weft::test::CommandTest;
using weft::test::read_binary;
using weft::test::read_text;
namespace fs = std::filesystem;

namespace {

// A swinging sheet long enough to stop part-way: `integrator` picks the method.
std::string scene(const std::string& integrator, const std::string& duration = "3.0") {
  return R"({"weft_scene": 1, "duration": )" + duration + R"(, "frame_interval": 0.02,
  "integrator": )" + integrator + R"(,
  "cloth": {"mesh": {"grid": {"size": [0.5, 0.5], "vertices": [17, 17]}},
            "placement": {"rotation_deg": [-90, 0, 0]},
            "material": {"surface_density": 0.15, "weft": 100, "warp": 100, "shear": 10, "bending_rigidity": 1e-4,
                         "viscosity": 0.001},
            "pins": {"grid": [[0, 0], [-1, 0]]}}})";
}

// Every file below `dir` (relative path -> bytes), but summary.json and the checkpoint,
// which hold wall-clock times.
std::map<std::string, std::string> outputs(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file() && e.path().filename() != "summary.json" && e.path().filename() != "checkpoint.weft")
      files[fs::relative(e.path(), dir).string()] = read_binary(e.path());
  return files;
}

// summary.json without its timings.
nlohmann::json summary_without_timing(const fs::path& dir) {
  auto j = nlohmann::json::parse(read_text(dir / "summary.json"));
  for (const char* key : {"wall_seconds", "assembly_seconds", "solve_seconds", "intersection_seconds"}) {
    EXPECT_TRUE(j.contains(key)) << key;
    j.erase(key);
  }
  j.erase("export_seconds");
  if (j.contains("guard")) {
    EXPECT_TRUE(j["guard"].contains("seconds"));
    j["guard"].erase("seconds");
  }
  // The contact handlers' times, present when a scene has colliders or self-collision.
  if (j.contains("contacts")) {
    for (const char* key : {"detection_seconds", "response_seconds"}) j["contacts"].erase(key);
    if (j["contacts"].contains("self")) j["contacts"]["self"].erase("seconds");
  }
  return j;
}

// The final state a finished run's checkpoint holds.
weft::State final_state(const fs::path& scene_file, const fs::path& dir) {
  weft::Simulation sim(weft::load_scene(scene_file.string()));
  const fs::path file = dir / "checkpoint.weft";
  weft::restore_checkpoint(read_binary(file), file.string(), sim);
  return sim.core().state();
}

bool same_bits(const weft::VecX& a, const weft::VecX& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0;
}

}  // namespace

class Checkpoint : public CommandTest {
 protected:
  // Starts `weft ARGS...` in the background, its error output to stderr.txt in the folder.
  pid_t start(const std::vector<std::string>& args) {
    const std::string err = (folder_ / "stderr.txt").string();
    const pid_t pid = ::fork();
    if (pid == 0) {
      const int fd = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      ::dup2(fd, 2);
      const int null = ::open("/dev/null", O_WRONLY);
      ::dup2(null, 1);
      std::vector<char*> argv{const_cast<char*>("weft")};
      for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      ::execv(WEFT_EXE, argv.data());
      ::_exit(127);
    }
    return pid;
  }
  // Waits for `path` to appear (true) or the process to end (false).
  static bool wait_for(const fs::path& path, pid_t pid) {
    for (;;) {
      if (fs::exists(path)) return true;
      int status;
      if (::waitpid(pid, &status, WNOHANG) == pid) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  static int exit_status(pid_t pid) {
    int status = 0;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
  }

  // Runs the scene once uninterrupted and, for each of `kill_frames`, once killed with
  // SIGKILL after writing that frame and resumed; each resumed run must match the
  // uninterrupted one byte for byte. `formats`: the runs' --format (default: OBJ frames).
  void expect_resumed_runs_match(const std::string& integrator, const std::vector<int>& kill_frames,
                                 const std::string& formats = "obj") {
    const auto s = write("scene.json", scene(integrator));
    const auto ref = folder_ / "reference";
    const auto r = weft("run '" + s.string() + "' --out '" + ref.string() + "' --quiet --checkpoint-every 1000 --format " + formats);
    ASSERT_EQ(r.exit_code, 0) << r.error_output;
    const auto expected = outputs(ref);
    for (const char* animation : {"glb", "pc2"})
      if (formats.find(animation) != std::string::npos)
        ASSERT_EQ(expected.count(std::string("animation.") + animation), 1u) << animation;
    const auto expected_summary = summary_without_timing(ref);
    const weft::State expected_state = final_state(s, ref);
    ASSERT_GT(expected_summary["frames"].get<int>(), kill_frames.back() + 5);
    for (int k : kill_frames) {
      SCOPED_TRACE("killed after frame " + std::to_string(k));
      const auto out = folder_ / ("killed_" + std::to_string(k));
      char name[32];
      std::snprintf(name, sizeof name, "frame_%05d.obj", k);
      const pid_t pid =
          start({"run", s.string(), "--out", out.string(), "--quiet", "--checkpoint-every", "0", "--format", formats});
      ASSERT_TRUE(wait_for(out / "frames" / name, pid)) << read_text(folder_ / "stderr.txt");
      ::kill(pid, SIGKILL);
      ASSERT_EQ(exit_status(pid), -SIGKILL);
      ASSERT_FALSE(fs::exists(out / "summary.json")) << "the run was killed before it finished";
      ASSERT_TRUE(fs::exists(out / "checkpoint.weft"));
      const auto resumed = weft("run --resume '" + out.string() + "' --quiet");
      ASSERT_EQ(resumed.exit_code, 0) << resumed.error_output;
      EXPECT_TRUE(outputs(out) == expected) << "frames and energy.csv differ from the uninterrupted run's";
      EXPECT_EQ(summary_without_timing(out), expected_summary);
      const weft::State state = final_state(s, out);
      EXPECT_TRUE(same_bits(state.x, expected_state.x)) << "final positions";
      EXPECT_TRUE(same_bits(state.v, expected_state.v)) << "final velocities";
      EXPECT_EQ(std::memcmp(&state.t, &expected_state.t, sizeof state.t), 0);
    }
  }
};

TEST_F(Checkpoint, KilledImplicitMidpointRunResumesToTheSameBytes) {
  // Adaptive damping on (the Implicit Midpoint default), warm starts from the solution history.
  expect_resumed_runs_match(R"({"method": "implicit-midpoint", "dt": 0.005})", {1, 9, 30});
}

TEST_F(Checkpoint, KilledBdf2RunResumesToTheSameBytes) {
  expect_resumed_runs_match(R"({"method": "bdf2", "dt": 0.005})", {2, 17});
}

TEST_F(Checkpoint, KilledRk45RunResumesToTheSameBytes) {
  // The adaptive step carried between frames is part of the state.
  expect_resumed_runs_match(R"({"method": "rk45", "dt": 0.005, "tolerance": 1e-5})", {6});
}

TEST_F(Checkpoint, KilledMultigridRunResumesToTheSameBytes) {
  // The hierarchy follows the first matrix's couplings: a resumed run must rebuild it from
  // that matrix, not from the first one it assembles.
  expect_resumed_runs_match(R"({"method": "implicit-midpoint", "dt": 0.005, "preconditioner": "multigrid"})", {12});
}

TEST_F(Checkpoint, KilledRunWithAnimationsResumesToTheSameGlbAndPc2) {
  // The glb and PC2 hold every frame of the run: those before the checkpoint come from the
  // frames recorded beside it.
  expect_resumed_runs_match(R"({"method": "implicit-midpoint", "dt": 0.005})", {9}, "obj,glb,pc2");
}

TEST_F(Checkpoint, CtrlCStopsWithStatus130AndAResumableCheckpoint) {
  const auto s = write("scene.json", scene(R"({"method": "implicit-midpoint", "dt": 0.005})"));
  const auto ref = folder_ / "reference";
  ASSERT_EQ(weft("run '" + s.string() + "' --out '" + ref.string() + "' --quiet").exit_code, 0);
  const auto out = folder_ / "out";
  const pid_t pid = start({"run", s.string(), "--out", out.string(), "--quiet"});
  ASSERT_TRUE(wait_for(out / "frames" / "frame_00005.obj", pid));
  ::kill(pid, SIGINT);
  const int status = exit_status(pid);
  const std::string err = read_text(folder_ / "stderr.txt");
  ASSERT_EQ(status, 130) << err;
  EXPECT_NE(err.find("weft run --resume"), std::string::npos) << err;
  // Frames, energies and summary so far, consistent with each other, and a checkpoint.
  const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
  EXPECT_EQ(summary["status"], "interrupted");
  const int frames = summary["frames"].get<int>();
  EXPECT_GE(frames, 6);
  const std::string csv = read_text(out / "energy.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), frames + 1);
  char name[32];
  std::snprintf(name, sizeof name, "frame_%05d.obj", frames - 1);
  EXPECT_TRUE(fs::exists(out / "frames" / name));
  std::snprintf(name, sizeof name, "frame_%05d.obj", frames);
  EXPECT_FALSE(fs::exists(out / "frames" / name));
  ASSERT_TRUE(fs::exists(out / "checkpoint.weft"));

  const auto resumed = weft("run --resume '" + out.string() + "' --quiet");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.error_output;
  EXPECT_TRUE(outputs(out) == outputs(ref));
  EXPECT_EQ(summary_without_timing(out), summary_without_timing(ref));
  // Without --checkpoint-every the finished run leaves no checkpoint behind.
  EXPECT_FALSE(fs::exists(out / "checkpoint.weft"));
}

TEST_F(Checkpoint, ResumeRefusesWhatItCannotContinue) {
  const auto s = write("scene.json", scene(R"({"method": "implicit-midpoint", "dt": 0.01})", "0.1"));
  const auto out = folder_ / "out";
  // No checkpoint in the folder.
  auto r = weft("run --resume '" + out.string() + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find((out / "checkpoint.weft").string() + ": no checkpoint to resume from"),
            std::string::npos) << r.error_output;
  ASSERT_EQ(weft("run '" + s.string() + "' --out '" + out.string() + "' --quiet --checkpoint-every 0").exit_code, 0);
  ASSERT_TRUE(fs::exists(out / "checkpoint.weft"));
  // Settings of its own: the run goes on with those it started with.
  r = weft("run --resume '" + out.string() + "' --dt 0.001");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("--dt cannot be combined with --resume"), std::string::npos) << r.error_output;
  // A damaged checkpoint.
  const std::string bytes = read_binary(out / "checkpoint.weft");
  std::string damaged = bytes;
  damaged[damaged.size() / 2] ^= 1;
  std::ofstream(out / "checkpoint.weft", std::ios::binary) << damaged;
  r = weft("run --resume '" + out.string() + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("checkpoint is damaged"), std::string::npos) << r.error_output;
  // A scene changed since.
  std::ofstream(out / "checkpoint.weft", std::ios::binary) << bytes;
  write("scene.json", scene(R"({"method": "implicit-midpoint", "dt": 0.01})", "0.2"));
  r = weft("run --resume '" + out.string() + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("the scene changed since the checkpoint"), std::string::npos) << r.error_output;
}
