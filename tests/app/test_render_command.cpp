// `weft render` end to end: the cloth's pixels against its projected area for a given camera,
// the automatic camera framing it, the default frames of a short run, the video through
// ffmpeg, and the refusals of bad input (exit 2, a message naming it, nothing written).
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <set>

#include "weft/run_folder.hpp"
#include "weft/render/appearance.hpp"
#include "support/command.hpp"
#include "support/png.hpp"
#include "weft/types.hpp"

using weft::Vec2;
using weft::Vec3;
using weft::test::CommandTest;
using weft::test::read_png;
namespace fs = std::filesystem;

namespace {

// A 0.6 m square in the plane z = 0 around (0, 1, 0), facing +Z, as two triangles with
// texture coordinates in metres.
const std::array<Vec3, 4> kSquare{Vec3(-0.3, 0.7, 0), Vec3(0.3, 0.7, 0), Vec3(0.3, 1.3, 0), Vec3(-0.3, 1.3, 0)};

std::string square_obj(double dz) {
  std::string s;
  for (const Vec3& p : kSquare) s += "v " + std::to_string(p.x()) + " " + std::to_string(p.y()) + " " + std::to_string(p.z() + dz) + "\n";
  s += "vt 0 0\nvt 0.6 0\nvt 0.6 0.6\nvt 0 0.6\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
  return s;
}

class RenderCommand : public CommandTest {
 protected:
  // A run folder with frames 0 to 4 of the square (moving 1 cm along z per frame).
  fs::path run_folder() {
    const fs::path run = folder_ / "run";
    fs::create_directories(run / "frames");
    for (int f = 0; f < 5; ++f) {
      char name[32];
      std::snprintf(name, sizeof name, "frame_%05d.obj", f);
      std::ofstream(run / "frames" / name) << square_obj(0.01 * f);
    }
    std::ofstream(run / "summary.json") << R"({"frame_interval": 0.02})";
    return run;
  }
  std::string quoted(const fs::path& p) const { return "'" + p.string() + "'"; }
};

// Pixels that differ from the background. Without the ground the background is the same all
// along a row, so each row's first pixel (which the cloth does not reach) gives it.
int cloth_pixels(const weft::test::PngInfo& png, bool* touches_border = nullptr) {
  int count = 0;
  if (touches_border) *touches_border = false;
  for (unsigned y = 0; y < png.height; ++y) {
    const std::uint8_t* row = png.pixels.data() + 3 * static_cast<size_t>(y) * png.width;
    for (unsigned x = 1; x < png.width; ++x) {
      bool differs = false;
      for (int c = 0; c < 3; ++c) differs = differs || std::abs(row[3 * x + c] - row[c]) > 6;
      if (!differs) continue;
      ++count;
      if (touches_border && (x + 1 == png.width || y == 0 || y + 1 == png.height)) *touches_border = true;
    }
  }
  return count;
}

TEST_F(RenderCommand, ClothPixelsCoverItsProjectedArea) {
  const fs::path run = run_folder(), out = folder_ / "pictures";
  const int width = 200, height = 160;
  const Vec3 eye(0.4, 1.2, 2.5), target(0, 1, 0);
  const double fov_deg = 30;
  const auto r = weft("render " + quoted(run) + " --out " + quoted(out) +
                      " --camera 0.4,1.2,2.5,0,1,0,30 --size 200x160 --frames 0 --no-ground --no-caption");
  ASSERT_EQ(r.exit_code, 0) << r.error_output;
  const auto png = read_png(out / "frame_00000.png");
  ASSERT_TRUE(png.signature_ok);
  ASSERT_EQ(png.color_type, PNG_COLOR_TYPE_RGB);
  ASSERT_EQ(png.width, static_cast<unsigned>(width));
  ASSERT_EQ(png.height, static_cast<unsigned>(height));

  // The square's image through a pinhole camera at `eye` looking at `target`, Y up.
  const Vec3 forward = (target - eye).normalized();
  const Vec3 right = forward.cross(Vec3::UnitY()).normalized(), up = right.cross(forward);
  const double focal = 0.5 * height / std::tan(0.5 * fov_deg * M_PI / 180);
  std::array<Vec2, 4> image;
  for (int k = 0; k < 4; ++k) {
    const Vec3 d = kSquare[k] - eye;
    image[k] = Vec2(0.5 * width + focal * d.dot(right) / d.dot(forward), 0.5 * height - focal * d.dot(up) / d.dot(forward));
  }
  double area = 0, perimeter = 0;
  for (int k = 0; k < 4; ++k) {
    const Vec2 &p = image[k], &q = image[(k + 1) % 4];
    area += 0.5 * (p.x() * q.y() - p.y() * q.x());
    perimeter += (q - p).norm();
  }
  area = std::abs(area);
  ASSERT_GT(area, 1000);  // the test means something only if the square is well in view
  // Inside pixels all count; a pixel on the outline counts when the cloth covers enough of it
  // to change its colour by more than 6 levels, so the count can be off by at most the
  // pixels the outline crosses (about its length, plus the corners).
  EXPECT_NEAR(cloth_pixels(png), area, perimeter + 8) << "projected area " << area;
}

TEST_F(RenderCommand, TheAutomaticCameraFramesTheCloth) {
  const fs::path run = run_folder(), out = folder_ / "pictures";
  const auto r = weft("render " + quoted(run) + " --out " + quoted(out) + " --size 160x120 --frames 0,4 --no-ground --no-caption");
  ASSERT_EQ(r.exit_code, 0) << r.error_output;
  for (const char* name : {"frame_00000.png", "frame_00004.png"}) {
    const auto png = read_png(out / name);
    ASSERT_TRUE(png.signature_ok) << name;
    bool touches_border = true;
    const int pixels = cloth_pixels(png, &touches_border);
    // Framed: a good part of the picture, and all of the cloth inside it.
    EXPECT_GT(pixels, 160 * 120 / 10) << name;
    EXPECT_FALSE(touches_border) << name;
  }
  std::set<std::string> files;
  for (const auto& e : fs::directory_iterator(out)) files.insert(e.path().filename().string());
  EXPECT_EQ(files, (std::set<std::string>{"frame_00000.png", "frame_00004.png"}));
}

TEST_F(RenderCommand, DrawsFourFramesSpreadOverAShortRun) {
  const auto scene = write("scene.json", R"({"weft_scene": 1, "duration": 0.1, "frame_interval": 0.02,
    "integrator": {"method": "implicit-midpoint", "dt": 0.02},
    "cloth": {"mesh": {"grid": {"size": [0.2, 0.2], "vertices": [4, 4]}},
              "placement": {"rotation_deg": [-90, 0, 0], "translation": [0, 1, 0]},
              "material": {"surface_density": 0.15, "weft": 100, "warp": 100, "shear": 10, "bending_rigidity": 1e-4},
              "pins": {"grid": [[0, 0], [-1, 0]]}},
    "colliders": [{"type": "sphere", "centre": [0.1, 0.6, -0.1], "radius": 0.1},
                  {"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]}]})");
  const fs::path run = folder_ / "run", out = folder_ / "pictures";
  ASSERT_EQ(weft("run " + quoted(scene) + " --out " + quoted(run)).exit_code, 0);
  const auto r = weft("render " + quoted(run) + " --out " + quoted(out) + " --size 96x72 --samples 2");
  ASSERT_EQ(r.exit_code, 0) << r.error_output;
  // Frames 0 to 5: four spread evenly are 0, 5/3, 10/3 and 5, rounded.
  std::set<std::string> files;
  for (const auto& e : fs::directory_iterator(out)) files.insert(e.path().filename().string());
  EXPECT_EQ(files, (std::set<std::string>{"frame_00000.png", "frame_00002.png", "frame_00003.png", "frame_00005.png"}));
  const auto png = read_png(out / "frame_00005.png");
  EXPECT_EQ(png.width, 96u);
  EXPECT_EQ(png.height, 72u);
}

TEST_F(RenderCommand, VideoThroughFfmpeg) {
  if (std::system("command -v ffmpeg > /dev/null 2>&1") != 0) GTEST_SKIP() << "ffmpeg is not installed (make deps installs it)";
  const fs::path run = run_folder(), out = folder_ / "video";
  const auto r = weft("render " + quoted(run) + " --out " + quoted(out) + " --video --size 64x48 --samples 1");
  ASSERT_EQ(r.exit_code, 0) << r.error_output;
  std::ifstream in(out / "render.mp4", std::ios::binary);
  char head[8] = {};
  in.read(head, 8);
  EXPECT_EQ(std::string(head + 4, 4), "ftyp");  // an MP4 file starts with its ftyp box
  size_t files = 0;
  for (const auto& e : fs::directory_iterator(out)) files += e.path().filename() != "render.mp4";
  EXPECT_EQ(files, 0u);  // no temporary file or picture left beside it
}

TEST_F(RenderCommand, BadInputExitsTwoNamingItAndWritesNothing) {
  const fs::path run = run_folder(), out = folder_ / "pictures";
  const std::string dir = quoted(run) + " --out " + quoted(out);
  const std::vector<std::pair<std::string, std::string>> cases{
      {quoted(folder_ / "nowhere") + " --out " + quoted(out), "nowhere: no such folder"},
      {dir + " --frames 0,x", "--frames '0,x': 'x' is not a frame number"},
      {dir + " --frames 9", "--frames '9': no frame 9 (the run has frames 0 to 4)"},
      {dir + " --frames 3-1", "the range '3-1' runs backwards"},
      {dir + " --camera 1,2,3", "--camera '1,2,3': 3 numbers"},
      {dir + " --camera 1,2,x,0,0,0", "--camera '1,2,x,0,0,0': 'x' is not a number"},
      {dir + " --camera 0,1,0,0,1,0", "the eye and the target are the same point"},
      {dir + " --camera 0,3,0,0,1,0", "the view is straight up or down"},
      {dir + " --camera 0,1,3,0,1,0,0", "field of view"},
      {dir + " --size 10x10", "--size '10x10'"},
      {dir + " --size 960", "--size '960'"},
      {dir + " --video --size 161x120", "needs an even width and height"},
      {dir + " --color rainbow", "--color 'rainbow'"},
      {dir + " --color viscosity", "--color viscosity reads the added viscosity of PLY frames"},
      {dir + " --color strain --uv-scale -2", "--uv-scale -2: expected a number > 0"},
  };
  for (const auto& [arguments, message] : cases) {
    const auto r = weft("render " + arguments);
    EXPECT_EQ(r.exit_code, 2) << arguments;
    EXPECT_NE(r.error_output.find(message), std::string::npos) << arguments << " -> " << r.error_output;
    EXPECT_FALSE(fs::exists(out)) << arguments << ": wrote something";
  }
  // A summary whose uv_scale is not a scale, for --color strain.
  std::ofstream(run / "summary.json") << R"({"frame_interval": 0.02, "uv_scale": -1})";
  const auto scale = weft("render " + dir + " --color strain");
  EXPECT_EQ(scale.exit_code, 2);
  EXPECT_NE(scale.error_output.find("summary.json: uv_scale -1: expected a number > 0"), std::string::npos) << scale.error_output;
  EXPECT_FALSE(fs::exists(out));
  std::ofstream(run / "summary.json") << R"({"frame_interval": 0.02})";
  // Without ffmpeg on the PATH, --video says so.
  const auto r = weft("render " + dir + " --video", "PATH=/nowhere");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("ffmpeg not found on the PATH"), std::string::npos) << r.error_output;
  EXPECT_FALSE(fs::exists(out));
  // A frame that cannot be read stops the command before any picture is written.
  std::ofstream(run / "frames" / "frame_00003.obj") << "v 0 0 0\nf 1 2 3\n";
  const auto bad = weft("render " + dir);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.error_output.find("frame_00003.obj:2:"), std::string::npos) << bad.error_output;
  EXPECT_FALSE(fs::exists(out));
}

// The strain scale `weft render --color strain ARGUMENTS` prints (in %), or -1 when it fails.
double printed_strain_scale(const fs::path& folder, const std::string& arguments) {
  const fs::path out = folder / "stdout.txt";
  const int status = std::system(("'" + std::string(WEFT_EXE) + "' render " + arguments + " --color strain > '" + out.string() +
                                  "' 2> /dev/null").c_str());
  const std::string text = weft::test::read_text(out);
  const size_t at = text.find("colour scale: strain -");
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || at == std::string::npos) return -1;
  return std::stod(text.substr(at + std::strlen("colour scale: strain -")));
}

