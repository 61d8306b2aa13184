#pragma once
// Shared, loaded-once mannequin for the body tests, and a scratch folder helper.
#include <unistd.h>

#include <filesystem>
#include <string>

#include "weft/body.hpp"

namespace weft::test {

/// The shipped mannequin walking the shipped motion (speed 0.75, LBS).
inline const WalkingBody& shipped_body() {
  static const WalkingBody body{BodyColliderSpec{}};
  return body;
}

/// A fresh, empty folder under the system's temporary folder, of this process alone (ctest
/// runs the tests of one suite at the same time, each in its own process).
inline std::filesystem::path scratch_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("weft_body_tests_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace weft::test
