// `weft sweep SWEEP.json --out DIR`: many runs of one scene on Dask's distributed scheduler
// (docs/sweeps.md). The command finds the Python driver shipped with weft (python/weft_sweep)
// and replaces itself with Debian's interpreter running it; the driver calls back
// `weft sweep --check-scenes FILE` to have every run's scene checked by the library before
// anything runs.
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include <unistd.h>

#include "command.hpp"
#include "weft/error.hpp"
#include "weft/garment/pattern.hpp"
#include "weft/scene.hpp"

#ifndef WEFT_PYTHON_EXECUTABLE
#define WEFT_PYTHON_EXECUTABLE "/usr/bin/python3"
#endif
#ifndef WEFT_PYTHON_SOURCE_DIR
#define WEFT_PYTHON_SOURCE_DIR ""
#endif

namespace fs = std::filesystem;

namespace {

struct SweepArgs {
  std::string sweep, out, scheduler, check_scenes;
  int workers = 0;
  bool quiet = false;
  bool rerun_other_builds = false;
};

// The folder holding the driver's package weft_sweep/: $WEFT_PYTHON_DIR, else beside an
// installed weft (PREFIX/share/weft/python), else the source tree weft was built from.
fs::path driver_dir(const fs::path& exe, std::vector<std::string>& looked) {
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv("WEFT_PYTHON_DIR"); env && *env) candidates.emplace_back(env);
  candidates.push_back(exe.parent_path().parent_path() / "share" / "weft" / "python");
  if (*WEFT_PYTHON_SOURCE_DIR) candidates.emplace_back(WEFT_PYTHON_SOURCE_DIR);
  for (const auto& dir : candidates) {
    looked.push_back(dir.string());
    std::error_code ec;
    if (fs::is_regular_file(dir / "weft_sweep" / "__main__.py", ec)) return dir;
  }
  return {};
}

// Checks the scenes of a sweep's runs: FILE holds [{"scene": {...}, "name": ..., "base_dir": ...}];
// prints a JSON array of {"index", "error"} for those the library refuses.
int check_scenes(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw weft::InputError(file + ": cannot read");
  nlohmann::json runs;
  try {
    runs = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw weft::InputError(file + ": not JSON: " + e.what());
  }
  nlohmann::json refused = nlohmann::json::array();
  for (size_t k = 0; k < runs.size(); ++k) {
    const auto& r = runs.at(k);
    try {
      const weft::Scene scene =
          weft::parse_scene(r.at("scene"), r.at("name").get<std::string>(), r.at("base_dir").get<std::string>());
      // The scene's reader reads no pattern: the panels a garment names are checked against it here.
      if (scene.cloth.garment) weft::check_scene_panels(scene, weft::load_pattern(scene.cloth.garment->pattern_file));
    } catch (const weft::InputError& e) {
      refused.push_back({{"index", k}, {"error", e.what()}});
    }
  }
  std::cout << refused.dump() << "\n";
  return weft::app::kExitOk;
}

