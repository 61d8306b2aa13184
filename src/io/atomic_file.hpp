#pragma once
// Outputs are written to a temporary name beside the target, then renamed into place, so a
// reader never sees a half-written file.
#include <functional>
#include <ostream>
#include <string>

namespace weft {

/// Calls `write` on a stream to `path + ".tmp"`, then renames it to `path`. Throws
/// std::runtime_error (and removes the temporary) when writing fails.
void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write);

}  // namespace weft
