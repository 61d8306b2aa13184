// `weft view`: the run folder read back (weft/run_folder.hpp) gives the same run from the glb as
// from the OBJ frames, the PLY frames' added viscosity frame by frame, and the command's bad
// input (a missing folder, a folder that is not a run's, a port in use) exits 2 with a message
// naming it. The page itself is tested in a browser: viewer/test/browser_test.mjs.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <cmath>

#include "weft/run_folder.hpp"
#include "support/command.hpp"

using weft::test::CommandTest;
using weft::test::read_text;
namespace fs = std::filesystem;

namespace {

// A 5 x 5 grid hung from two corners over a spinning sphere and a floor, 0.1 s at 0.02 s per
// frame (frames 0 to 5).
const char* kScene = R"({"weft_scene": 1, "duration": 0.1, "frame_interval": 0.02,
  "integrator": {"method": "implicit-midpoint", "dt": 0.01},
  "cloth": {"mesh": {"grid": {"size": [0.2, 0.2], "vertices": [5, 5]}},
            "placement": {"rotation_deg": [-90, 0, 0], "translation": [0, 1, 0]},
            "material": {"surface_density": 0.15, "weft": 100, "warp": 100, "shear": 10, "bending_rigidity": 1e-4},
            "pins": {"grid": [[0, 0], [-1, 0]]}},
  "colliders": [
    {"type": "sphere", "centre": [0, 0.3, 0], "radius": 0.1, "motion": {"angular_velocity_deg": [0, 90, 0], "centre": [0, 0.3, 0]}},
    {"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]}
  ]})";

class ViewCommand : public CommandTest {
 protected:
  // Runs the scene into folder_/NAME with --format `formats`; returns the folder.
  fs::path run(const std::string& name, const std::string& formats) {
    const fs::path scene = write("scene.json", kScene);
    const fs::path out = folder_ / name;
    const auto r = weft("run '" + scene.string() + "' --out '" + out.string() + "' --format " + formats);
    EXPECT_EQ(r.exit_code, 0) << r.error_output;
    return out;
  }
};

std::vector<double> energy_times(const fs::path& dir) {
  std::istringstream in(read_text(dir / "energy.csv"));
  std::string line;
  std::getline(in, line);
  std::vector<double> times;
  while (std::getline(in, line)) times.push_back(std::stod(line));
  return times;
}

TEST_F(ViewCommand, TheGlbAndTheObjFramesGiveTheSameRun) {
  const fs::path dir = run("run", "obj,glb");
  const weft::RunRecording from_glb = weft::read_run_folder(dir.string());
  fs::remove(dir / "animation.glb");
  const weft::RunRecording from_obj = weft::read_run_folder(dir.string());
  EXPECT_EQ(from_glb.positions_source, "glb");
  EXPECT_EQ(from_obj.positions_source, "obj");
  const std::vector<double> times = energy_times(dir);
  EXPECT_EQ(from_glb.times, times);
  EXPECT_EQ(from_obj.times, times);
  ASSERT_EQ(from_glb.meshes.size(), from_obj.meshes.size());
  ASSERT_EQ(from_obj.meshes.size(), 3u);  // the cloth, the sphere, the floor
  EXPECT_EQ(from_obj.meshes[0].name, "cloth");
  EXPECT_EQ(from_obj.meshes[0].vertex_count, 25);
  const int frames = static_cast<int>(times.size());
  for (size_t m = 0; m < from_obj.meshes.size(); ++m) {
    const weft::RunMesh &a = from_glb.meshes[m], &b = from_obj.meshes[m];
    SCOPED_TRACE(b.name);
    EXPECT_EQ(a.name, b.name);
    ASSERT_EQ(a.vertex_count, b.vertex_count);
    EXPECT_EQ(a.indices, b.indices);
    EXPECT_EQ(b.frames, frames);
    // The glb leaves out the frames of a collider that does not move.
    ASSERT_TRUE(a.frames == frames || a.frames == 1) << a.frames;
    const size_t n = 3 * static_cast<size_t>(a.vertex_count);
    double worst = 0;
    for (int f = 0; f < frames; ++f)
      for (size_t k = 0; k < n; ++k)
        worst = std::max(worst, std::abs(double(a.positions[std::min(f, a.frames - 1) * n + k]) - b.positions[f * n + k]));
    EXPECT_LT(worst, 1e-6);  // single precision of coordinates below 1 m, and the OBJ's 9 decimals
    ASSERT_EQ(a.texcoords.size(), b.texcoords.size());
    for (size_t k = 0; k < a.texcoords.size(); ++k) EXPECT_NEAR(a.texcoords[k], b.texcoords[k], 1e-6) << k;
  }
  EXPECT_EQ(from_obj.meshes[0].texcoords.size(), 50u);
  EXPECT_EQ(from_obj.meshes[1].frames, frames);  // the spinning sphere moves
  EXPECT_EQ(from_glb.meshes[1].frames, frames);
}

