// `weft stability`: spectral-radius map of an integrator on one damped spring
// (docs/method.md 3, the paper's figures 2-4), written as a PNG picture and a CSV table.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <limits>
#include <memory>
#include <string>

#include "command.hpp"
#include "weft/error.hpp"
#include "weft/stability.hpp"
#include "weft/stability_image.hpp"

namespace weft::app {
namespace {

constexpr int kMaxMapSize = 4096;

struct StabilityArgs {
  std::string method;
  double alpha = std::numeric_limits<double>::quiet_NaN();
  double kappa_max = 0.0;
  double lambda_max = 0.0;
  int size = 0;
  std::string out;
};

std::string number(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}

void require_positive_finite(const char* option, double value) {
  if (!(std::isfinite(value) && value > 0.0))
    throw InputError(std::string(option) + " " + number(value) +
                     ": expected a finite number greater than 0");
}

std::string scheme_title(const std::string& method, const StabilityScheme& scheme) {
  char buffer[128];
  std::snprintf(buffer, sizeof buffer, "%s, alpha=%.4g",
                method == "alpha" ? "alpha family" : method.c_str(), scheme.alpha);
  return buffer;
}

int run_stability(const StabilityArgs& args) {
  // Every check comes before any output (exit 2, nothing written).
  const StabilityScheme scheme = stability_scheme_by_name(args.method, args.alpha);
  require_positive_finite("--kappa-max", args.kappa_max);
  require_positive_finite("--lambda-max", args.lambda_max);
  if (args.size < 2 || args.size > kMaxMapSize)
    throw InputError("--size " + std::to_string(args.size) + ": expected an integer from 2 to " +
                     std::to_string(kMaxMapSize));
  const std::filesystem::path png_path = args.out;
  if (png_path.extension() != ".png" || png_path.stem().empty())
    throw InputError("--out '" + args.out + "': expected a file name ending in .png");
  std::filesystem::path csv_path = png_path;
  csv_path.replace_extension(".csv");

  const StabilityMap map = compute_stability_map(scheme, args.kappa_max, args.lambda_max, args.size);
  try {
    write_stability_files(map, scheme_title(args.method, scheme), png_path, csv_path);
  } catch (const std::exception& e) {
    throw InputError(std::string("--out '") + args.out + "': " + e.what());
  }

  long stable_points = 0;
  for (int i = 0; i < args.size; ++i)
    for (int j = 0; j < args.size; ++j) stable_points += map.stable(i, j) ? 1 : 0;
  Eigen::Index i_min = 0, j_min = 0;
  const double radius_min = map.spectral_radius.minCoeff(&i_min, &j_min);
  std::printf(
      "%s (alpha %.6g): %d x %d points, kappa 0..%g, lambda 0..%g\n"
      "  stable: %.1f%% of points; smallest spectral radius %.6g at kappa %.4g, lambda %.4g\n"
      "  wrote %s and %s\n",
      args.method.c_str(), scheme.alpha, args.size, args.size, args.kappa_max, args.lambda_max,
      100.0 * stable_points / (static_cast<double>(args.size) * args.size), radius_min,
      map.kappa[i_min], map.lambda[j_min], png_path.c_str(), csv_path.c_str());
  return kExitOk;
}

const RegisterCommand register_stability{CommandSpec{
    "",
    "stability",
    "Map the spectral radius of an integrator on one damped spring over kappa = k dt^2/m "
    "(horizontal) and lambda = l dt/m (vertical): a PNG in the style of the paper's figures "
    "2-4 (darker = faster decay, white = unstable) and a CSV of the values.",
    [](CLI::App& sub) {
      auto args = std::make_shared<StabilityArgs>();
      std::string methods;
      for (const auto& n : stability_method_names()) methods += (methods.empty() ? "" : ", ") + n;
      sub.add_option("--method", args->method, "Integrator: " + methods)->required();
      sub.add_option("--alpha", args->alpha,
                     "alpha in [0, 1] for methods alpha (required) and bdf2-alpha "
                     "(default 1/sqrt(3))");
      sub.add_option("--kappa-max", args->kappa_max, "Largest kappa = k dt^2 / m (> 0)")->required();
      sub.add_option("--lambda-max", args->lambda_max, "Largest lambda = l dt / m (> 0)")->required();
      sub.add_option("--size", args->size, "Grid points per axis (2 to 4096)")->required();
      sub.add_option("--out", args->out,
                     "Output PNG; the CSV goes beside it with the extension .csv")
          ->required();
      return [args] { return run_stability(*args); };
    },
    40}};

}  // namespace
}  // namespace weft::app
