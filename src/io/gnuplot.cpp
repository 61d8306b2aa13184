#include "io/gnuplot.hpp"

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <system_error>

#include "weft/atomic_file.hpp"

namespace weft {

namespace {

std::string shell_quote(const std::string& text) {
  std::string q = "'";
  for (char c : text) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string gnuplot_program() {
  const char* env = std::getenv("WEFT_GNUPLOT");
  return env && *env ? env : "gnuplot";
}

}  // namespace

std::string gnuplot_quote(const std::string& text) {
  std::string q = "'";
  for (char c : text) q += c == '\'' ? std::string("''") : std::string(1, c);
  return q + "'";
}

std::string render_gnuplot_figure(const std::filesystem::path& dir, const GnuplotFigure& fig) {
  namespace fs = std::filesystem;
  const std::string script = fig.name + ".gp";
  // `suffix` lets weft render under temporary names; run by hand it writes the final files.
  write_file_atomically((dir / script).string(), [&](std::ostream& o) {
    o << "# Renders " << fig.name << ".png and " << fig.name << ".svg; run: gnuplot " << script
      << "\n"
      << "if (!exists(\"suffix\")) suffix = ''\n"
      << "set datafile separator ','\n"
      << "set terminal pngcairo size " << fig.width_px << "," << fig.height_px
      << " enhanced font 'Sans,10'\n"
      << "set output '" << fig.name << ".png'.suffix\n"
      << fig.body << "\nunset output\n"
      << "set terminal svg size " << fig.width_px << "," << fig.height_px
      << " enhanced font 'Sans,10'\n"
      << "set output '" << fig.name << ".svg'.suffix\n"
      << fig.body << "\nunset output\n";
  });
  const std::string program = gnuplot_program();
  const std::string manual =
      "run `cd " + shell_quote(dir.string()) + " && gnuplot " + script + "` to draw it";
  const std::string probe = "command -v " + shell_quote(program) + " > /dev/null 2>&1";
  if (std::system(probe.c_str()) != 0)
    return "gnuplot ('" + program + "') not found: wrote " + (dir / script).string() +
           " and its data; " + manual;

  const std::string command = "cd " + shell_quote(dir.string()) + " && " + shell_quote(program) +
                              " -e \"suffix='.tmp'\" " + shell_quote(script) + " 2>&1";
  std::string output;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return "could not start gnuplot; " + manual;
  std::array<char, 512> buffer{};
  while (fgets(buffer.data(), buffer.size(), pipe)) output += buffer.data();
  const int status = pclose(pipe);
  const fs::path png = dir / (fig.name + ".png"), svg = dir / (fig.name + ".svg");
  const fs::path png_tmp = dir / (fig.name + ".png.tmp"), svg_tmp = dir / (fig.name + ".svg.tmp");
  std::error_code ec;
  if (status != 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0 || !fs::exists(png_tmp) ||
      !fs::exists(svg_tmp)) {
    fs::remove(png_tmp, ec);
    fs::remove(svg_tmp, ec);
    return "gnuplot failed on " + (dir / script).string() + ": " + output;
  }
  fs::rename(png_tmp, png, ec);
  if (!ec) fs::rename(svg_tmp, svg, ec);
  if (ec) return "could not move the rendered figure into place: " + ec.message();
  return "";
}

}  // namespace weft