TEST_F(ViewCommand, PlyFramesGiveTheAddedViscosityOfEveryFrame) {
  const fs::path dir = run("run", "ply");
  const weft::RunRecording rec = weft::read_run_folder(dir.string());
  EXPECT_EQ(rec.positions_source, "ply");
  EXPECT_EQ(rec.viscosity_source, "ply");
  const weft::RunMesh& cloth = rec.meshes.front();
  ASSERT_EQ(cloth.viscosity_frames, cloth.frames);
  ASSERT_EQ(cloth.viscosity.size(), static_cast<size_t>(cloth.frames * cloth.vertex_count));
  const weft::PlyFrame last = weft::read_ply_frame(dir / "frames" / ("frame_0000" + std::to_string(cloth.frames - 1) + ".ply"));
  for (int i = 0; i < cloth.vertex_count; ++i)
    EXPECT_FLOAT_EQ(cloth.viscosity[(cloth.frames - 1) * cloth.vertex_count + i], static_cast<float>(last.added_viscosity[i]));
  EXPECT_TRUE(cloth.texcoords.empty());  // PLY frames hold none
}

TEST_F(ViewCommand, AMissingFolderExitsTwo) {
  const auto r = weft("view '" + (folder_ / "nowhere").string() + "' --no-open");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("nowhere: no such folder"), std::string::npos) << r.error_output;
}

TEST_F(ViewCommand, AFolderThatIsNotARunsExitsTwo) {
  const auto r = weft("view '" + folder_.string() + "' --no-open");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("not the output folder of a run (no summary.json"), std::string::npos) << r.error_output;

  // A summary without frames or a glb: nothing to play.
  fs::create_directories(folder_ / "empty");
  write("empty/summary.json", "{}");
  const auto e = weft("view '" + (folder_ / "empty").string() + "' --no-open");
  EXPECT_EQ(e.exit_code, 2);
  EXPECT_NE(e.error_output.find("empty: no frames to play"), std::string::npos) << e.error_output;
}

TEST_F(ViewCommand, AFrameOfAnotherMeshIsNamed) {
  const fs::path dir = run("run", "obj");
  fs::copy_file(dir / "frames" / "collider0_00000.obj", dir / "frames" / "frame_00002.obj", fs::copy_options::overwrite_existing);
  const auto r = weft("view '" + dir.string() + "' --no-open");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("frame_00002.obj: "), std::string::npos) << r.error_output;
  EXPECT_NE(r.error_output.find("not the mesh of"), std::string::npos) << r.error_output;
}

TEST_F(ViewCommand, TheRunsUvScaleReachesThePageAndABadOneIsNamed) {
  const fs::path dir = run("run", "glb");
  EXPECT_EQ(weft::read_run_folder(dir.string()).uv_scale, 1.0);  // a grid cloth
  std::string summary = read_text(dir / "summary.json");
  const std::string key = "\"uv_scale\": 1.0";
  ASSERT_NE(summary.find(key), std::string::npos);
  std::ofstream(dir / "summary.json") << summary.replace(summary.find(key), key.size(), "\"uv_scale\": 0.25");
  EXPECT_EQ(weft::read_run_folder(dir.string()).uv_scale, 0.25);
  summary = read_text(dir / "summary.json");
  const std::string scaled = "\"uv_scale\": 0.25";
  std::ofstream(dir / "summary.json") << summary.replace(summary.find(scaled), scaled.size(), "\"uv_scale\": \"wide\"");
  const auto r = weft("view '" + dir.string() + "' --no-open");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("summary.json: uv_scale \"wide\": expected a number > 0"), std::string::npos) << r.error_output;
}

TEST_F(ViewCommand, APortInUseExitsTwo) {
  const fs::path dir = run("run", "glb");
  // Hold a port on 127.0.0.1 for the duration of the test.
  const int sock = ::socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(sock, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  ASSERT_EQ(::bind(sock, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  ASSERT_EQ(::listen(sock, 1), 0);
  socklen_t length = sizeof address;
  ASSERT_EQ(::getsockname(sock, reinterpret_cast<sockaddr*>(&address), &length), 0);
  const int port = ntohs(address.sin_port);
  const auto r = weft("view '" + dir.string() + "' --no-open --port " + std::to_string(port));
  ::close(sock);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("cannot listen on 127.0.0.1:" + std::to_string(port) + ": the port is in use"), std::string::npos)
      << r.error_output;
}

}  // namespace
