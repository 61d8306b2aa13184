// `weft garment PATTERN.json --out DIR`: meshes a sewing pattern's panels (docs/garments.md)
// and writes them laid flat (OBJ), a picture of the panels with their meshes and stitches
// (SVG) and a summary. Placing the panels around the body and sewing them come later.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "command.hpp"
#include "experiment_common.hpp"
#include "garment/garment_mesh.hpp"
#include "weft/atomic_file.hpp"
#include "weft/error.hpp"

namespace fs = std::filesystem;

namespace weft::app {
namespace {

/// Mesh sizes accepted: below 2 mm a garment has millions of triangles, above 0.5 m a panel
/// is hardly sampled at all.
constexpr double kSmallestEdge_m = 0.002;
constexpr double kLargestEdge_m = 0.5;

struct GarmentArgs {
  std::string pattern_file, out;
  double edge_length_m = 0.015;
};

std::string num(double v, const char* format = "%.10g") {
  char b[64];
  std::snprintf(b, sizeof b, format, v);
  return b;
}

std::string thousands(long n) {
  std::string digits = std::to_string(n), out;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

/// A panel name as text in an SVG (panel names are any JSON key).
std::string xml_text(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '&')
      out += "&amp;";
    else if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '"')
      out += "&quot;";
    else if (static_cast<unsigned char>(c) < 0x20)
      out += ' ';
    else
      out += c;
  }
  return out;
}

/// A panel name on an OBJ `o` line, which ends at the line's end.
std::string obj_name(const std::string& name) {
  std::string out = name;
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 0x20) c = '_';
  return out;
}

/// Every panel laid flat at z = 0 at its layout offset, texture coordinates = pattern
/// coordinates (m), one object per panel.
std::string panels_obj(const Pattern& pattern, const GarmentMesh& mesh,
                       const std::vector<Vec2>& offsets) {
  std::ostringstream obj;
  obj << "# weft garment: pattern " << pattern.name << ", " << mesh.panels.size()
      << " panels laid flat at z = 0 (m); texture coordinates are pattern coordinates (m)\n";
  int first = 1;  // OBJ indices start at 1
  for (size_t p = 0; p < mesh.panels.size(); ++p) {
    const GarmentPanelMesh& panel = mesh.panels[p];
    obj << "o " << obj_name(panel.name) << "\n";
    for (const Vec2& x : panel.vertices_m) {
      const Vec2 laid = x + offsets[p];
      obj << "v " << num(laid.x()) << ' ' << num(laid.y()) << " 0\n";
    }
    for (const Vec2& x : panel.vertices_m) obj << "vt " << num(x.x()) << ' ' << num(x.y()) << "\n";
    for (const auto& t : panel.triangles) {
      obj << 'f';
      for (int v : t) obj << ' ' << first + v << '/' << first + v;
      obj << '\n';
    }
    first += static_cast<int>(panel.vertices_m.size());
  }
  return obj.str();
}

/// A colour per stitch, hues spread by the golden angle so neighbours differ.
std::string stitch_colour(size_t i) {
  return "hsl(" + num(std::fmod(static_cast<double>(i) * 137.508, 360.0), "%.0f") + ",80%,42%)";
}

