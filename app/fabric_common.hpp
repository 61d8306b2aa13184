#pragma once
// Shared by the fabric experiments (`weft experiment tensile|cantilever|drape`): the --material
// argument and text outputs for write_files_atomically.
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "weft/atomic_file.hpp"

#include "weft/error.hpp"
#include "weft/material.hpp"

namespace weft::app {

/// A preset name, or a material file when the argument names one (or looks like a path).
/// Throws InputError "--material 'ARG': ...".
inline Material resolve_material(const std::string& arg) {
  namespace fs = std::filesystem;
  try {
    const bool looks_like_file = arg.find('/') != std::string::npos ||
                                 fs::path(arg).extension() == ".json" || fs::is_regular_file(arg);
    return looks_like_file ? load_material_file(arg) : material_preset(arg);
  } catch (const InputError& e) {
    throw InputError("--material '" + arg + "': " + e.what());
  }
}

/// A text file for write_files_atomically.
inline PendingFile text_file(const std::filesystem::path& path, std::string text) {
  return {path, [text = std::move(text)](const std::filesystem::path& temporary) {
            std::ofstream f(temporary, std::ios::binary);
            f << text;
            f.close();
            if (!f) throw std::runtime_error("cannot write " + temporary.string());
          }};
}

}  // namespace weft::app
