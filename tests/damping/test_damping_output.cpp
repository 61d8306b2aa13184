// "Seeing it": `weft run --frame-format ply` writes the added viscosity of adaptive damping per
// vertex; zero with --damping-ratio 0, positive somewhere with 0.05.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

/// Reads the added_viscosity column of an ASCII PLY frame; fails the test if it is missing.
std::vector<double> added_viscosity(const fs::path& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in) << path;
  std::string line;
  long vertices = -1;
  int property = 0, column = -1;
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream ls(line);
    std::string word, type, name;
    ls >> word;
    if (word == "element") {
      ls >> type;
      if (type == "vertex") ls >> vertices;
    } else if (word == "property" && vertices >= 0) {
      ls >> type >> name;
      if (type != "list") {
        if (name == "added_viscosity") column = property;
        ++property;
      }
    }
  }
  EXPECT_GE(column, 0) << path << " has no added_viscosity property";
  std::vector<double> values;
  for (long i = 0; i < vertices && column >= 0; ++i) {
    std::getline(in, line);
    std::istringstream ls(line);
    double v = 0;
    for (int c = 0; c <= column; ++c) ls >> v;
    EXPECT_TRUE(ls) << path << " vertex " << i;
    values.push_back(v);
  }
  return values;
}

int run_weft(const std::string& arguments) {
  const std::string command = std::string("'") + WEFT_EXE + "' " + arguments + " > /dev/null 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(DampingOutput, PlyFramesCarryAddedViscosity) {
  const fs::path folder = fs::temp_directory_path() / ("weft_damping_ply_" + std::to_string(::getpid()));
  fs::remove_all(folder);
  const std::string scene = std::string(WEFT_SOURCE_DIR) + "/scenes/swing.json";
  for (double ratio : {0.0, 0.05}) {
    const fs::path out = folder / std::to_string(ratio);
    ASSERT_EQ(run_weft("run '" + scene + "' --out '" + out.string() + "' --duration 0.1 --frame-format ply -q " +
                       "--damping-ratio " + std::to_string(ratio)),
              0);
    double largest = 0, smallest = 1e300;
    int frames = 0;
    for (const auto& e : fs::directory_iterator(out / "frames")) {
      if (e.path().extension() != ".ply") continue;
      ++frames;
      // Frame 0 is written before the first step, when nothing has been added yet.
      if (e.path().filename() == "frame_00000.ply") continue;
      for (double v : added_viscosity(e.path())) {
        largest = std::max(largest, v);
        smallest = std::min(smallest, v);
      }
    }
    EXPECT_EQ(frames, 6);
    EXPECT_GE(smallest, 0.0);
    if (ratio == 0.0) EXPECT_EQ(largest, 0.0);
    else EXPECT_GT(largest, 0.0);
  }
  fs::remove_all(folder);
}

}  // namespace
