#pragma once
// 8-bit rasters, greyscale (0 black, 255 white) and RGB, and their PNG writer (libpng).
#include <cstdint>
#include <filesystem>
#include <vector>

namespace weft {

struct GrayImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> pixels;  ///< width * height values, row-major, top row first

  GrayImage() = default;
  GrayImage(int width_px, int height_px, std::uint8_t fill)
      : width(width_px), height(height_px), pixels(static_cast<size_t>(width_px) * height_px, fill) {}

  bool contains(int x, int y) const { return x >= 0 && y >= 0 && x < width && y < height; }
  std::uint8_t& at(int x, int y) { return pixels[static_cast<size_t>(y) * width + x]; }
  std::uint8_t at(int x, int y) const { return pixels[static_cast<size_t>(y) * width + x]; }
  /// Sets a pixel; points outside the image are ignored.
  void set(int x, int y, std::uint8_t value) {
    if (contains(x, y)) at(x, y) = value;
  }
};

/// An 8-bit RGB raster (sRGB values).
struct RgbImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> pixels;  ///< 3 * width * height values (r, g, b), row-major, top row first

  RgbImage() = default;
  RgbImage(int width_px, int height_px) : width(width_px), height(height_px), pixels(3 * static_cast<size_t>(width_px) * height_px, 0) {}

  std::uint8_t* at(int x, int y) { return pixels.data() + 3 * (static_cast<size_t>(y) * width + x); }
  const std::uint8_t* at(int x, int y) const { return pixels.data() + 3 * (static_cast<size_t>(y) * width + x); }
};

/// Writes `image` as an 8-bit greyscale PNG at `path` (overwriting it).
/// Throws std::runtime_error naming the path if the file cannot be written.
void write_png(const GrayImage& image, const std::filesystem::path& path);
/// Writes `image` as an 8-bit RGB PNG at `path` (overwriting it); throws as above.
void write_png(const RgbImage& image, const std::filesystem::path& path);

}  // namespace weft
