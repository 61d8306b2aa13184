// `weft check DIR` end to end on crafted frame folders (exit statuses, messages, the JSON
// counts), and the intersection counts `weft run` puts in summary.json.
#include <cstdio>
#include <nlohmann/json.hpp>

#include "support/command.hpp"

using weft::test::CommandTest;
using weft::test::read_text;

namespace {

// A flat 1 m square in z = 0 as two triangles.
const char* kFlat =
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
    "f 1 2 3\nf 1 3 4\n";

// The square and, as separate vertices, a vertical square through it at x = 0.5: each of the
// two vertical triangles crosses the horizontal ones.
const char* kCrossing =
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
    "v 0.5 0.25 -0.5\nv 0.5 0.75 -0.5\nv 0.5 0.75 0.5\nv 0.5 0.25 0.5\n"
    "f 1 2 3\nf 1 3 4\nf 5 6 7\nf 5 7 8\n";

// A body triangle through the flat square.
const char* kBodyThrough = "v 0.3 0.3 -1\nv 0.4 0.3 1\nv 0.3 0.4 1\nf 1 2 3\n";
// A body triangle 1 mm above it.
const char* kBodyAbove = "v 0.3 0.3 0.001\nv 0.4 0.3 1\nv 0.3 0.4 1\nf 1 2 3\n";

class CheckCommand : public CommandTest {
 protected:
  std::filesystem::path frames() {
    const auto p = folder_ / "run" / "frames";
    std::filesystem::create_directories(p);
    return p;
  }
  void frame(const std::string& name, const std::string& text) { std::ofstream(frames() / name) << text; }

  // Runs `weft check` with its standard output captured; returns the exit status.
  int check_json(const std::string& arguments, nlohmann::json& out) {
    const auto file = folder_ / "stdout.json";
    std::string command = "'";
    command.append(WEFT_EXE).append("' check ").append(arguments).append(" --json > '");
    command.append(file.string()).append("' 2> /dev/null");
    const int status = std::system(command.c_str());
    const std::string text = read_text(file);
    out = text.empty() ? nlohmann::json() : nlohmann::json::parse(text);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  // The run folder, quoted for the shell.
  std::string run_dir() const { return std::string("'").append((folder_ / "run").string()).append("'"); }
};

TEST_F(CheckCommand, CleanFramesExitZero) {
  frame("frame_00000.obj", kFlat);
  frame("frame_00001.obj", kFlat);
  frame("body0_00000.obj", kBodyAbove);
  frame("body0_00001.obj", kBodyAbove);
  const auto r = weft("check " + run_dir());
  EXPECT_EQ(r.exit_code, 0) << r.error_output;
  nlohmann::json j;
  ASSERT_EQ(check_json(run_dir(), j), 0);
  EXPECT_EQ(j["frames"], 2);
  EXPECT_EQ(j["total"], 0);
  EXPECT_TRUE(j["worst_frame"].is_null());
}

TEST_F(CheckCommand, IntersectionsExitFiveWithCountsPerFrame) {
  frame("frame_00000.obj", kFlat);
  frame("frame_00001.obj", kCrossing);
  frame("frame_00002.obj", kFlat);
  frame("body0_00002.obj", kBodyThrough);
  EXPECT_EQ(weft("check " + run_dir()).exit_code, 5);
  nlohmann::json j;
  ASSERT_EQ(check_json(run_dir(), j), 5);
  ASSERT_EQ(j["per_frame"].size(), 3u);
  EXPECT_EQ(j["per_frame"][0]["cloth_self"], 0);
  // Vertical triangles (2, 3) each cross both horizontal ones (0, 1): 4 pairs.
  EXPECT_EQ(j["per_frame"][1]["cloth_self"], 4);
  EXPECT_EQ(j["per_frame"][1]["cloth_self_examples"], nlohmann::json::parse("[[0,2],[0,3],[1,2]]"));
  EXPECT_EQ(j["per_frame"][1]["cloth_body"], 0);
  // The body triangle meets z = 0 along x + y = 0.65, x and y in [0.3, 0.35], which crosses
  // the square's diagonal: both of its triangles.
  EXPECT_EQ(j["per_frame"][2]["cloth_body"], 2);
  EXPECT_EQ(j["per_frame"][2]["cloth_self"], 0);
  EXPECT_EQ(j["worst_frame"], 1);
  EXPECT_EQ(j["worst_count"], 4);
  EXPECT_EQ(j["total"], 6);
  EXPECT_EQ(j["frames_with_intersections"], 2);
}

TEST_F(CheckCommand, ReadsPlyFrames) {
  frame("frame_00000.ply",
        "ply\nformat ascii 1.0\ncomment weft frame\nelement vertex 8\nproperty float x\nproperty float y\n"
        "property float z\nproperty float added_viscosity\nelement face 4\nproperty list uchar int vertex_indices\n"
        "end_header\n0 0 0 0\n1 0 0 0\n1 1 0 0\n0 1 0 0\n0.5 0.25 -0.5 0\n0.5 0.75 -0.5 0\n0.5 0.75 0.5 0\n"
        "0.5 0.25 0.5 0\n3 0 1 2\n3 0 2 3\n3 4 5 6\n3 4 6 7\n");
  nlohmann::json j;
  ASSERT_EQ(check_json(run_dir(), j), 5);
  EXPECT_EQ(j["per_frame"][0]["cloth_self"], 4);
}

TEST_F(CheckCommand, BadFoldersExitTwoWithAMessage) {
  auto r = weft("check '" + (folder_ / "nowhere").string() + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("nowhere: no such folder"), std::string::npos) << r.error_output;

  std::filesystem::create_directories(folder_ / "run");
  r = weft("check " + run_dir());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("run/frames: no such folder"), std::string::npos) << r.error_output;

