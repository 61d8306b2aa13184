#pragma once
// Runs the built `weft` command for end-to-end tests and captures its exit status and
// error output. Each test gets a fresh temporary folder.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace weft::test {

struct CommandResult {
  int exit_code = -1;
  std::string error_output;
};

inline std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

inline std::string read_binary(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class CommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = std::filesystem::temp_directory_path() /
              ("weft_cmd_" + std::to_string(::getpid()) + "_" +
               ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(folder_);
    std::filesystem::create_directories(folder_);
  }
  void TearDown() override { std::filesystem::remove_all(folder_); }

  /// Runs `weft ARGUMENTS` (arguments are passed to the shell as given), with `environment`
  /// (e.g. "PATH=/nowhere") set for the command.
  CommandResult weft(const std::string& arguments, const std::string& environment = "") const {
    const auto err = folder_ / "stderr.txt";
    const std::string command = environment + " '" + WEFT_EXE + "' " + arguments + " > /dev/null 2> '" + err.string() + "'";
    const int status = std::system(command.c_str());
    CommandResult r{WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_text(err)};
    std::filesystem::remove(err);
    return r;
  }

  std::filesystem::path write(const std::string& name, const std::string& text) {
    const auto p = folder_ / name;
    std::ofstream(p) << text;
    return p;
  }

  std::filesystem::path folder_;
};

}  // namespace weft::test
