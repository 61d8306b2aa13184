#include "weft/stability_image.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <vector>

#include "render/bitmap_font.hpp"
#include "weft/atomic_file.hpp"

namespace weft {
namespace {

constexpr std::uint8_t kInk = 0;
constexpr std::uint8_t kPaper = 255;

/// Tick values 0, step, 2 step, ... <= max with step 1, 2 or 5 times a power of ten, chosen
/// so there are about four to eight of them.
std::vector<double> nice_ticks(double max_value) {
  const double rough = max_value / 5.0;
  const double magnitude = std::pow(10.0, std::floor(std::log10(rough)));
  double step = magnitude;
  for (double factor : {1.0, 2.0, 5.0, 10.0}) {
    step = factor * magnitude;
    if (max_value / step <= 7.0) break;
  }
  std::vector<double> ticks;
  for (int k = 0; k * step <= max_value * (1.0 + 1e-9); ++k) ticks.push_back(k * step);
  return ticks;
}

std::string tick_label(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6g", value);
  return buffer;
}

void fill_rectangle(GrayImage& image, int x0, int y0, int width, int height, std::uint8_t grey) {
  for (int y = y0; y < y0 + height; ++y)
    for (int x = x0; x < x0 + width; ++x) image.set(x, y, grey);
}

}  // namespace

std::uint8_t stability_grey_level(double spectral_radius) {
  if (!(spectral_radius <= 1.0 + kStabilityTolerance)) return kPaper;
  const double r = std::clamp(spectral_radius, 0.0, 1.0);
  return static_cast<std::uint8_t>(std::lround(r * kMarginalGrey));
}

StabilityImage render_stability_image(const StabilityMap& map, const std::string& title) {
  const int size = static_cast<int>(map.kappa.size());
  if (size < 2 || static_cast<int>(map.lambda.size()) != size ||
      map.spectral_radius.rows() != size || map.spectral_radius.cols() != size)
    throw std::invalid_argument("render_stability_image: malformed map");
  const double kappa_max = map.kappa.back();
  const double lambda_max = map.lambda.back();
  const std::vector<double> kappa_ticks = nice_ticks(kappa_max);
  const std::vector<double> lambda_ticks = nice_ticks(lambda_max);

  // Font pixels grow with the plot so labels stay legible on large maps.
  const int scale = std::clamp(size / 300 + 1, 1, 4);
  const int pad = 4 * scale;
  const int tick_length = 3 * scale;
  const int text_height = render::kGlyphHeight * scale;
  int lambda_label_width = 0;
  for (double v : lambda_ticks)
    lambda_label_width = std::max(lambda_label_width, render::text_width(tick_label(v), scale));
  const std::string legend_top = "1", legend_bottom = "0", legend_unstable = ">1";
  const int legend_bar_width = 8 * scale;
  const int legend_label_width = render::text_width(legend_unstable, scale);

  StabilityImageLayout layout;
  layout.plot_size = size;
  layout.plot_left = pad + text_height + pad + lambda_label_width + pad + tick_length + 1;
  layout.plot_top = pad + text_height + pad + text_height / 2;
  const int plot_right = layout.plot_left + size;  // one past the last plot column
  const int plot_bottom = layout.plot_top + size;  // one past the last plot row
  const int legend_left = plot_right + 1 + 2 * pad;
  int width = legend_left + legend_bar_width + pad + legend_label_width + pad;
  width = std::max(width, layout.plot_left + render::text_width(title, scale) + pad);
  const int height = plot_bottom + 1 + tick_length + pad + text_height + pad + text_height + pad;

  StabilityImage result{GrayImage(width, height, kPaper), layout};
  GrayImage& image = result.image;

  // The map: column i is kappa_i, row counted from the bottom is lambda_j (paper fig. 2-4).
  for (int i = 0; i < size; ++i)
    for (int j = 0; j < size; ++j)
      image.at(layout.plot_left + i, plot_bottom - 1 - j) =
          stability_grey_level(map.spectral_radius(i, j));

  // Frame (axis lines) one pixel outside the plot.
  for (int x = layout.plot_left - 1; x <= plot_right; ++x) {
    image.set(x, layout.plot_top - 1, kInk);
    image.set(x, plot_bottom, kInk);
  }
  for (int y = layout.plot_top - 1; y <= plot_bottom; ++y) {
    image.set(layout.plot_left - 1, y, kInk);
    image.set(plot_right, y, kInk);
  }

  // kappa ticks and labels below the plot.
  const int kappa_label_top = plot_bottom + 1 + tick_length + pad / 2;
  for (double v : kappa_ticks) {
    const int x = layout.plot_left + static_cast<int>(std::lround(v / kappa_max * (size - 1)));
    for (int t = 1; t <= tick_length; ++t)
      for (int s = 0; s < scale; ++s) image.set(x + s, plot_bottom + t, kInk);
    const std::string label = tick_label(v);
    const int label_left = std::clamp(x - render::text_width(label, scale) / 2, 0,
                                      width - render::text_width(label, scale));
    render::draw_text(image, label_left, kappa_label_top, label, scale, kInk);
  }
  const std::string kappa_title = "kappa";
  render::draw_text(image,
                    layout.plot_left + (size - render::text_width(kappa_title, scale)) / 2,
                    kappa_label_top + text_height + pad, kappa_title, scale, kInk);

  // lambda ticks and labels left of the plot, lambda increasing upward.
  for (double v : lambda_ticks) {
    const int y = plot_bottom - 1 - static_cast<int>(std::lround(v / lambda_max * (size - 1)));
    for (int t = 1; t <= tick_length; ++t)
      for (int s = 0; s < scale; ++s) image.set(layout.plot_left - 1 - t, y - s, kInk);
    const std::string label = tick_label(v);
    const int label_top = std::clamp(y - text_height / 2, 0, height - text_height);
    render::draw_text(image,
                      layout.plot_left - 1 - tick_length - pad / 2 -
                          render::text_width(label, scale),
                      label_top, label, scale, kInk);
  }
  const std::string lambda_title = "lambda";
  render::draw_text_vertical(image, pad,
                             layout.plot_top + (size + render::text_width(lambda_title, scale)) / 2,
                             lambda_title, scale, kInk);

  render::draw_text(image, layout.plot_left, pad, title, scale, kInk);

  // Legend: a white "unstable" box above a ramp from radius 1 (top) down to 0 (bottom).
  const int box_height = std::max(text_height, size / 10);
  const int ramp_top = layout.plot_top + box_height + pad;
  const int ramp_height = plot_bottom - ramp_top;
  auto frame = [&](int top, int rows) {
    for (int x = legend_left - 1; x <= legend_left + legend_bar_width; ++x) {
      image.set(x, top - 1, kInk);
      image.set(x, top + rows, kInk);
    }
    for (int y = top - 1; y <= top + rows; ++y) {
      image.set(legend_left - 1, y, kInk);
      image.set(legend_left + legend_bar_width, y, kInk);
    }
  };
  fill_rectangle(image, legend_left, layout.plot_top, legend_bar_width, box_height, kPaper);
  frame(layout.plot_top, box_height);
  for (int row = 0; row < ramp_height; ++row) {
    const double radius = ramp_height > 1 ? 1.0 - static_cast<double>(row) / (ramp_height - 1) : 0.0;
    fill_rectangle(image, legend_left, ramp_top + row, legend_bar_width, 1,
                   stability_grey_level(radius));
  }
  frame(ramp_top, ramp_height);
  const int legend_text_left = legend_left + legend_bar_width + pad / 2 + 1;
  render::draw_text(image, legend_text_left, layout.plot_top + (box_height - text_height) / 2,
                    legend_unstable, scale, kInk);
  render::draw_text(image, legend_text_left, ramp_top, legend_top, scale, kInk);
  render::draw_text(image, legend_text_left, plot_bottom - text_height, legend_bottom, scale, kInk);
  return result;
}

void write_stability_csv(const StabilityMap& map, std::ostream& out) {
  out << "kappa,lambda,spectral_radius,stable\n";
  char line[128];
  const int size = static_cast<int>(map.kappa.size());
  for (int i = 0; i < size; ++i)
    for (int j = 0; j < size; ++j) {
      std::snprintf(line, sizeof line, "%.17g,%.17g,%.17g,%d\n", map.kappa[i], map.lambda[j],
                    map.spectral_radius(i, j), map.stable(i, j) ? 1 : 0);
      out << line;
    }
}

void write_stability_files(const StabilityMap& map, const std::string& title,
                           const std::filesystem::path& png_path,
                           const std::filesystem::path& csv_path) {
  const StabilityImage picture = render_stability_image(map, title);
  write_files_atomically({
      {png_path, [&](const std::filesystem::path& temporary) { write_png(picture.image, temporary); }},
      {csv_path,
       [&](const std::filesystem::path& temporary) {
         std::ofstream out(temporary);
         write_stability_csv(map, out);
         out.close();
         if (!out) throw std::runtime_error("cannot write CSV '" + temporary.string() + "'");
       }},
  });
}

}  // namespace weft