  frames();
  r = weft("check " + run_dir());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("frames: no frames"), std::string::npos) << r.error_output;

  frame("frame_00000.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
  r = weft("check " + run_dir());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("frame_00000.obj:4:"), std::string::npos) << r.error_output;

  frame("frame_00000.obj", kFlat);
  frame("body0_00001.obj", kBodyAbove);
  r = weft("check " + run_dir());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("body0_00001.obj: a body frame without its cloth frame"), std::string::npos)
      << r.error_output;
  std::filesystem::remove(frames() / "body0_00001.obj");

  frame("frame_00000.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                           "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                           "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  r = weft("check " + run_dir());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("frame 00000 is also in"), std::string::npos) << r.error_output;
  std::filesystem::remove(frames() / "frame_00000.obj");

  frame("frame_00000.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                           "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                           "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
  r = weft("check " + run_dir());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("frame_00000.ply:13: expected a face of vertex indices in [0, 3), got '3 0 1 7'"),
            std::string::npos)
      << r.error_output;
}

// A scene whose cloth is kCrossing, every vertex pinned: the same intersections in every frame.
std::string crossing_scene() {
  return R"({"weft_scene": 1, "duration": 0.04, "frame_interval": 0.02,
  "integrator": {"method": "implicit-midpoint", "dt": 0.01},
  "cloth": {"mesh": {"obj": "crossing.obj"},
            "material": {"surface_density": 0.15, "weft": 100, "warp": 100, "shear": 10, "bending_rigidity": 1e-4},
            "pins": {"vertices": [0, 1, 2, 3, 4, 5, 6, 7]}}})";
}

// The crossing mesh with texture coordinates, so each square has a flat pattern of its own.
const char* kCrossingWithUv =
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
    "v 0.5 0.25 -0.5\nv 0.5 0.75 -0.5\nv 0.5 0.75 0.5\nv 0.5 0.25 0.5\n"
    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 2 0\nvt 2.5 0\nvt 2.5 1\nvt 2 1\n"
    "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\nf 5/5 6/6 7/7\nf 5/5 7/7 8/8\n";

TEST_F(CheckCommand, RunCountsIntersectionsInTheSummaryAsCheckDoes) {
  write("crossing.obj", kCrossingWithUv);
  const auto scene = write("scene.json", crossing_scene());
  for (const char* extra : {"", " --no-frames"}) {
    // A run whose frames cross finishes, says so (quiet or not) and exits as `weft check` does.
    const auto r = weft("run '" + scene.string() + "' --out " + run_dir() + " --quiet" + extra);
    ASSERT_EQ(r.exit_code, 5) << r.error_output;
    EXPECT_NE(r.error_output.find("weft: warning: 3 of 3 frames have intersecting triangle pairs (12 in all; the "
                                  "worst, frame 0, 4); `weft check " + (folder_ / "run").string() + "` lists them."),
              std::string::npos)
        << r.error_output;
    const auto summary = nlohmann::json::parse(read_text(folder_ / "run" / "summary.json"));
    const auto& in = summary["intersections"];
    EXPECT_EQ(in["per_frame"], nlohmann::json::parse("[4, 4, 4]")) << extra;
    EXPECT_EQ(in["cloth_self_per_frame"], nlohmann::json::parse("[4, 4, 4]"));
    EXPECT_EQ(in["total"], 12);
    EXPECT_EQ(in["worst_frame"], 0);
    EXPECT_EQ(in["worst_count"], 4);
    EXPECT_EQ(in["first_frame"], 0);
  }
  // The frames written by a run (without --no-frames) give `weft check` the same counts.
  ASSERT_EQ(weft("run '" + scene.string() + "' --out " + run_dir() + " --quiet").exit_code, 5);
  nlohmann::json j;
  ASSERT_EQ(check_json(run_dir(), j), 5);
  EXPECT_EQ(j["total"], 12);
}

TEST_F(CheckCommand, RunOfACleanSceneCountsZeroPerFrame) {
  write("flat.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n");
  std::string scene = crossing_scene();
  scene.replace(scene.find("crossing.obj"), 12, "flat.obj");
  scene.replace(scene.find("[0, 1, 2, 3, 4, 5, 6, 7]"), 24, "[0, 1]");
  const auto s = write("scene.json", scene);
  const auto r = weft("run '" + s.string() + "' --out " + run_dir() + " --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.error_output;
  const auto in = nlohmann::json::parse(read_text(folder_ / "run" / "summary.json"))["intersections"];
  EXPECT_EQ(in["per_frame"], nlohmann::json::parse("[0, 0, 0]"));
  EXPECT_EQ(in["total"], 0);
  EXPECT_TRUE(in["worst_frame"].is_null());
  EXPECT_EQ(weft("check " + run_dir()).exit_code, 0);
}

}  // namespace