TEST_F(RenderCommand, AnObjClothAtRestShowsNoStrainWithTheRunsUvScale) {
  // A 0.5 m square of 3 x 3 vertices whose texture coordinates are in units of 2.5 m, without
  // gravity: it stays at rest, so its strain is 0 when the texture coordinates are read times
  // 2.5, and 1.5 (150%) when read as metres.
  std::string obj;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) obj += "v " + std::to_string(0.25 * i) + " " + std::to_string(0.25 * j) + " 0\n";
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) obj += "vt " + std::to_string(0.1 * i) + " " + std::to_string(0.1 * j) + "\n";
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      const std::string a = std::to_string(3 * j + i + 1), b = std::to_string(3 * j + i + 2), c = std::to_string(3 * j + i + 5),
                        d = std::to_string(3 * j + i + 4);
      obj += "f " + a + "/" + a + " " + b + "/" + b + " " + c + "/" + c + "\nf " + a + "/" + a + " " + c + "/" + c + " " + d + "/" + d + "\n";
    }
  write("square.obj", obj);
  const auto scene = write("scene.json", R"({"weft_scene": 1, "duration": 0.04, "frame_interval": 0.02, "gravity": [0, 0, 0],
    "integrator": {"method": "implicit-midpoint", "dt": 0.02},
    "cloth": {"mesh": {"obj": "square.obj", "uv_scale": 2.5},
              "material": {"surface_density": 0.15, "weft": 100, "warp": 100, "shear": 10, "bending_rigidity": 1e-4}}})");
  const fs::path run = folder_ / "run";
  const auto r = weft("run " + quoted(scene) + " --out " + quoted(run) + " --format obj");
  ASSERT_EQ(r.exit_code, 0) << r.error_output;
  EXPECT_NE(weft::test::read_text(run / "summary.json").find("\"uv_scale\": 2.5"), std::string::npos);

  // weft render takes the scale from the run; --uv-scale overrides it.
  const std::string dir = quoted(run) + " --out " + quoted(folder_ / "pictures") + " --size 64x48 --samples 1";
  const double at_rest = printed_strain_scale(folder_, dir);
  ASSERT_GE(at_rest, 0);
  EXPECT_LT(at_rest, 1e-3);  // % (the OBJ frames' decimals)
  EXPECT_NEAR(printed_strain_scale(folder_, dir + " --uv-scale 1"), 150, 1e-3);

  // The viewer's data: the run folder reader gives the scale with the per-vertex texture
  // coordinates, from which the page computes the same strain (tests/render/test_appearance.cpp).
  const weft::RunRecording rec = weft::read_run_folder(run.string());
  EXPECT_EQ(rec.uv_scale, 2.5);
  const weft::RunMesh& cloth = rec.meshes.front();
  std::vector<std::array<int, 3>> triangles;
  std::vector<double> corner_uv;
  for (size_t t = 0; 3 * t < cloth.indices.size(); ++t) {
    triangles.push_back({int(cloth.indices[3 * t]), int(cloth.indices[3 * t + 1]), int(cloth.indices[3 * t + 2])});
    for (int k : triangles.back()) corner_uv.insert(corner_uv.end(), {cloth.texcoords[2 * k], cloth.texcoords[2 * k + 1]});
  }
  const size_t n = 3 * static_cast<size_t>(cloth.vertex_count);
  for (int f = 0; f < cloth.frames; ++f) {
    const std::vector<double> xyz(cloth.positions.begin() + f * n, cloth.positions.begin() + (f + 1) * n);
    for (double v : weft::render::vertex_strain(xyz, triangles, corner_uv, rec.uv_scale)) EXPECT_LT(std::abs(v), 1e-5) << "frame " << f;
  }
}

}  // namespace

