#include "io/json_util.hpp"

#include <algorithm>
#include <climits>
#include <unordered_set>
#include <vector>

#include "weft/input_file.hpp"

namespace weft::json_util {

namespace {

/// Where the parser is: one frame per open object or array, for the key path of messages.
class ParsePosition {
 public:
  explicit ParsePosition(const std::string& file) : file_(file) {}

  bool on_event(int depth, nlohmann::json::parse_event_t event, const nlohmann::json& parsed) {
    using E = nlohmann::json::parse_event_t;
    switch (event) {
      case E::object_start:
      case E::array_start:
        count_element();
        if (depth > kMaxDepth) fail("arrays and objects are nested deeper than " + std::to_string(kMaxDepth) + " levels");
        frames_.push_back(Frame{event == E::object_start, {}, {}, -1});
        break;
      case E::key: {
        Frame& f = frames_.back();
        f.key = parsed.get<std::string>();
        if (!f.keys.insert(f.key).second) fail("duplicate key (a key may appear only once in an object)");
        break;
      }
      case E::value:
        count_element();
        break;
      case E::object_end:
      case E::array_end:
        frames_.pop_back();
        break;
    }
    return true;
  }

  /// "FILE: key PATH" of the value being read ("FILE: top level" outside any object).
  std::string where(bool value_pending) const {
    std::string path;
    for (size_t k = 0; k < frames_.size(); ++k) {
      const Frame& f = frames_[k];
      if (f.object) {
        if (f.key.empty() && f.keys.empty()) break;
        path += (path.empty() ? "" : ".") + f.key;
      } else {
        // The element being parsed: counted when it started if it is an array or object.
        const long index = f.index + (value_pending && k + 1 == frames_.size() ? 1 : 0);
        path += "[" + std::to_string(std::max(0L, index)) + "]";
      }
    }
    return file_ + (path.empty() ? std::string(": top level") : ": key " + path);
  }

 private:
  struct Frame {
    bool object;
    std::unordered_set<std::string> keys;
    std::string key;
    long index;  ///< arrays: the element last started
  };
  void count_element() {
    if (!frames_.empty() && !frames_.back().object) ++frames_.back().index;
  }
  [[noreturn]] void fail(const std::string& message) const { throw InputError(where(false) + ": " + message); }