int sweep(const SweepArgs& a) {
  if (!a.check_scenes.empty()) return check_scenes(a.check_scenes);
  if (a.sweep.empty()) throw weft::InputError("command line: a sweep file is required (weft sweep SWEEP.json --out DIR)");
  if (a.out.empty()) throw weft::InputError("command line: --out DIR is required");
  std::error_code ec;
  const fs::path exe = fs::canonical("/proc/self/exe", ec);
  std::vector<std::string> looked;
  const fs::path dir = driver_dir(exe, looked);
  if (dir.empty()) {
    std::string where;
    for (const auto& l : looked) where += "\n  " + l;
    std::cerr << "weft: error: weft sweep's Python driver (weft_sweep/__main__.py) is in none of:" << where
              << "\n(set WEFT_PYTHON_DIR to the folder that holds weft_sweep/)\n";
    return 1;
  }
  const char* env_python = std::getenv("WEFT_PYTHON");
  const std::string python = env_python && *env_python ? env_python : WEFT_PYTHON_EXECUTABLE;
  const char* old_path = std::getenv("PYTHONPATH");
  const std::string path = dir.string() + (old_path && *old_path ? ":" + std::string(old_path) : "");
  ::setenv("PYTHONPATH", path.c_str(), 1);
  std::vector<std::string> args = {python, "-m", "weft_sweep", a.sweep, "--out", a.out, "--weft", exe.string()};
  if (!a.scheduler.empty()) args.insert(args.end(), {"--scheduler", a.scheduler});
  if (a.workers > 0) args.insert(args.end(), {"--workers", std::to_string(a.workers)});
  if (a.quiet) args.push_back("--quiet");
  if (a.rerun_other_builds) args.push_back("--rerun-other-builds");
  std::vector<char*> argv;
  for (auto& s : args) argv.push_back(s.data());
  argv.push_back(nullptr);
  std::cout.flush();
  ::execv(python.c_str(), argv.data());
  std::cerr << "weft: error: weft sweep runs its driver in Python (" << python << "), which could not be started: "
            << std::strerror(errno) << " (install python3-distributed and python3-pandas, or set WEFT_PYTHON)\n";
  return 1;
}

weft::app::RegisterCommand reg{{"", "sweep", "Run many variations of a scene on Dask, locally or on a cluster",
  [](CLI::App& sub) {
    auto a = std::make_shared<SweepArgs>();
    sub.add_option("sweep", a->sweep, "Sweep file (JSON, see docs/sweeps.md)");
    sub.add_option("--out,-o", a->out,
                   "Output folder: runs/<id>/ per run, results.csv; runs already finished there are kept and "
                   "skipped (run the same command again after Ctrl-C)");
    sub.add_option("--scheduler", a->scheduler,
                   "Address of a running Dask scheduler (e.g. tcp://10.0.0.1:8786); default: a local cluster");
    sub.add_option("--workers", a->workers,
                   "Workers of the local cluster, each running one run at a time (default: the cores)")
        ->check(CLI::Range(1, 4096));
    sub.add_flag("--quiet,-q", a->quiet, "No progress line (failures and the final count are still printed)");
    sub.add_flag("--rerun-other-builds", a->rerun_other_builds,
                 "Run again the runs in DIR that another weft build made (results.csv's weft_version); by default "
                 "they are kept and counted on standard error");
    sub.add_option("--check-scenes", a->check_scenes, "(the driver's own) check the scenes listed in FILE")
        ->group("");
    sub.footer(
        "A sweep file names a base scene, fixed settings (\"set\") and axes (\"vary\"), key paths in the scene such\n"
        "as integrator.dt or colliders[0].friction, combined as a product or zipped. Each run is a `weft run` in\n"
        "its own process on a Dask worker; its outputs come back to this machine and are written to\n"
        "DIR/runs/<id>/ (summary.json, energy.csv, run.json, and what \"keep\" asks for), one row each in\n"
        "DIR/results.csv. With \"experiment\": \"drape\" in place of the scene, each run is `weft experiment drape`\n"
        "with the options set and varied, and its figures (drape coefficient, nodes, ...) are the row's.\n"
        "A worker lost mid-run has its run retried on another; runs already in DIR are skipped (those of another\n"
        "weft build too, counted on standard error, unless --rerun-other-builds).\n"
        "The driver is Python (python/weft_sweep, found through $WEFT_PYTHON_DIR, PREFIX/share/weft/python or\n"
        "the source tree) run by " WEFT_PYTHON_EXECUTABLE " ($WEFT_PYTHON), with python3-distributed and python3-pandas.\n"
        "Exit status: 0 every run ended ok, 1 internal error or Python/Dask missing, 2 bad sweep file (nothing run),\n"
        "4 an output could not be written, 7 some runs did not end ok (each has its row), 130 interrupted\n"
        "(finished runs kept; the same command goes on).");
    return std::function<int()>([a] { return sweep(*a); });
  }, 15}};

}  // namespace