/// The flat panels drawn with their mesh edges (grey), outlines (black) and stitches: both
/// sides of a stitch in one colour and labelled with its number; each panel labelled with its
/// name.
std::string panels_svg(const Pattern& pattern, const GarmentMesh& mesh,
                       const std::vector<Vec2>& offsets, double edge_length_m) {
  constexpr double kPixelsPerMetre = 500, kMargin = 40, kTitle = 30;
  Vec2 lo = Vec2::Constant(INFINITY), hi = Vec2::Constant(-INFINITY);
  for (size_t p = 0; p < mesh.panels.size(); ++p)
    for (const Vec2& x : mesh.panels[p].vertices_m) {
      lo = lo.cwiseMin(x + offsets[p]);
      hi = hi.cwiseMax(x + offsets[p]);
    }
  // Wide enough for the title line too (about 8 px a character at 16 px).
  const double width =
      std::max((hi.x() - lo.x()) * kPixelsPerMetre + 2 * kMargin, 2 * kMargin + 8.5 * 90);
  const double height = (hi.y() - lo.y()) * kPixelsPerMetre + 2 * kMargin + kTitle;
  // SVG's y runs down; the pattern's runs up.
  auto px = [&](const Vec2& x) {
    return num((x.x() - lo.x()) * kPixelsPerMetre + kMargin, "%.2f") + "," +
           num((hi.y() - x.y()) * kPixelsPerMetre + kMargin + kTitle, "%.2f");
  };
  long triangles = 0;
  for (const auto& panel : mesh.panels) triangles += static_cast<long>(panel.triangles.size());

  std::ostringstream svg;
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << num(width, "%.0f")
      << "\" height=\"" << num(height, "%.0f") << "\" viewBox=\"0 0 " << num(width, "%.0f") << ' '
      << num(height, "%.0f") << "\" font-family=\"sans-serif\">\n"
      << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      << "<text x=\"" << kMargin
      << "\" y=\"24\" font-size=\"16\">weft garment: " << xml_text(pattern.name) << ", "
      << mesh.panels.size() << " panels, " << thousands(triangles) << " triangles at "
      << num(100 * edge_length_m, "%.3g") << " cm, " << mesh.stitches.size()
      << " stitches (flat, 1 m = " << num(kPixelsPerMetre, "%.0f") << " px)</text>\n";
  for (size_t p = 0; p < mesh.panels.size(); ++p) {
    const GarmentPanelMesh& panel = mesh.panels[p];
    auto at = [&](int v) { return px(panel.vertices_m[static_cast<size_t>(v)] + offsets[p]); };
    svg << "<g id=\"panel-" << p
        << "\">\n<path fill=\"#eef3fa\" stroke=\"black\" stroke-width=\"1.2\" d=\"M";
    for (int v = 0; v < panel.boundary_vertices; ++v) svg << (v ? " L" : "") << at(v);
    svg << " Z\"/>\n<path fill=\"none\" stroke=\"#8a8a8a\" stroke-width=\"0.4\" d=\"";
    std::set<std::pair<int, int>> edges;
    for (const auto& t : panel.triangles)
      for (int i = 0; i < 3; ++i) edges.insert(std::minmax(t[i], t[(i + 1) % 3]));
    for (const auto& e : edges) svg << 'M' << at(e.first) << 'L' << at(e.second);
    svg << "\"/>\n</g>\n";
  }
  for (size_t s = 0; s < mesh.stitches.size(); ++s) {
    const StitchVertexPairs& st = mesh.stitches[s];
    const std::string colour = stitch_colour(s);
    for (int side = 0; side < 2; ++side) {
      const size_t p = static_cast<size_t>(side ? st.panel_b : st.panel_a);
      const GarmentPanelMesh& panel = mesh.panels[p];
      svg << "<polyline fill=\"none\" stroke=\"" << colour
          << "\" stroke-width=\"3.5\" stroke-opacity=\"0.8\" stroke-linecap=\"round\" points=\"";
      for (const auto& pair : st.pairs)
        svg << px(panel.vertices_m[static_cast<size_t>(pair[static_cast<size_t>(side)])] +
                  offsets[p])
            << ' ';
      svg << "\"/>\n";
      // The label sits at the side's middle vertex, nudged into the panel by the font's size.
      const auto& mid = st.pairs[st.pairs.size() / 2];
      const Vec2 x =
          panel.vertices_m[static_cast<size_t>(mid[static_cast<size_t>(side)])] + offsets[p];
      const std::string at = px(x);
      svg << "<text x=\"" << at.substr(0, at.find(',')) << "\" y=\"" << at.substr(at.find(',') + 1)
          << "\" font-size=\"13\" font-weight=\"bold\" fill=\"" << colour
          << "\" text-anchor=\"middle\" dominant-baseline=\"middle\" stroke=\"white\" "
             "stroke-width=\"3\" "
             "paint-order=\"stroke\">"
          << s << "</text>\n";
    }
  }
  for (size_t p = 0; p < mesh.panels.size(); ++p) {
    const GarmentPanelMesh& panel = mesh.panels[p];
    Vec2 centre = Vec2::Zero();
    for (int v = 0; v < panel.boundary_vertices; ++v)
      centre += panel.vertices_m[static_cast<size_t>(v)];
    const std::string at = px(centre / panel.boundary_vertices + offsets[p]);
    svg << "<text x=\"" << at.substr(0, at.find(',')) << "\" y=\"" << at.substr(at.find(',') + 1)
        << "\" font-size=\"15\" text-anchor=\"middle\" dominant-baseline=\"middle\" "
           "stroke=\"white\" "
           "stroke-width=\"4\" paint-order=\"stroke\">"
        << xml_text(panel.name) << "</text>\n";
  }
  svg << "</svg>\n";
  return svg.str();
}

nlohmann::json garment_summary(const Pattern& pattern, const GarmentMesh& mesh,
                               const GarmentArgs& a, double meshing_s) {
  nlohmann::json panels = nlohmann::json::array(), stitches = nlohmann::json::array();
  long triangles = 0, vertices = 0;
  double area_m2 = 0;
  for (const GarmentPanelMesh& panel : mesh.panels) {
    const PanelMeshStats stats = panel_mesh_stats(panel);
    panels.push_back({{"name", panel.name},
                      {"triangles", panel.triangles.size()},
                      {"vertices", panel.vertices_m.size()},
                      {"boundary_vertices", panel.boundary_vertices},
                      {"area_m2", stats.area_m2},
                      {"smallest_angle_deg", stats.smallest_angle_deg},
                      {"mean_edge_m", stats.mean_edge_m},
                      {"grain_angle_deg", panel.grain_angle_rad * 180 / M_PI}});
    triangles += static_cast<long>(panel.triangles.size());
    vertices += static_cast<long>(panel.vertices_m.size());
    area_m2 += stats.area_m2;
  }
  for (size_t s = 0; s < mesh.stitches.size(); ++s) {
    const StitchVertexPairs& st = mesh.stitches[s];
    auto side = [&](int panel, int edge) {
      const Panel& p = pattern.panels[static_cast<size_t>(panel)];
      return nlohmann::json{{"panel", p.name},
                            {"edge", edge},
                            {"length_m", curve_length_m(p.edges[static_cast<size_t>(edge)].curve)},
                            {"vertices", mesh.panels[static_cast<size_t>(panel)]
                                             .edge_vertices[static_cast<size_t>(edge)]
                                             .size()}};
    };
    stitches.push_back({{"a", side(st.panel_a, st.edge_a)},
                        {"b", side(st.panel_b, st.edge_b)},
                        {"same_direction", pattern.stitches[s].same_direction}});
  }
  return {{"pattern", pattern.name},
          {"file", a.pattern_file},
          {"stage", "meshed (placement around the body and sewing are not implemented yet)"},
          {"edge_length_m", a.edge_length_m},
          {"panels", panels},
          {"stitches", stitches},
          {"triangles", triangles},
          {"vertices", vertices},
          {"area_m2", area_m2},
          {"meshing_time_s", meshing_s}};
}

