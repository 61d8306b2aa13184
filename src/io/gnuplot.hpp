#pragma once
// Figures drawn by gnuplot: weft writes the data and a script, then runs gnuplot if it is
// installed. Without gnuplot the script and data stay for later and the caller gets a warning.
#include <filesystem>
#include <string>

namespace weft {

struct GnuplotFigure {
  std::string name;  ///< file stem: NAME.gp renders NAME.png and NAME.svg in the same folder
  std::string body;  ///< gnuplot commands that draw the figure (after terminal and output)
  int width_px = 900, height_px = 600;
};

/// Writes DIR/NAME.gp (atomically) and, when gnuplot can be run, renders NAME.png and NAME.svg
/// in DIR (each renamed into place only once gnuplot succeeded). Data files the body names are
/// read relative to DIR. The program is $WEFT_GNUPLOT if set, else `gnuplot`.
/// Returns "" on success, otherwise a warning saying what to run by hand.
std::string render_gnuplot_figure(const std::filesystem::path& dir, const GnuplotFigure& figure);

/// Quotes a string for a gnuplot single-quoted literal.
std::string gnuplot_quote(const std::string& text);

}  // namespace weft
