#pragma once
// Shared by the `weft experiment ...` commands: the default scene, the output folder and
// progress lines per configuration.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "progress.hpp"
#include "weft/error.hpp"
#include "weft/scene.hpp"

namespace weft::app {

/// The scene the experiments use when --scene is not given: the source tree's swing scene.
inline std::string default_experiment_scene() {
  return (std::filesystem::path(WEFT_DATA_DIR).parent_path() / "scenes" / "swing.json").string();
}

/// Checks, before any work and without creating anything, that the output folder exists or
/// can be created (its nearest existing ancestor is a writable folder). Throws InputError.
inline void check_output_folder(const std::string& out) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path p = fs::absolute(out, ec);
  if (fs::exists(p, ec) && !fs::is_directory(p, ec))
    throw InputError("--out '" + out + "': exists and is not a folder");
  while (!p.empty() && !fs::exists(p, ec) && p != p.parent_path()) p = p.parent_path();
  if (!fs::is_directory(p, ec) || access(p.c_str(), W_OK | X_OK) != 0)
    throw InputError("--out '" + out + "': cannot create or write the output folder (" +
                     p.string() + " is not a writable folder)");
}

/// One progress bar per configuration label, replaced when the label changes.
class LabelledProgress {
 public:
  explicit LabelledProgress(std::string prefix, bool enabled)
      : prefix_(std::move(prefix)), enabled_(enabled) {}
  void operator()(const std::string& label, double fraction) {
    if (label != label_ || !bar_) {
      if (bar_) bar_->finish();
      label_ = label;
      bar_ = std::make_unique<Progress>(prefix_ + " " + label, enabled_);
    }
    bar_->update(fraction);
  }
  void finish() {
    if (bar_) bar_->finish();
  }

 private:
  std::string prefix_, label_;
  bool enabled_;
  std::unique_ptr<Progress> bar_;
};

/// The options every experiment takes: --scene, --out and --quiet.
inline void add_common_options(CLI::App& sub, std::string& scene, std::string& out, bool& quiet) {
  sub.add_option("--scene", scene, "Scene file (default: the source tree's scenes/swing.json)");
  sub.add_option("--out,-o", out, "Output folder (created)")->required();
  sub.add_flag("--quiet,-q", quiet, "No progress bars");
}

inline void print_warnings(const std::vector<std::string>& warnings) {
  for (const auto& w : warnings) std::fprintf(stderr, "weft: warning: %s\n", w.c_str());
}

}  // namespace weft::app