namespace {

// Pixels (of the same-sized pictures a and b, from row `from` down) whose colours differ by more
// than `tolerance` in some channel.
int differing_pixels(const weft::test::PngInfo& a, unsigned ax, const weft::test::PngInfo& b, unsigned bx, unsigned width,
                     unsigned from, int tolerance = 0) {
  int count = 0;
  for (unsigned y = from; y < a.height; ++y)
    for (unsigned x = 0; x < width; ++x) {
      const std::uint8_t* p = a.pixels.data() + 3 * (static_cast<size_t>(y) * a.width + ax + x);
      const std::uint8_t* q = b.pixels.data() + 3 * (static_cast<size_t>(y) * b.width + bx + x);
      bool differs = false;
      for (int c = 0; c < 3; ++c) differs = differs || std::abs(p[c] - q[c]) > tolerance;
      count += differs;
    }
  return count;
}

}  // namespace

TEST_F(RenderCommand, BesideDrawsTwoRunsSideBySideWithOneCameraAndLabels) {
  const fs::path run = run_folder(), copy = folder_ / "copy", out = folder_ / "both", alone = folder_ / "alone";
  fs::copy(run, copy, fs::copy_options::recursive);
  const std::string common = " --size 160x120 --frames 2 --no-ground --no-caption";
  const auto r = weft("render " + quoted(run) + " --beside " + quoted(copy) + " --labels 'Left,right' --out " + quoted(out) + common);
  ASSERT_EQ(r.exit_code, 0) << r.error_output;
  ASSERT_EQ(weft("render " + quoted(run) + " --out " + quoted(alone) + common).exit_code, 0);
  const auto both = read_png(out / "frame_00002.png"), one = read_png(alone / "frame_00002.png");
  ASSERT_TRUE(both.signature_ok);
  ASSERT_EQ(both.width, 320u);
  ASSERT_EQ(both.height, 120u);
  // Below the labels (7 font pixels at scale 2 from row 8), each half is the run drawn alone:
  // the same frames frame the same camera.
  const unsigned below_labels = 24;
  EXPECT_EQ(differing_pixels(both, 0, one, 0, 160, below_labels), 0);
  EXPECT_EQ(differing_pixels(both, 160, one, 0, 160, below_labels), 0);
  EXPECT_GT(cloth_pixels(one), 160 * 120 / 10);
  // The labels are drawn over each half (and only there: the rows below are the pictures').
  EXPECT_GT(differing_pixels(both, 0, one, 0, 160, 0), 0);
  EXPECT_GT(differing_pixels(both, 160, one, 0, 160, 0), 0);
}

