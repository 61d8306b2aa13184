#pragma once
// Number parsing shared by the body's file readers: strict, locale-free, errors name `where`.
#include <charconv>
#include <string>

#include "weft/error.hpp"

namespace weft::text {

inline double parse_double(const std::string& token, const std::string& where) {
  double value = 0.0;
  const char* begin = token.data();
  const char* end = token.data() + token.size();
  if (begin != end && *begin == '+') ++begin;
  auto [ptr, ec] = std::from_chars(begin, end, value);
  if (ec != std::errc() || ptr != end || begin == end)
    throw InputError(where + ": expected a number, got '" + token + "'");
  return value;
}

inline int parse_int(const std::string& token, const std::string& where) {
  int value = 0;
  auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc() || ptr != token.data() + token.size() || token.empty())
    throw InputError(where + ": expected an integer, got '" + token + "'");
  return value;
}

}  // namespace weft::text
