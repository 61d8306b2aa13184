#pragma once
// Reading an input file whole, for the readers that parse text (scene, material, OBJ, BVH and
// the body's JSON files).
#include <string>

namespace weft {

/// Largest input file read (bytes); a larger one is refused rather than read into memory.
constexpr long long kMaxInputFileBytes = 1LL << 31;

/// The contents of the regular file at `path`. Throws InputError "PATH: cannot open WHAT"
/// (`what` names the kind of file: "scene file", "OBJ file"...) when it is missing, not a
/// regular file (a folder, a device), unreadable or larger than kMaxInputFileBytes.
std::string read_input_file(const std::string& path, const std::string& what);

}  // namespace weft
