#include <png.h>

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "weft/gray_image.hpp"

namespace weft {
namespace {

// Writes `height` rows of `row_bytes` bytes each, of libpng colour type `color_type`.
void write_png_rows(const std::uint8_t* rows, int width, int height, size_t row_bytes, int color_type,
                    const std::filesystem::path& path) {
  const std::string where = "cannot write PNG '" + path.string() + "'";
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!file) throw std::runtime_error(where);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  if (!png) throw std::runtime_error(where + ": libpng initialisation failed");
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    throw std::runtime_error(where + ": libpng initialisation failed");
  }
  // libpng reports errors by longjmp; nothing with a destructor is created below this point.
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error(where);
  }
  png_init_io(png, file.get());
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8, color_type,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < height; ++y) png_write_row(png, const_cast<png_bytep>(rows + static_cast<size_t>(y) * row_bytes));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  if (std::fflush(file.get()) != 0) throw std::runtime_error(where);
}

}  // namespace

void write_png(const GrayImage& image, const std::filesystem::path& path) {
  write_png_rows(image.pixels.data(), image.width, image.height, static_cast<size_t>(image.width), PNG_COLOR_TYPE_GRAY,
                 path);
}

void write_png(const RgbImage& image, const std::filesystem::path& path) {
  write_png_rows(image.pixels.data(), image.width, image.height, 3 * static_cast<size_t>(image.width),
                 PNG_COLOR_TYPE_RGB, path);
}

}  // namespace weft
