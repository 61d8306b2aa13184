#pragma once
// The sample patterns shipped in data/patterns, for the tests that run over all of them.
#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

namespace weft::test {

/// Every .json file under data/patterns, sorted.
inline std::vector<std::string> sample_pattern_files() {
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(
           std::string(WEFT_SOURCE_DIR) + "/data/patterns"))
    if (entry.path().extension() == ".json") files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace weft::test
