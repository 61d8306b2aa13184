// BVH (Biovision hierarchy) reader: HIERARCHY with ROOT/JOINT/End Site blocks, OFFSET and
// CHANNELS lines, then MOTION with "Frames:", "Frame Time:" and one line of values per frame.
#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "body/text.hpp"
#include "weft/input_file.hpp"
#include "weft/body.hpp"
#include "weft/error.hpp"

namespace weft {

namespace {

/// Largest magnitude of an offset, a position or an angle (file units, degrees).
constexpr double kMaxBvhValue = 1e6;
/// Deepest joint hierarchy read (a human skeleton needs about 10 levels).
constexpr int kMaxBvhDepth = 256;
/// Frame time bounds (s): 100 kHz to 0.1 Hz.
constexpr double kMinFrameTime_s = 1e-5, kMaxFrameTime_s = 10;

// Splits the input into whitespace-separated tokens, remembering each token's line.
class Tokenizer {
 public:
  Tokenizer(std::istream& in, std::string name) : in_(in), name_(std::move(name)) {}

  bool next(std::string& token) {
    while (!(line_tokens_ >> token)) {
      std::string line;
      if (!std::getline(in_, line)) return false;
      ++line_;
      line_tokens_.clear();
      line_tokens_.str(line);
    }
    return true;
  }
  std::string expect_any(const std::string& what) {
    std::string token;
    if (!next(token)) fail("unexpected end of file, expected " + what);
    return token;
  }
  void expect(const std::string& word) {
    const std::string token = expect_any("'" + word + "'");
    if (token != word) fail("expected '" + word + "', got '" + token + "'");
  }
  double number(const std::string& what) { return text::parse_double(expect_any(what), where()); }
  /// A number within [-kMaxBvhValue, kMaxBvhValue].
  double bounded(const std::string& what) {
    const std::string token = expect_any(what);
    const double value = text::parse_double(token, where());
    if (!(std::abs(value) <= kMaxBvhValue))
      fail(what + " " + token + " is out of range (expected a magnitude of at most 1e6)");
    return value;
  }
  /// Reads the rest of the current line.
  std::string rest_of_line() {
    std::string rest;
    std::getline(line_tokens_, rest);
    return rest;
  }
  /// Moves to the next line and returns it whole (false at end of file).
  bool next_line(std::string& line) {
    if (!std::getline(in_, line)) return false;
    ++line_;
    line_tokens_.clear();
    line_tokens_.str("");
    return true;
  }
  std::string where() const { return name_ + ":" + std::to_string(line_); }
  [[noreturn]] void fail(const std::string& message) const {
    throw InputError(where() + ": " + message);
  }

