// All-or-nothing output of several files (include/weft/atomic_file.hpp).
#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <stdexcept>

#include "weft/atomic_file.hpp"

namespace {

namespace fs = std::filesystem;

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream(path) << text;
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

class AtomicFile : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = fs::temp_directory_path() / ("weft_atomic_" + std::to_string(::getpid()) + "_" +
                                           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(folder_);
  }
  void TearDown() override { fs::remove_all(folder_); }
  fs::path folder_;
};

TEST_F(AtomicFile, WritesEveryFileAndCreatesFolders) {
  weft::write_files_atomically({
      {folder_ / "a" / "one.txt", [](const fs::path& p) { write_text(p, "one"); }},
      {folder_ / "two.txt", [](const fs::path& p) { write_text(p, "two"); }},
  });
  EXPECT_EQ(read_text(folder_ / "a" / "one.txt"), "one");
  EXPECT_EQ(read_text(folder_ / "two.txt"), "two");
  EXPECT_EQ(std::distance(fs::directory_iterator(folder_ / "a"), fs::directory_iterator()), 1);
}

TEST_F(AtomicFile, FailureLeavesOldFilesAndNoTemporaries) {
  fs::create_directories(folder_);
  write_text(folder_ / "one.txt", "old");
  EXPECT_THROW(weft::write_files_atomically({
                   {folder_ / "one.txt", [](const fs::path& p) { write_text(p, "new"); }},
                   {folder_ / "two.txt",
                    [](const fs::path& p) {
                      write_text(p, "partial");
                      throw std::runtime_error("disk full");
                    }},
               }),
               std::runtime_error);
  EXPECT_EQ(read_text(folder_ / "one.txt"), "old");
  EXPECT_FALSE(fs::exists(folder_ / "two.txt"));
  EXPECT_EQ(std::distance(fs::directory_iterator(folder_), fs::directory_iterator()), 1);
}

}  // namespace
