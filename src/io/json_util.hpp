#pragma once
// Strict JSON access for input files: every error names the file, the key path, the value
// found and what was expected. Unknown keys are errors.
#include <cmath>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "weft/error.hpp"
#include "weft/types.hpp"

namespace weft::json_util {

/// Deepest nesting of arrays and objects accepted in an input file (the formats need 6).
constexpr int kMaxDepth = 64;

/// Parses the JSON text of `file`. Throws InputError "FILE:LINE: malformed JSON: ..." for a
/// syntax error, and "FILE: key PATH: ..." for a key repeated within one object, a number too
/// large for a double (1e400) or nesting deeper than kMaxDepth. Every JSON reader uses it.
nlohmann::json parse_json(std::string_view text, const std::string& file);
/// Reads the file at `path` (read_input_file; `what` names the kind of file) and parses it.
nlohmann::json load_json_file(const std::string& path, const std::string& what);

/// The value of an integer that fits in a long, or nothing (a fraction, a string, an integer
/// beyond 2^63 - 1).
std::optional<long> integer_value(const nlohmann::json& v);
/// "[-1e4, 1e4] m" style text for messages.
std::string range_text(double lo, double hi, const std::string& unit);

/// A JSON object being read, with its location for messages ("scene.json: cloth.mesh").
class Reader {
 public:
  Reader(const nlohmann::json& j, std::string file, std::string path);

  /// Throws unless every key of the object is in `allowed`.
  void allow_only(std::initializer_list<const char*> allowed) const;
  bool has(const char* key) const { return j_.contains(key); }
  const nlohmann::json& raw(const char* key) const;
  Reader object(const char* key) const;

  double number(const char* key) const;
  double number(const char* key, double fallback) const { return has(key) ? number(key) : fallback; }
  /// A number within [lo, hi] (inclusive), or (lo, hi] when `open_low`.
  double number_in(const char* key, double lo, double hi, bool open_low) const;
  long integer(const char* key) const;
  /// An integer within [lo, hi].
  long integer_in(const char* key, long lo, long hi) const;
  std::string string(const char* key) const;
  bool boolean(const char* key) const;
  Vec3 vec3(const char* key) const;
  /// Three numbers, each within [-limit, limit] (`unit` for the message).
  Vec3 vec3_within(const char* key, double limit, const std::string& unit) const;

  /// "FILE: key PATH.KEY" for messages.
  std::string where(const char* key) const;
  [[noreturn]] void fail(const char* key, const std::string& message) const;
  const std::string& file() const { return file_; }
  const std::string& path() const { return path_; }
  const nlohmann::json& json() const { return j_; }

 private:
  const nlohmann::json& j_;
  std::string file_, path_;
};

std::string describe(const nlohmann::json& value);  ///< short text of a value for messages

}  // namespace weft::json_util