TEST_F(RenderCommand, BesideRefusesRunsWithoutTheFramesAndBadLabels) {
  const fs::path run = run_folder(), other = folder_ / "other", out = folder_ / "pictures";
  fs::copy(run, other, fs::copy_options::recursive);
  fs::remove(other / "frames" / "frame_00004.obj");
  const std::string dir = quoted(run) + " --out " + quoted(out);
  const std::vector<std::pair<std::string, std::string>> cases{
      {dir + " --beside " + quoted(folder_ / "nowhere"), "nowhere: no such folder"},
      {dir + " --beside " + quoted(other) + " --frames 3,4", "no frame 4 (it has frames 0 to 3; choose frames both runs have"},
      {dir + " --labels a,b", "--labels: only with --beside"},
      {dir + " --beside " + quoted(other) + " --frames 0 --labels ab", "--labels 'ab': expected LEFT,RIGHT"},
      {dir + " --beside " + quoted(other) + " --frames 0 --labels a,b,c", "--labels 'a,b,c': expected LEFT,RIGHT"},
  };
  for (const auto& [arguments, message] : cases) {
    const auto r = weft("render " + arguments);
    EXPECT_EQ(r.exit_code, 2) << arguments;
    EXPECT_NE(r.error_output.find(message), std::string::npos) << arguments << " -> " << r.error_output;
    EXPECT_FALSE(fs::exists(out)) << arguments << ": wrote something";
  }
}

