#pragma once
// Pictures and tables of stability maps in the style of the paper's figures 2-4:
// kappa horizontal, lambda vertical (increasing upward), greyscale with darker = smaller
// spectral radius and white = unstable.
#include <cstdint>
#include <filesystem>
#include <ostream>
#include <string>

#include "weft/gray_image.hpp"
#include "weft/stability.hpp"

namespace weft {

/// Grey level of a grid point: stable radii r in [0, 1] map linearly to 0 (black) ..
/// kMarginalGrey, so the marginal r = 1 stays distinguishable from unstable (255, white).
/// NaN counts as unstable.
constexpr std::uint8_t kMarginalGrey = 224;
std::uint8_t stability_grey_level(double spectral_radius);

/// Where the map lies in the picture: grid point (i, j) (kappa_i, lambda_j) is the pixel
/// (plot_left + i, plot_top + plot_size - 1 - j). The plot is framed by axis lines one
/// pixel outside it.
struct StabilityImageLayout {
  int plot_left = 0;
  int plot_top = 0;
  int plot_size = 0;
};

struct StabilityImage {
  GrayImage image;
  StabilityImageLayout layout;
};

/// Renders `map` with a frame, ticks and numeric labels on both axes, the axis titles
/// "kappa" and "lambda", `title` above, and a grey-scale legend on the right.
StabilityImage render_stability_image(const StabilityMap& map, const std::string& title);

/// The map as CSV: header "kappa,lambda,spectral_radius,stable", then one row per grid
/// point (kappa outer, lambda inner), stable 1 when radius <= 1 + kStabilityTolerance else 0.
void write_stability_csv(const StabilityMap& map, std::ostream& out);

/// Writes the PNG and the CSV together (both or neither; see write_files_atomically).
void write_stability_files(const StabilityMap& map, const std::string& title,
                           const std::filesystem::path& png_path,
                           const std::filesystem::path& csv_path);

}  // namespace weft
