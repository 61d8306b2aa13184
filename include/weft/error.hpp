#pragma once
// Errors raised by weft. InputError means the user gave something wrong (a scene, a file,
// a parameter): its message names the place and the value, and the command exits with 2.
#include <stdexcept>
#include <string>

namespace weft {

class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace weft