TEST_F(RenderCommand, FollowKeepsTheViewOfAMovingCloth) {
  // The square moves 4 cm towards the camera from frame 0 to frame 4: the fixed camera sees it
  // grow; the following one moves with it and sees the same picture.
  const fs::path run = run_folder(), fixed = folder_ / "fixed", follow = folder_ / "follow";
  const std::string common = " --size 160x120 --frames 0,4 --no-ground --no-caption";
  ASSERT_EQ(weft("render " + quoted(run) + " --out " + quoted(fixed) + common).exit_code, 0);
  const auto r = weft("render " + quoted(run) + " --out " + quoted(follow) + common + " --follow");
  ASSERT_EQ(r.exit_code, 0) << r.error_output;
  const auto f0 = read_png(follow / "frame_00000.png"), f4 = read_png(follow / "frame_00004.png");
  const auto s0 = read_png(fixed / "frame_00000.png"), s4 = read_png(fixed / "frame_00004.png");
  const int area = cloth_pixels(f0);
  ASSERT_GT(area, 160 * 120 / 10);
  // Rasterising the same view from a camera moved by 4 cm may round an edge pixel or two
  // differently; the fixed camera's pictures differ all along the square's outline.
  const int followed = differing_pixels(f0, 0, f4, 0, 160, 0, 8);
  const int fixed_camera = differing_pixels(s0, 0, s4, 0, 160, 0, 8);
  EXPECT_LT(followed, area / 200 + 2);
  EXPECT_GT(fixed_camera, 10 * (followed + 2));
  EXPECT_GT(cloth_pixels(s4), cloth_pixels(s0));
}
