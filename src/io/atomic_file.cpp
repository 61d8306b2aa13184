#include "weft/atomic_file.hpp"

#include <unistd.h>

#include <fstream>
#include <stdexcept>
#include <string>
#include <system_error>

namespace weft {

void write_files_atomically(const std::vector<PendingFile>& files) {
  namespace fs = std::filesystem;
  std::vector<fs::path> temporaries;
  auto remove_temporaries = [&temporaries] {
    std::error_code ignored;
    for (const auto& t : temporaries) fs::remove(t, ignored);
  };
  try {
    for (const auto& file : files) {
      if (file.path.has_parent_path()) fs::create_directories(file.path.parent_path());
      // The temporary sits in the same folder, so the rename below cannot cross file systems.
      fs::path temporary = file.path;
      temporary += ".";
      temporary += std::to_string(::getpid());
      temporary += ".tmp";
      temporaries.push_back(temporary);
      file.write(temporary);
    }
    for (size_t i = 0; i < files.size(); ++i) fs::rename(temporaries[i], files[i].path);
  } catch (...) {
    remove_temporaries();
    throw;
  }
}

void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write) {
  write_files_atomically({PendingFile{path, [&](const std::filesystem::path& temporary) {
                                        std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
                                        if (!out) throw std::runtime_error(path + ": cannot open for writing");
                                        write(out);
                                        out.flush();
                                        if (!out) throw std::runtime_error(path + ": write failed");
                                      }}});
}

}  // namespace weft
