// The BVH reader: the shipped file, channel order, and errors that name the line.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "body/body_fixture.hpp"
#include "weft/body.hpp"
#include "weft/error.hpp"

namespace weft {
namespace {

// A two-joint file; line numbers below refer to it.
const char* kSmall =
    "HIERARCHY\n"                                                        // 1
    "ROOT Hips\n"                                                        // 2
    "{\n"                                                                // 3
    "  OFFSET 0 0 0\n"                                                   // 4
    "  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n"  // 5
    "  JOINT Leg\n"                                                      // 6
    "  {\n"                                                              // 7
    "    OFFSET 1 -2 0\n"                                                // 8
    "    CHANNELS 3 Zrotation Yrotation Xrotation\n"                     // 9
    "    End Site\n"                                                     // 10
    "    {\n"                                                            // 11
    "      OFFSET 0 -3 0\n"                                              // 12
    "    }\n"                                                            // 13
    "  }\n"                                                              // 14
    "}\n"                                                                // 15
    "MOTION\n"                                                           // 16
    "Frames: 2\n"                                                        // 17
    "Frame Time: 0.5\n"                                                  // 18
    "0 10 0 0 0 0 30 20 10\n"                                            // 19
    "1 10 0 0 0 0 -30 0 45\n";                                           // 20

std::string replace_line(const std::string& text, int line, const std::string& replacement) {
  std::istringstream in(text);
  std::string out, current;
  for (int n = 1; std::getline(in, current); ++n) {
    if (n == line) {
      if (!replacement.empty()) out += replacement + "\n";
    } else {
      out += current + "\n";
    }
  }
  return out;
}

// Writes `text` to a file and returns the InputError message of reading it ("" if none).
std::string read_error(const std::string& text, const std::string& name) {
  const auto path = (test::scratch_dir("bvh") / name).string();
  std::ofstream(path) << text;
  try {
    read_bvh(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(BvhReader, ReadsTheShippedWalk) {
  const BvhMotion m = read_bvh(default_motion_file());
  EXPECT_EQ(m.frame_count(), 359);
  EXPECT_NEAR(m.frame_time_s, 1.0 / 120.0, 1e-6);
  ASSERT_EQ(m.joints.size(), 31u);
  EXPECT_EQ(m.joints[0].name, "Hips");
  EXPECT_EQ(m.joints[0].parent, -1);
  int channels = 0;
  for (size_t j = 0; j < m.joints.size(); ++j) {
    EXPECT_EQ(m.joints[j].first_channel, channels);
    channels += static_cast<int>(m.joints[j].channels.size());
    if (j > 0) EXPECT_LT(m.joints[j].parent, static_cast<int>(j));
  }
  EXPECT_EQ(m.frames.cols(), channels);
  EXPECT_EQ(channels, 6 + 30 * 3);
  EXPECT_GE(m.find("LeftHandIndex1"), 0);
  EXPECT_TRUE(m.joints[m.find("LeftToeBase")].has_end_site);
  EXPECT_TRUE(m.frames.allFinite());
}

TEST(BvhReader, ParsesHierarchyAndChannelOrder) {
  std::istringstream in(kSmall);
  const BvhMotion m = parse_bvh(in, "small.bvh");
  ASSERT_EQ(m.joints.size(), 2u);
  EXPECT_EQ(m.joints[1].parent, 0);
  EXPECT_EQ(m.joints[1].offset, Vec3(1, -2, 0));
  EXPECT_EQ(m.joints[1].end_site, Vec3(0, -3, 0));
  EXPECT_EQ(m.joints[1].first_channel, 6);
  EXPECT_DOUBLE_EQ(m.frame_time_s, 0.5);
  EXPECT_EQ(m.local_translation(1, 0), Vec3(1, 10, 0));
  // Channels listed Z, Y, X: the local rotation is Rz * Ry * Rx (X applied first).
  const double deg = M_PI / 180;
  const Mat3 expected = (Eigen::AngleAxisd(30 * deg, Vec3::UnitZ()) *
                         Eigen::AngleAxisd(20 * deg, Vec3::UnitY()) *
                         Eigen::AngleAxisd(10 * deg, Vec3::UnitX()))
                            .toRotationMatrix();
  EXPECT_LT((m.local_rotation(0, 1).toRotationMatrix() - expected).norm(), 1e-12);
  const Mat3 not_expected = (Eigen::AngleAxisd(10 * deg, Vec3::UnitX()) *
                             Eigen::AngleAxisd(20 * deg, Vec3::UnitY()) *
                             Eigen::AngleAxisd(30 * deg, Vec3::UnitZ()))
                                .toRotationMatrix();
  EXPECT_GT((m.local_rotation(0, 1).toRotationMatrix() - not_expected).norm(), 1e-3);
}

TEST(BvhReader, RejectsMalformedFilesNamingTheLine) {
  const std::string good = kSmall;
  ASSERT_EQ(read_error(good, "good.bvh"), "");
  struct Case {
    std::string name, text;
    int line;
    std::string says;
  };
  const std::vector<Case> cases = {
      {"truncated.bvh", replace_line(good, 20, ""), 19, "file ends after 1 of 2 frames"},
      {"short_frame.bvh", replace_line(good, 19, "0 10 0 0 0 0 30 20"), 19, "8 values"},
      {"long_frame.bvh", replace_line(good, 20, "1 10 0 0 0 0 -30 0 45 7"), 20, "more than"},
      {"bad_number.bvh", replace_line(good, 8, "    OFFSET 1 x2 0"), 8, "'x2'"},
      {"bad_channel.bvh", replace_line(good, 9, "    CHANNELS 3 Zrotation Wrotation Xrotation"), 9,
       "unknown channel 'Wrotation'"},
      {"no_brace.bvh", replace_line(good, 7, ""), 7, "expected '{'"},
      {"bad_frames.bvh", replace_line(good, 17, "Frames: two"), 17, "'two'"},
      {"bad_frame_time.bvh", replace_line(good, 18, "Frame Time: -1"), 18, "frame time -1.0 s is out of range [1e-05, 10] s"},
      {"huge_frame_time.bvh", replace_line(good, 18, "Frame Time: 1e300"), 18, "out of range [1e-05, 10] s"},
      {"nan_frame_time.bvh", replace_line(good, 18, "Frame Time: nan"), 18, "out of range [1e-05, 10] s"},
      // The frame count is not trusted to size anything: a count far beyond the file ends in
      // an error naming how many frames there were, not in an allocation of 2e9 rows.
      {"many_frames.bvh", replace_line(good, 17, "Frames: 2000000000"), 20, "file ends after 2 of 2000000000 frames"},
      {"overflow_frames.bvh", replace_line(good, 17, "Frames: 99999999999"), 17, "expected an integer, got '99999999999'"},
      {"huge_offset.bvh", replace_line(good, 8, "    OFFSET 1 1e300 0"), 8,
       "OFFSET coordinate 1e300 is out of range (expected a magnitude of at most 1e6)"},
      {"huge_value.bvh", replace_line(good, 19, "0 10 0 0 0 0 30 1e308 10"), 19,
       "value 1e308 is out of range (expected a finite number of magnitude at most 1e6)"},
      {"nan_value.bvh", replace_line(good, 19, "0 10 0 0 0 0 30 nan 10"), 19, "value nan is out of range"},
      {"trailing.bvh", good + "1 2 3\n", 21, "after the last frame"},
      {"no_motion.bvh", good.substr(0, good.find("MOTION")), 15, "end of file"},
  };
  for (const Case& c : cases) {
    const std::string message = read_error(c.text, c.name);
    EXPECT_NE(message.find(c.name + ":" + std::to_string(c.line) + ":"), std::string::npos)
        << c.name << ": " << message;
    EXPECT_NE(message.find(c.says), std::string::npos) << c.name << ": " << message;
  }
  EXPECT_NE(read_error("", "empty.bvh").find("empty.bvh"), std::string::npos);
}

TEST(BvhReader, RefusesHierarchiesNestedTooDeeply) {
  std::string text = "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 0\n";
  for (int k = 0; k < 300; ++k) text += "JOINT j" + std::to_string(k) + "\n{\nOFFSET 0 1 0\nCHANNELS 0\n";
  // Five header lines, then four per joint: joint j256 (257 levels deep) starts on line 6 + 4 * 256.
  EXPECT_NE(read_error(text, "deep.bvh").find("deep.bvh:1030: joints nested deeper than 256 levels"), std::string::npos)
      << read_error(text, "deep.bvh");
}

}  // namespace
}  // namespace weft
