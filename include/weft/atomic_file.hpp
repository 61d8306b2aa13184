#pragma once
// All-or-nothing output: files are written under temporary names beside their final
// paths and renamed into place only once every one of them was written.
#include <filesystem>
#include <functional>
#include <vector>

namespace weft {

struct PendingFile {
  std::filesystem::path path;  ///< final location
  /// Writes the whole content to the given (temporary) path; throws on failure.
  std::function<void(const std::filesystem::path& temporary_path)> write;
};

/// Creates missing parent folders, runs every writer on a temporary path in the target's
/// folder, then renames each into place. If a writer throws, every temporary is removed,
/// no final path is touched, and the exception propagates.
void write_files_atomically(const std::vector<PendingFile>& files);

}  // namespace weft
