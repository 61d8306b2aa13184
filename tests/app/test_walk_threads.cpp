// The coat's walk on one, two and three threads: every parallel part of a step (detection,
// response, assembly; docs/performance.md, "Threads") cuts its work into pieces that do not
// depend on the thread count and uses their results in a fixed order, so the same binary must
// write the same bytes whatever the count, on a garment with body and self contacts.
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "support/command.hpp"

using weft::test::CommandTest;
using weft::test::read_binary;
using weft::test::read_text;
namespace fs = std::filesystem;

namespace {

// energy.csv and every frame (relative path -> bytes).
std::map<std::string, std::string> motion_files(const fs::path& dir) {
  std::map<std::string, std::string> files;
  files["energy.csv"] = read_binary(dir / "energy.csv");
  for (const auto& e : fs::directory_iterator(dir / "frames"))
    if (e.is_regular_file()) files["frames/" + e.path().filename().string()] = read_binary(e.path());
  return files;
}

class WalkThreads : public CommandTest {};

TEST_F(WalkThreads, TheCoatsFirstFifthOfASecondIsTheSameBitsOnOneTwoAndThreeThreads) {
  // The coat of scenes/walk.json, sewn once (on two threads), then its scene with the sewn
  // garment in place of the pattern, so that only the walk's steps run at each count.
  const std::string source = WEFT_SOURCE_DIR;
  const fs::path coat = folder_ / "coat";
  const auto sewn = weft("--threads 2 garment '" + source + "/data/patterns/coat/coat.json' --edge-length 0.016 " +
                         "--material wool --out '" + coat.string() + "'");
  ASSERT_EQ(sewn.exit_code, 0) << sewn.error_output;
  auto scene = nlohmann::json::parse(read_text(source + "/scenes/walk.json"));
  ASSERT_TRUE(scene["cloth"]["mesh"].contains("pattern"));
  scene["cloth"]["mesh"] = {{"obj", (coat / "garment.obj").string()}};
  scene["duration"] = 0.2;
  const fs::path scene_file = write("walk.json", scene.dump(2));

  std::map<std::string, std::string> first;
  for (int threads : {1, 2, 3}) {
    const fs::path out = folder_ / ("run" + std::to_string(threads));
    const auto r = weft("--threads " + std::to_string(threads) + " run '" + scene_file.string() + "' --out '" +
                        out.string() + "'");
    ASSERT_EQ(r.exit_code, 0) << threads << " threads: " << r.error_output;
    const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
    // Contacts of both kinds took part, or the comparison would not reach their parallel code.
    EXPECT_GT(summary["contacts"]["node_contacts_max"].get<double>(), 0) << summary["contacts"].dump();
    EXPECT_GT(summary["contacts"]["self"]["repulsions"].get<double>(), 0) << summary["contacts"].dump();
    const auto files = motion_files(out);
    EXPECT_EQ(files.size(), 1u + 3u * 6u) << "energy.csv, and the cloth, the body and the floor at each of 6 frames";
    if (threads == 1) {
      first = files;
      continue;
    }
    for (const auto& [name, bytes] : first) {
      ASSERT_TRUE(files.count(name)) << name << " missing at " << threads << " threads";
      EXPECT_TRUE(files.at(name) == bytes) << name << " differs between 1 and " << threads << " threads";
    }
  }
}

}  // namespace
