#include "io/json_util.hpp"

#include <algorithm>

namespace weft::json_util {

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
  if (!v.is_number_integer()) fail(key, "expected an integer, got " + describe(v));
  return v.get<long>();
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

}  // namespace weft::json_util
