#pragma once
// The paper's walk comparison (its section 3.2, docs/walk.md): one garment-on-a-body scene run
// with Implicit Midpoint (5% adaptive damping) at 5 ms and 2 ms, backward Euler at 2 ms and
// 5 ms, BDF-2 and the alpha = 1/sqrt(3) BDF-2 at 2 ms. Per run: wall time split into its parts,
// steps, CG iterations, intersections per frame, energies, and how lively the garment moves
// (weft/experiments/liveliness.hpp), including its distance from the Implicit Midpoint 2 ms run.
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "weft/experiments/trajectory.hpp"

namespace weft {

struct WalkConfiguration {
  MethodConfiguration configuration;
  double dt = 0.005;
};
/// The six configurations in table order; the first one with label "im-2ms" is the reference.
std::vector<WalkConfiguration> walk_configurations();

struct WalkExperimentOptions {
  std::optional<double> duration;     ///< overrides the scene's
  std::optional<double> edge_length;  ///< a garment's mesh size (m), overriding the scene's
  std::vector<std::string> only;      ///< labels to run (empty: all)
  bool frames = true;                 ///< write LABEL/frames (PLY with added viscosity, body OBJ)
};

struct WalkRun {
  WalkConfiguration entry;
  RunResult result;
  nlohmann::json summary;
  std::vector<double> time;              ///< per output frame (s)
  std::vector<double> relative_kinetic;  ///< garment kinetic energy relative to the body (J)
  std::vector<double> hem_forward;       ///< hem centre ahead of the body's centre (m, walking direction)
  std::vector<long> intersections;       ///< cloth self plus cloth-body, per frame
  std::vector<VecX> positions;           ///< per frame
  std::vector<double> distance;          ///< RMS vertex distance from the reference per frame (m)
  double swing = 0;                      ///< swing_amplitude of hem_forward after the blend (m)
};

struct WalkExperiment {
  Scene scene;
  std::vector<WalkRun> runs;
  std::string reference;  ///< label of the run the distances are measured from ("" if none ran)
};

using WalkProgress = std::function<void(const std::string& label, double fraction)>;

/// Runs the configurations; writes each run's frames under dir/LABEL/frames as it goes when
/// options.frames. Throws InputError for bad options (an unknown label, a scene without a body
/// collider).
WalkExperiment run_walk_experiment(const Scene& scene, const WalkExperimentOptions& options,
                                   const std::filesystem::path& dir, const WalkProgress& progress = {});

/// Writes dir/LABEL/{energy.csv,summary.json}, dir/results.{json,csv,md}, dir/liveliness.csv
/// and the figures dir/liveliness.{gp,png,svg}. Returns warnings (gnuplot missing).
std::vector<std::string> write_walk_experiment(const WalkExperiment& experiment, const std::filesystem::path& dir);

/// The table of results.md (Markdown).
std::string walk_results_markdown(const WalkExperiment& experiment);

}  // namespace weft
