#pragma once
// Shared by the harnesses: a reader may refuse its input with InputError (the message names the
// problem); any other exception escapes, and libFuzzer reports it as a crash, since `weft`
// would answer it with "internal error" and exit status 1 instead of 2.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "weft/error.hpp"

namespace weft::fuzz {

inline std::string_view text(const uint8_t* data, size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

template <class F>
void read_or_refuse(F&& f) {
  try {
    f();
  } catch (const InputError&) {
  }
}

}  // namespace weft::fuzz
