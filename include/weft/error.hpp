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

/// A garment that did not sew (a stitch left open, an intersection left), as a scene refuses
/// it: the message names the pattern, each open stitch with its gap and panels, and the
/// intersections left. An InputError (the pattern cannot be used as given); `weft` exits with
/// 6 for it.
class SewingError : public InputError {
 public:
  explicit SewingError(const std::string& what) : InputError(what) {}
};

}  // namespace weft