PendingFile text_output(const fs::path& path, std::string text) {
  return {path, [text = std::move(text)](const fs::path& temporary) {
            std::ofstream f(temporary, std::ios::binary);
            f << text;
            f.close();
            if (!f) throw std::runtime_error("cannot write " + temporary.string());
          }};
}

int run_garment(const GarmentArgs& a) {
  if (!(a.edge_length_m >= kSmallestEdge_m && a.edge_length_m <= kLargestEdge_m))
    throw InputError("--edge-length " + num(a.edge_length_m) +
                     ": expected a length in metres from " + num(kSmallestEdge_m) + " to " +
                     num(kLargestEdge_m));
  check_output_folder(a.out);
  // Everything is read and meshed before the first file is written.
  const Pattern pattern = load_pattern(a.pattern_file);
  const auto start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  GarmentMeshOptions options;
  options.target_edge_m = a.edge_length_m;
  const GarmentMesh mesh = mesh_garment(pattern, options);
  const double meshing_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double meshing_cpu_s = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;

  const std::vector<Vec2> offsets = flat_layout_offsets(mesh);
  nlohmann::json summary = garment_summary(pattern, mesh, a, meshing_s);
  // CPU time too: on a busy machine the wall time says more about the other work.
  summary["meshing_cpu_time_s"] = meshing_cpu_s;
  const fs::path dir(a.out);
  write_files_atomically(
      {text_output(dir / "panels.obj", panels_obj(pattern, mesh, offsets)),
       text_output(dir / "panels.svg", panels_svg(pattern, mesh, offsets, a.edge_length_m)),
       text_output(dir / "summary.json", summary.dump(2) + "\n")});

  std::printf(
      "weft garment: %s: %zu panels, %zu stitches, %s triangles, %.3f m^2 at %.3g cm in %.0f ms "
      "(CPU %.0f ms)\n",
      pattern.name.c_str(), mesh.panels.size(), mesh.stitches.size(),
      thousands(summary["triangles"].get<long>()).c_str(), summary["area_m2"].get<double>(),
      100 * a.edge_length_m, 1e3 * meshing_s, 1e3 * meshing_cpu_s);
  for (const auto& p : summary["panels"])
    std::printf("  %-22s %6ld triangles  %.4f m^2  smallest angle %4.1f deg  mean edge %.2f cm\n",
                p["name"].get<std::string>().c_str(), p["triangles"].get<long>(),
                p["area_m2"].get<double>(), p["smallest_angle_deg"].get<double>(),
                100 * p["mean_edge_m"].get<double>());
  std::printf(
      "  wrote %s (panels.obj, panels.svg, summary.json); placement around the body and sewing are "
      "not implemented yet\n",
      dir.string().c_str());
  return kExitOk;
}

RegisterCommand reg{
    {"", "garment", "Mesh a sewing pattern's panels, laid flat (placement and sewing: not yet)",
     [](CLI::App& sub) {
       sub.footer(
           "Reads a GarmentCode or Garment-Pattern-Generator pattern (docs/garments.md), meshes "
           "every panel\n"
           "with both sides of each stitch given matching boundary vertices, and writes "
           "DIR/panels.obj (the\n"
           "panels laid flat at z = 0, texture coordinates = pattern coordinates in metres, one "
           "object per\n"
           "panel), DIR/panels.svg (the panels, their meshes and stitches) and DIR/summary.json.\n"
           "The command stops after meshing: placing the panels around the body and sewing them "
           "are not\n"
           "implemented yet. Exit status 2 for a bad pattern or option (nothing written).");
       auto a = std::make_shared<GarmentArgs>();
       sub.add_option("pattern", a->pattern_file, "Pattern file (JSON)")->required();
       sub.add_option("--out,-o", a->out, "Output folder (created)")->required();
       sub.add_option("--edge-length", a->edge_length_m, "Target mesh edge length (m)")
           ->capture_default_str();
       return std::function<int()>([a] { return run_garment(*a); });
     },
     60}};

}  // namespace
}  // namespace weft::app
