// The `weft body` command.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "body/body_fixture.hpp"
#include "weft/body.hpp"
#include "weft/error.hpp"

namespace weft {
namespace {

int run_weft(const std::string& arguments, const std::filesystem::path& log) {
  const std::string command =
      std::string(WEFT_EXE) + " " + arguments + " > " + log.string() + " 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST(BodyCommand, WritesFramesAndSummary) {
  const auto dir = test::scratch_dir("command");
  const auto out = dir / "walk";
  ASSERT_EQ(run_weft("body --fps 5 --skinning dqs --out " + out.string(), dir / "log.txt"), 0)
      << read_text(dir / "log.txt");
  const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
  const int frames = summary.at("frames").get<int>();
  EXPECT_EQ(frames, static_cast<int>(std::floor(summary.at("motion_duration_s").get<double>() * 5)) + 1);
  EXPECT_GT(summary.at("distance_walked_m").get<double>(), 3.0);
  EXPECT_GT(summary.at("skinning_ms_per_frame").get<double>(), 0.0);
  EXPECT_EQ(summary.at("skinning"), "dqs");
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(out / "frames")) {
    EXPECT_EQ(entry.path().extension(), ".obj") << "no temporary file is left behind";
    ++files;
  }
  EXPECT_EQ(files, frames);
  // A frame is a whole body: same vertex and triangle counts as the shipped mesh.
  const ObjMesh last = read_obj((out / "frames" / "body_00019.obj").string());
  EXPECT_EQ(last.positions.rows(), test::shipped_body().vertex_count());
  EXPECT_EQ(last.triangles.rows(), test::shipped_body().triangles().rows());
}

TEST(BodyCommand, BadInputWritesNothing) {
  const auto dir = test::scratch_dir("command_bad");
  const auto bad_motion = dir / "bad.bvh";
  std::ofstream(bad_motion) << "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0\n";
  const std::vector<std::string> cases = {
      "--skinning linear", "--speed -1", "--fps 0", "--motion " + bad_motion.string(),
      "--motion " + (dir / "missing.bvh").string(), "--start-time 100"};
  for (const auto& arguments : cases) {
    const auto out = dir / "out";
    EXPECT_EQ(run_weft("body " + arguments + " --out " + out.string(), dir / "log.txt"), 2)
        << arguments;
    EXPECT_FALSE(std::filesystem::exists(out)) << arguments;
    EXPECT_NE(read_text(dir / "log.txt").find("error"), std::string::npos) << arguments;
  }
  // The malformed file's error names its line.
  run_weft("body --motion " + bad_motion.string() + " --out " + (dir / "out").string(),
           dir / "log.txt");
  EXPECT_NE(read_text(dir / "log.txt").find("bad.bvh:4:"), std::string::npos)
      << read_text(dir / "log.txt");
}

}  // namespace
}  // namespace weft
