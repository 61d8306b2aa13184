#pragma once
// All-or-nothing output: files are written under temporary names beside their final
// paths and renamed into place only once every one of them was written.
#include <filesystem>
#include <functional>
#include <ostream>
#include <string>
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

/// One file: calls `write` on a stream to a temporary beside `path`, then renames it into
/// place. Throws std::runtime_error (and removes the temporary) when writing fails.
void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write);

}  // namespace weft