  const std::string& file_;
  std::vector<Frame> frames_;
};

}  // namespace

nlohmann::json parse_json(std::string_view text, const std::string& file) {
  ParsePosition position(file);
  try {
    return nlohmann::json::parse(text, [&](int depth, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
      return position.on_event(depth, event, parsed);
    });
  } catch (const nlohmann::json::parse_error& e) {
    const size_t upto = std::min<size_t>(e.byte, text.size());
    const long line = 1 + std::count(text.begin(), text.begin() + static_cast<long>(upto), '\n');
    const std::string msg = e.what();
    const auto pos = msg.find("parse error");
    throw InputError(file + ":" + std::to_string(line) + ": malformed JSON: " +
                     (pos == std::string::npos ? msg : msg.substr(pos)));
  } catch (const nlohmann::json::out_of_range& e) {
    // 406: a number beyond the range of a double ("number overflow parsing '1e400'").
    const std::string msg = e.what();
    const auto open = msg.find('\''), close = msg.rfind('\'');
    const std::string number = open != std::string::npos && close > open ? msg.substr(open + 1, close - open - 1) : msg;
    throw InputError(position.where(true) + ": number " + number +
                     " is too large (expected a finite number, at most about 1.8e308 in magnitude)");
  }
}

nlohmann::json load_json_file(const std::string& path, const std::string& what) {
  return parse_json(read_input_file(path, what), path);
}

std::optional<long> integer_value(const nlohmann::json& v) {
  if (v.is_number_unsigned()) {
    const auto u = v.get<std::uint64_t>();
    if (u > static_cast<std::uint64_t>(LONG_MAX)) return std::nullopt;
    return static_cast<long>(u);
  }
  if (v.is_number_integer()) return v.get<long>();
  return std::nullopt;
}

std::string range_text(double lo, double hi, const std::string& unit) {
  return "[" + nlohmann::json(lo).dump() + ", " + nlohmann::json(hi).dump() + "]" + (unit.empty() ? "" : " " + unit);
}

std::string describe(const nlohmann::json& v) {
  std::string s = v.dump();
  if (s.size() > 60) s = s.substr(0, 57) + "...";
  return s + " (" + v.type_name() + ")";
}

Reader::Reader(const nlohmann::json& j, std::string file, std::string path)
    : j_(j), file_(std::move(file)), path_(std::move(path)) {
  if (!j_.is_object())
    throw InputError(file_ + ": " + (path_.empty() ? std::string("top level") : "key " + path_) +
                     ": expected an object, got " + describe(j_));
}

std::string Reader::where(const char* key) const {
  return file_ + ": key " + (path_.empty() ? std::string(key) : path_ + "." + key);
}

void Reader::fail(const char* key, const std::string& message) const {
  throw InputError(where(key) + ": " + message);
}

void Reader::allow_only(std::initializer_list<const char*> allowed) const {
  for (auto it = j_.begin(); it != j_.end(); ++it) {
    const bool ok = std::any_of(allowed.begin(), allowed.end(), [&](const char* a) { return it.key() == a; });
    if (!ok) {
      std::string list;
      for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
      throw InputError(where(it.key().c_str()) + ": unknown key (expected one of: " + list + ")");
    }
  }
}

const nlohmann::json& Reader::raw(const char* key) const {
  if (!j_.contains(key)) fail(key, "missing");
  return j_.at(key);
}

Reader Reader::object(const char* key) const {
  const auto& v = raw(key);
  if (!v.is_object()) fail(key, "expected an object, got " + describe(v));
  return Reader(v, file_, path_.empty() ? key : path_ + "." + key);
}

double Reader::number(const char* key) const {
  const auto& v = raw(key);
  if (!v.is_number()) fail(key, "expected a number, got " + describe(v));
  const double d = v.get<double>();
  if (!std::isfinite(d)) fail(key, "expected a finite number, got " + describe(v));
  return d;
}

double Reader::number_in(const char* key, double lo, double hi, bool open_low) const {
  const double d = number(key);
  if ((open_low ? !(d > lo) : !(d >= lo)) || !(d <= hi)) {
    fail(key, "value " + nlohmann::json(d).dump() + " is out of range " + (open_low ? "(" : "[") +
                  nlohmann::json(lo).dump() + ", " + nlohmann::json(hi).dump() + "]");
  }
  return d;
}

long Reader::integer(const char* key) const {
  const auto& v = raw(key);
  const std::optional<long> i = integer_value(v);
  if (!i) fail(key, "expected an integer, got " + describe(v));
  return *i;
}

long Reader::integer_in(const char* key, long lo, long hi) const {
  const long i = integer(key);
  if (i < lo || i > hi)
    fail(key, "value " + std::to_string(i) + " is out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return i;
}

std::string Reader::string(const char* key) const {
  const auto& v = raw(key);
  if (!v.is_string()) fail(key, "expected a string, got " + describe(v));
  return v.get<std::string>();
}

bool Reader::boolean(const char* key) const {
  const auto& v = raw(key);
  if (!v.is_boolean()) fail(key, "expected true or false, got " + describe(v));
  return v.get<bool>();
}

Vec3 Reader::vec3(const char* key) const {
  const auto& v = raw(key);
  if (!v.is_array() || v.size() != 3 || !std::all_of(v.begin(), v.end(), [](const auto& e) { return e.is_number(); }))
    fail(key, "expected an array of 3 numbers, got " + describe(v));
  Vec3 r(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
  if (!r.allFinite()) fail(key, "expected finite numbers, got " + describe(v));
  return r;
}

Vec3 Reader::vec3_within(const char* key, double limit, const std::string& unit) const {
  const Vec3 r = vec3(key);
  if (!(r.cwiseAbs().maxCoeff() <= limit))
    fail(key, "value " + describe(raw(key)) + " is out of range: each component must be within " +
                  range_text(-limit, limit, unit));
  return r;
}

}  // namespace weft::json_util
