#pragma once
// A 5x7 pixel bitmap font for labelling plots (digits, lowercase letters, N, a few signs).
#include <cstdint>
#include <string>

#include "weft/gray_image.hpp"

namespace weft::render {

constexpr int kGlyphWidth = 5;
constexpr int kGlyphHeight = 7;
constexpr int kGlyphAdvance = 6;  ///< glyph width plus one column of spacing

/// Width in pixels of `text` drawn at `scale` (each font pixel becomes scale x scale).
int text_width(const std::string& text, int scale);

/// Draws `text` left to right with its top-left corner at (x, y); characters without a
/// glyph are drawn as '?'. Pixels outside the image are skipped.
void draw_text(GrayImage& image, int x, int y, const std::string& text, int scale,
               std::uint8_t ink);

/// Draws `text` rotated a quarter turn counter-clockwise (reading bottom to top), with the
/// bottom-left corner of the first glyph at (x, y).
void draw_text_vertical(GrayImage& image, int x, int y, const std::string& text, int scale,
                        std::uint8_t ink);

}  // namespace weft::render
