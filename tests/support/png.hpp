#pragma once
// Reads a PNG file back for the tests (libpng): its header and its rows of bytes.
#include <png.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <vector>

namespace weft::test {

struct PngInfo {
  bool signature_ok = false;
  unsigned width = 0, height = 0;
  int color_type = -1, bit_depth = 0;
  std::vector<std::uint8_t> pixels;
};

inline PngInfo read_png(const std::filesystem::path& path) {
  PngInfo info;
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (!file) return info;
  png_byte signature[8] = {};
  if (std::fread(signature, 1, 8, file) != 8 || png_sig_cmp(signature, 0, 8) != 0) {
    std::fclose(file);
    return info;
  }
  info.signature_ok = true;
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop png_info = png_create_info_struct(png);
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &png_info, nullptr);
    std::fclose(file);
    info.width = info.height = 0;
    return info;
  }
  png_init_io(png, file);
  png_set_sig_bytes(png, 8);
  png_read_info(png, png_info);
  info.width = png_get_image_width(png, png_info);
  info.height = png_get_image_height(png, png_info);
  info.color_type = png_get_color_type(png, png_info);
  info.bit_depth = png_get_bit_depth(png, png_info);
  const size_t row_bytes = png_get_rowbytes(png, png_info);
  info.pixels.resize(row_bytes * info.height);
  for (unsigned y = 0; y < info.height; ++y) png_read_row(png, info.pixels.data() + y * row_bytes, nullptr);
  png_destroy_read_struct(&png, &png_info, nullptr);
  std::fclose(file);
  return info;
}

}  // namespace weft::test
