#include "weft/input_file.hpp"

#include <filesystem>
#include <fstream>
#include <iterator>

#include "weft/error.hpp"

namespace weft {

std::string read_input_file(const std::string& path, const std::string& what) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || !fs::exists(status)) throw InputError(path + ": cannot open " + what + " (no such file)");
  // A folder, a pipe or a device (/dev/zero) would never end or not be a file at all.
  if (!fs::is_regular_file(status)) throw InputError(path + ": cannot open " + what + " (not a regular file)");
  const auto size = fs::file_size(path, ec);
  if (ec) throw InputError(path + ": cannot open " + what + " (" + ec.message() + ")");
  if (size > static_cast<std::uintmax_t>(kMaxInputFileBytes))
    throw InputError(path + ": cannot open " + what + " (" + std::to_string(size) + " bytes, more than the " +
                     std::to_string(kMaxInputFileBytes) + " an input file may have)");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open " + what);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw InputError(path + ": cannot read " + what);
  return text;
}

}  // namespace weft