 private:
  std::istream& in_;
  std::string name_;
  std::istringstream line_tokens_;
  int line_ = 0;
};

int channel_kind(const std::string& name) {
  static const char* kNames[] = {"Xposition", "Yposition", "Zposition",
                                 "Xrotation", "Yrotation", "Zrotation"};
  for (int k = 0; k < 6; ++k)
    if (name == kNames[k]) return k;
  return -1;
}

// Reads the body of a ROOT/JOINT block after its name; the opening brace comes next.
void read_joint(Tokenizer& tok, BvhMotion& motion, const std::string& name, int parent,
                int& channel_count, int depth) {
  if (depth > kMaxBvhDepth) tok.fail("joints nested deeper than " + std::to_string(kMaxBvhDepth) + " levels");
  BvhJoint joint;
  joint.name = name;
  joint.parent = parent;
  tok.expect("{");
  tok.expect("OFFSET");
  for (int k = 0; k < 3; ++k) joint.offset[k] = tok.bounded("OFFSET coordinate");
  tok.expect("CHANNELS");
  const std::string count_token = tok.expect_any("a channel count");
  const int count = text::parse_int(count_token, tok.where());
  if (count < 0 || count > 6) tok.fail("channel count must be 0 to 6, got " + count_token);
  for (int c = 0; c < count; ++c) {
    const std::string channel = tok.expect_any("a channel name");
    const int kind = channel_kind(channel);
    if (kind < 0) tok.fail("unknown channel '" + channel + "'");
    joint.channels.push_back(kind);
  }
  joint.first_channel = channel_count;
  channel_count += count;
  const int self = static_cast<int>(motion.joints.size());
  motion.joints.push_back(joint);
  for (;;) {
    const std::string token = tok.expect_any("JOINT, End Site or '}'");
    if (token == "}") return;
    if (token == "JOINT") {
      const std::string child = tok.expect_any("a joint name");
      read_joint(tok, motion, child, self, channel_count, depth + 1);
    } else if (token == "End") {
      tok.expect("Site");
      tok.expect("{");
      tok.expect("OFFSET");
      Vec3 end;
      for (int k = 0; k < 3; ++k) end[k] = tok.bounded("OFFSET coordinate");
      tok.expect("}");
      motion.joints[self].has_end_site = true;
      motion.joints[self].end_site = end;
    } else {
      tok.fail("expected JOINT, End Site or '}', got '" + token + "'");
    }
  }
}

}  // namespace

int BvhMotion::find(const std::string& name) const {
  for (size_t j = 0; j < joints.size(); ++j)
    if (joints[j].name == name) return static_cast<int>(j);
  return -1;
}

Eigen::Quaterniond BvhMotion::local_rotation(int frame, int joint) const {
  const BvhJoint& jt = joints[joint];
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  for (size_t c = 0; c < jt.channels.size(); ++c) {
    const int kind = jt.channels[c];
    if (kind < 3) continue;
    const double angle_rad = frames(frame, jt.first_channel + c) * (M_PI / 180.0);
    q = q * Eigen::Quaterniond(Eigen::AngleAxisd(angle_rad, Vec3::Unit(kind - 3)));
  }
  return q.normalized();
}

Vec3 BvhMotion::local_translation(int frame, int joint) const {
  const BvhJoint& jt = joints[joint];
  Vec3 p = jt.offset;
  for (size_t c = 0; c < jt.channels.size(); ++c)
    if (jt.channels[c] < 3) p[jt.channels[c]] = frames(frame, jt.first_channel + c);
  return p;
}

BvhMotion parse_bvh(std::istream& in, const std::string& name) {
  Tokenizer tok(in, name);
  BvhMotion motion;
  tok.expect("HIERARCHY");
  tok.expect("ROOT");
  int channel_count = 0;
  read_joint(tok, motion, tok.expect_any("the root joint name"), -1, channel_count, 0);
  tok.expect("MOTION");
  tok.expect("Frames:");
  const std::string frames_token = tok.expect_any("a frame count");
  const int frame_count = text::parse_int(frames_token, tok.where());
  if (frame_count < 1) tok.fail("frame count must be positive, got " + frames_token);
  tok.expect("Frame");
  tok.expect("Time:");
  motion.frame_time_s = tok.number("the frame time");
  if (!(motion.frame_time_s >= kMinFrameTime_s && motion.frame_time_s <= kMaxFrameTime_s))
    tok.fail("frame time " + nlohmann::json(motion.frame_time_s).dump() + " s is out of range [1e-05, 10] s");
  const std::string trailing = tok.rest_of_line();
  if (trailing.find_first_not_of(" \t\r") != std::string::npos)
    tok.fail("unexpected text after the frame time");
  // The frames are stored as they are read: the count in the header may exceed the file.
  std::vector<double> values_read;
  std::string line;
  for (int f = 0; f < frame_count; ++f) {
    do {
      if (!tok.next_line(line))
        tok.fail("file ends after " + std::to_string(f) + " of " + std::to_string(frame_count) +
                 " frames");
    } while (line.find_first_not_of(" \t\r") == std::string::npos);
    std::istringstream values(line);
    std::string value;
    int c = 0;
    while (values >> value) {
      if (c == channel_count)
        tok.fail("frame " + std::to_string(f) + " has more than " +
                 std::to_string(channel_count) + " values");
      const double x = text::parse_double(value, tok.where());
      if (!(std::abs(x) <= kMaxBvhValue))
        tok.fail("value " + value + " is out of range (expected a finite number of magnitude at most 1e6)");
      values_read.push_back(x);
      ++c;
    }
    if (c != channel_count)
      tok.fail("frame " + std::to_string(f) + " has " + std::to_string(c) + " values, expected " +
               std::to_string(channel_count));
  }
  while (tok.next_line(line))
    if (line.find_first_not_of(" \t\r") != std::string::npos)
      tok.fail("unexpected text after the last frame");
  motion.frames = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      values_read.data(), frame_count, channel_count);
  return motion;
}

BvhMotion read_bvh(const std::string& path) {
  std::istringstream in(read_input_file(path, "BVH file"));
  return parse_bvh(in, path);
}

}  // namespace weft
