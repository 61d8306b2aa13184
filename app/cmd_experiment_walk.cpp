// `weft experiment walk`: the paper's walk comparison (its section 3.2, docs/walk.md) on a
// garment-on-a-body scene.
#include <cstdio>
#include <memory>

#include "command.hpp"
#include "experiment_common.hpp"
#include "weft/experiments/walk.hpp"

namespace weft::app {
namespace {

struct WalkArgs {
  std::string scene = (std::filesystem::path(WEFT_DATA_DIR).parent_path() / "scenes" / "walk.json").string(), out;
  WalkExperimentOptions options;
  std::string configs;
  bool no_frames = false, quiet = false;
};

int run_walk(WalkArgs a) {
  Scene scene = load_scene(a.scene);
  if (!a.configs.empty()) {
    std::string item;
    for (char c : a.configs + ",") {
      if (c == ',') {
        if (!item.empty()) a.options.only.push_back(item);
        item.clear();
      } else {
        item += c;
      }
    }
  }
  a.options.frames = !a.no_frames;
  check_output_folder(a.out);
  LabelledProgress progress("walk", !a.quiet);
  const WalkExperiment ex = run_walk_experiment(scene, a.options, a.out, std::ref(progress));
  progress.finish();
  print_warnings(write_walk_experiment(ex, a.out));
  std::printf("%s", walk_results_markdown(ex).c_str());
  std::printf("results in %s (results.md, results.csv, results.json, liveliness.csv, liveliness.png, LABEL/)\n",
              a.out.c_str());
  return kExitOk;
}

const RegisterCommand register_walk{CommandSpec{
    "experiment", "walk",
    "The paper's walk comparison: Implicit Midpoint (5% adaptive damping) at 5 and 2 ms, backward Euler at "
    "2 and 5 ms, BDF-2 and the alpha = 1/sqrt(3) BDF-2 at 2 ms on a garment on the walking body, and the guarded "
    "alpha = 1/sqrt(3) BDF-2 at 5 ms",
    [](CLI::App& sub) {
      auto a = std::make_shared<WalkArgs>();
      add_common_options(sub, a->scene, a->out, a->quiet);
      sub.get_option("--scene")->description("Scene file (default: the source tree's scenes/walk.json)");
      sub.add_option("--duration", a->options.duration, "Simulated time (s; default: the scene's)");
      sub.add_option("--edge-length", a->options.edge_length, "The garment's mesh size (m; default: the scene's)");
      sub.add_option("--configs", a->configs,
                     "Comma-separated labels to run (default all): im-5ms, im-2ms, be-2ms, be-5ms, bdf2-2ms, "
                     "bdf2-alpha-2ms, bdf2-alpha-guarded-5ms");
      sub.add_flag("--no-frames", a->no_frames, "Do not write LABEL/frames (PLY cloth with added viscosity, body OBJ)");
      sub.footer(
          "The default scene is scenes/walk.json. Distances are measured from the im-2ms run when it is run.\n"
          "Writes DIR/results.{md,csv,json}, DIR/liveliness.{csv,gp,png,svg} (figures need gnuplot),\n"
          "DIR/LABEL/{energy.csv,summary.json} and DIR/LABEL/frames/ (for weft render and weft view).\n"
          "A run that becomes unstable is recorded (status, time, why), not an error.");
      return std::function<int()>([a] { return run_walk(*a); });
    },
    65}};

}  // namespace
}  // namespace weft::app
