// `weft experiment stability --out DIR`: the stability experiment of the paper's figure 5
// (include/weft/experiments/stability_experiment.hpp, docs/stability-experiment.md).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

#include "command.hpp"
#include "weft/experiments/stability_experiment.hpp"
#include "progress.hpp"
#include "weft/atomic_file.hpp"
#include "weft/error.hpp"

namespace {

struct ExperimentArgs {
  std::string out, methods;
  weft::StabilityExperimentSettings settings;
  bool quiet = false;
};

void write_text(const std::filesystem::path& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  f << text;
  f.close();
  if (!f) throw std::runtime_error(path.string() + ": cannot write");
}

int run(ExperimentArgs& a) {
  using namespace weft;
  auto& s = a.settings;
  if (!a.methods.empty()) s.methods = parse_stability_methods(a.methods, "--methods");
  validate(s);
  app::Progress progress("weft experiment stability", !a.quiet);
  const StabilityExperimentResult r = run_stability_experiment(s, [&](double f) { progress.update(f); });
  progress.finish();
  const std::string csv = stability_csv(r), md = stability_markdown(r);
  const std::filesystem::path out(a.out);
  write_files_atomically({{out / "stability.csv", [&](const std::filesystem::path& p) { write_text(p, csv); }},
                          {out / "stability.md", [&](const std::filesystem::path& p) { write_text(p, md); }}});
  if (!a.quiet) {
    long unstable = 0;
    for (const auto& c : r.cells) unstable += c.stable ? 0 : 1;
    std::fprintf(stderr, "%zu cells (%ld unstable) in %.1f s; results in %s (stability.csv, stability.md)\n",
                 r.cells.size(), unstable, r.wall_seconds, a.out.c_str());
  }
  return app::kExitOk;
}

weft::app::RegisterCommand reg{{"experiment", "stability",
  "Stability of each integrator on a randomly deformed free square of cloth, per time step and damping ratio",
  [](CLI::App& sub) {
    auto a = std::make_shared<ExperimentArgs>();
    auto& s = a->settings;
    sub.add_option("--out,-o", a->out, "Output folder (stability.csv, stability.md)")->required();
    sub.add_option("--seed", s.seed, "Seed of the random perturbation")->capture_default_str();
    sub.add_option("--duration", s.duration_s, "Simulated time per cell in seconds")->capture_default_str();
    sub.add_option("--resolution", s.resolution, "Vertices per side of the square")->capture_default_str();
    sub.add_option("--size", s.size_m, "Side of the square in metres")->capture_default_str();
    sub.add_option("--stretch-modulus", s.stretch_modulus_N_m, "Weft and warp stiffness (N/m), linear")
        ->capture_default_str();
    sub.add_option("--shear-modulus", s.shear_modulus_N_m, "Shear stiffness (N/m), linear")->capture_default_str();
    sub.add_option("--density", s.surface_density_kg_m2, "Surface density (kg/m^2)")->capture_default_str();
    sub.add_option("--bending-rigidity", s.bending_rigidity_Nm, "Bending rigidity (N m)")->capture_default_str();
    sub.add_option("--fold", s.fold_fraction, "Amplitude of the smooth random fold, as a fraction of the size")
        ->capture_default_str();
    sub.add_option("--jitter", s.jitter_fraction, "Per-vertex random displacement, as a fraction of the edge length")
        ->capture_default_str();
    sub.add_option("--velocity", s.velocity_m_s, "Amplitude of the smooth random initial velocity (m/s)")
        ->capture_default_str();
    sub.add_option("--rest-fraction", s.rest_fraction,
                   "At rest: kinetic energy below this fraction of the initial energy for 0.1 s")
        ->capture_default_str();
    sub.add_option("--methods", a->methods,
                   "Comma-separated NAME or NAME:ALPHA (e.g. implicit-midpoint,alpha:2/3,bdf2-alpha); default: "
                   "forward-euler, backward-euler, implicit-midpoint-plain, implicit-midpoint, alpha:0.6, alpha:2/3, bdf2, bdf2-alpha");
    sub.add_option("--dts", s.dts, "Comma-separated time steps in seconds")->delimiter(',')->capture_default_str();
    sub.add_option("--ratios", s.ratios, "Comma-separated adaptive damping ratios (fractions of critical)")
        ->delimiter(',')
        ->capture_default_str();
    sub.add_flag("--quiet,-q", a->quiet, "No progress output");
    sub.footer(
        "Writes DIR/stability.csv (one row per method, dt and ratio) and DIR/stability.md (a table per method).\n"
        "See docs/stability-experiment.md.");
    return std::function<int()>([a] { return run(*a); });
  }, 50}};

}  // namespace
