// `weft garment PATTERN.json --out DIR`: meshes a sewing pattern's panels (docs/garments.md),
// places them around the mannequin in its bind pose and sews them into one garment; writes the
// sewn garment (OBJ), the panels laid flat (OBJ), a picture of the panels with their meshes and
// stitches (SVG) and a summary.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "command.hpp"
#include "experiment_common.hpp"
#include "weft/garment/garment_mesh.hpp"
#include "weft/garment/placement.hpp"
#include "weft/garment/sewing.hpp"
#include "weft/material.hpp"
#include "weft/atomic_file.hpp"
#include "weft/error.hpp"

namespace fs = std::filesystem;

namespace weft::app {
namespace {

/// Mesh sizes accepted: below 2 mm a garment has millions of triangles, above 0.5 m a panel
/// is hardly sampled at all.
constexpr double kSmallestEdge_m = 0.002;
constexpr double kLargestEdge_m = 0.5;
/// garment.obj's positions: 9 significant digits (a nanometre at a metre).
constexpr const char* kObjDigits = "%.9g";

struct GarmentArgs {
  std::string pattern_file, out;
  double edge_length_m = 0.015;
  bool no_sew = false;
  double clearance_m = 0.02;
  std::string material = "cotton";
  std::vector<std::string> panel_materials;  ///< NAME=PRESET
  std::vector<std::string> panel_grains;     ///< NAME=DEGREES
  double seam_stiffness_N_m = 1e4;
  double sewing_time_s = 0.5;
  bool allow_open_seams = false;  ///< write an unsewn garment as garment.obj and exit 0
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
          {"stage", "meshed"},
          {"edge_length_m", a.edge_length_m},
          {"panels", panels},
          {"stitches", stitches},
          {"triangles", triangles},
          {"vertices", vertices},
          {"area_m2", area_m2},
          {"meshing_time_s", meshing_s}};
}

/// The sewn garment: positions (m), texture coordinates = the flat panels' coordinates (m)
/// per triangle corner (a seam vertex has one on each panel it joins), one group per panel.
std::string garment_obj(const Pattern& pattern, const SewnGarment& sewn) {
  std::ostringstream obj;
  const TriMesh& m = sewn.mesh;
  obj << "# weft garment: pattern " << pattern.name << ", sewn on the mannequin in its bind pose (m); texture "
      << "coordinates are the flat panels' coordinates (m), one group per panel\n";
  for (int v = 0; v < m.num_vertices(); ++v)
    obj << "v " << num(m.positions(v, 0), kObjDigits) << ' ' << num(m.positions(v, 1), kObjDigits) << ' '
        << num(m.positions(v, 2), kObjDigits) << "\n";
  // One texture coordinate per distinct (vertex, place).
  std::map<std::pair<int, std::pair<double, double>>, int> uv_index;
  std::vector<std::array<int, 3>> corner_uv(m.triangles.size());
  for (size_t t = 0; t < m.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const Vec2& u = m.corner(t, k);
      const auto key = std::make_pair(m.triangles[t][k], std::make_pair(u.x(), u.y()));
      auto [it, inserted] = uv_index.try_emplace(key, static_cast<int>(uv_index.size()) + 1);
      if (inserted) obj << "vt " << num(u.x(), "%.9g") << ' ' << num(u.y(), "%.9g") << "\n";
      corner_uv[t][k] = it->second;
    }
  int panel = -1;
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    if (sewn.panel_of_triangle[t] != panel) {
      panel = sewn.panel_of_triangle[t];
      obj << "g " << obj_name(pattern.panels[static_cast<size_t>(panel)].name) << "\n";
    }
    obj << 'f';
    for (int k = 0; k < 3; ++k) obj << ' ' << m.triangles[t][k] + 1 << '/' << corner_uv[t][k];
    obj << '\n';
  }
  return obj.str();
}

nlohmann::json sewing_summary(const Pattern& pattern, const PlacedGarment& placed, const SewnGarment& sewn,
                              const GarmentArgs& a, double wall_s) {
  nlohmann::json parts = nlohmann::json::object();
  for (size_t p = 0; p < pattern.panels.size(); ++p) parts[pattern.panels[p].name] = body_part_name(placed.panel_part[p]);
  std::vector<double> gap = sewn.stitch_gap_m;
  gap.resize(pattern.stitches.size(), 0.0);
  nlohmann::json open = nlohmann::json::array();
  for (int st : sewn.open_stitches) {
    const Stitch& stitch = pattern.stitches[static_cast<size_t>(st)];
    auto side = [&](const StitchSide& x) {
      return nlohmann::json{{"panel", pattern.panels[static_cast<size_t>(x.panel)].name}, {"edge", x.edge}};
    };
    open.push_back({{"stitch", st}, {"a", side(stitch.a)}, {"b", side(stitch.b)}, {"gap_m", gap[static_cast<size_t>(st)]}});
  }
  const EdgeUse edges = edge_use(sewn.mesh.triangles);
  double area = 0;
  for (size_t t = 0; t < sewn.mesh.triangles.size(); ++t) {
    const Vec2 e1 = sewn.mesh.corner(t, 1) - sewn.mesh.corner(t, 0), e2 = sewn.mesh.corner(t, 2) - sewn.mesh.corner(t, 0);
    area += 0.5 * std::abs(e1.x() * e2.y() - e1.y() * e2.x());
  }
  return {{"clearance_m", a.clearance_m},
          {"panel_parts", parts},
          {"vertices_pushed_out_of_the_body", placed.vertices_pushed_out},
          {"panels_moved_apart", placed.panels_moved_apart},
          {"material", a.material},
          {"seam_stiffness_N_m", a.seam_stiffness_N_m},
          {"largest_seam_gap_placed_m", sewn.largest_gap_placed_m},
          {"largest_seam_gap_m", sewn.largest_gap_m},
          {"largest_seam_gap_per_stitch_m", gap},
          {"weld_gap_m", sewn.weld_gap_m},
          {"open_stitches", open},
          {"sewn", sewn.sewn()},
          {"converged", sewn.converged},
          {"simulated_time_s", sewn.sewing_time_s},
          {"steps", sewn.steps},
          {"time_s", wall_s},
          {"garment", {{"vertices", sewn.mesh.num_vertices()},
                       {"triangles", sewn.mesh.triangles.size()},
                       {"area_m2", area},
                       {"boundary_edges", edges.boundary},
                       {"non_manifold_edges", edges.non_manifold},
                       {"inconsistently_oriented_edges", edges.inconsistent}}},
          {"intersections", {{"self", sewn.intersections.cloth_self.count},
                             {"body", sewn.intersections.cloth_body.empty() ? 0 : sewn.intersections.cloth_body[0].count}}}};
}

/// The NAME=VALUE options given per panel (--panel-material, --panel-grain), by panel name.
std::map<std::string, std::string> per_panel_values(const Pattern& pattern, const std::vector<std::string>& given,
                                                    const std::string& option, const std::string& value_name) {
  std::map<std::string, std::string> out;
  for (const std::string& g : given) {
    const size_t eq = g.rfind('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == g.size())
      throw InputError(option + " '" + g + "': expected NAME=" + value_name);
    const std::string name = g.substr(0, eq);
    bool found = false;
    for (const Panel& panel : pattern.panels) found = found || panel.name == name;
    if (!found) throw InputError(option + " '" + g + "': the pattern " + pattern.file + " has no panel '" + name + "'");
    if (!out.emplace(name, g.substr(eq + 1)).second)
      throw InputError(option + " '" + g + "': panel '" + name + "' is given twice");
  }
  return out;
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
  if (!(a.clearance_m >= 0.002 && a.clearance_m <= 0.2))
    throw InputError("--clearance " + num(a.clearance_m) + ": expected a gap in metres from 0.002 to 0.2");
  if (!(a.seam_stiffness_N_m > 0 && a.seam_stiffness_N_m <= 1e7))
    throw InputError("--seam-stiffness " + num(a.seam_stiffness_N_m) + ": expected a stiffness in N/m in (0, 1e7]");
  if (!(a.sewing_time_s > 0 && a.sewing_time_s <= 60))
    throw InputError("--sewing-time " + num(a.sewing_time_s) + ": expected simulated seconds in (0, 60]");
  const Material fabric = material_preset(a.material);
  check_output_folder(a.out);
  // Everything is read and meshed before the first file is written.
  const Pattern pattern = load_pattern(a.pattern_file);
  // Per panel: its fabric (the --material preset unless --panel-material names one) and grain.
  std::vector<Material> panel_materials;
  std::vector<std::string> panel_material_names;
  const auto material_names = per_panel_values(pattern, a.panel_materials, "--panel-material", "PRESET");
  for (const Panel& panel : pattern.panels) {
    const auto own = material_names.find(panel.name);
    if (own == material_names.end()) {
      panel_materials.push_back(fabric);
      panel_material_names.push_back(a.material);
      continue;
    }
    try {
      panel_materials.push_back(material_preset(own->second));
    } catch (const InputError& e) {
      throw InputError("--panel-material '" + own->first + "=" + own->second + "': " + e.what());
    }
    panel_material_names.push_back(own->second);
  }
  GarmentMeshOptions options;
  options.target_edge_m = a.edge_length_m;
  for (const auto& [name, text] : per_panel_values(pattern, a.panel_grains, "--panel-grain", "DEGREES")) {
    size_t used = 0;
    double degrees = NAN;
    try {
      degrees = std::stod(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != text.size() || !(degrees >= -360 && degrees <= 360))
      throw InputError("--panel-grain '" + name + "=" + text + "': expected an angle in degrees from -360 to 360");
    options.grain_angle_rad[name] = degrees * M_PI / 180;
  }
  const auto start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  const GarmentMesh mesh = mesh_garment(pattern, options);
  const double meshing_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double meshing_cpu_s = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;

  const std::vector<Vec2> offsets = flat_layout_offsets(mesh);
  nlohmann::json summary = garment_summary(pattern, mesh, a, meshing_s);
  for (size_t p = 0; p < pattern.panels.size(); ++p) summary["panels"][p]["material"] = panel_material_names[p];
  // CPU time too: on a busy machine the wall time says more about the other work.
  summary["meshing_cpu_time_s"] = meshing_cpu_s;
  const fs::path dir(a.out);
  std::string garment_file;  // written when sewing: garment.obj, or garment_unsewn.obj
  bool sewn_ok = true;
  bool stitches_open = false;  // some stitch left open (not only intersections)
  std::string unsewn;        // what kept it from being sewn
  std::vector<PendingFile> files{
      text_output(dir / "panels.obj", panels_obj(pattern, mesh, offsets)),
      text_output(dir / "panels.svg", panels_svg(pattern, mesh, offsets, a.edge_length_m))};
  if (!a.no_sew) {
    const auto sew_start = std::chrono::steady_clock::now();
    const std::clock_t sew_cpu_start = std::clock();
    std::fprintf(stderr, "weft garment: placing %zu panels around the mannequin\n", pattern.panels.size());
    const BindBody body = load_bind_body(BodyColliderSpec{}, 1.0);
    PlacementOptions placement;
    placement.clearance_m = a.clearance_m;
    const PlacedGarment placed = place_garment(pattern, mesh, body, placement);
    SewingOptions sewing;
    sewing.material = fabric;
    sewing.panel_materials = panel_materials;
    sewing.seam_stiffness_N_m = a.seam_stiffness_N_m;
    sewing.max_time_s = a.sewing_time_s;
    std::fprintf(stderr, "weft garment: sewing %zu stitch%s (%zu vertex pairs, largest gap as placed %.1f mm), at most %g s simulated\n",
                 pattern.stitches.size(), pattern.stitches.size() == 1 ? "" : "es", placed.seam_pairs.size(),
                 1e3 * largest_seam_gap(placed.mesh.positions, placed.seam_pairs), a.sewing_time_s);
    SewnGarment sewn = sew_garment(placed, body, sewing, [](double t, double gap) {
      std::fprintf(stderr, "\rweft garment: sewing: %.2f s simulated, largest seam gap %.2f mm   ", t, 1e3 * gap);
    });
    std::fprintf(stderr, "\n");
    // The garment as garment.obj holds it (positions to 9 digits), and its intersections counted
    // on that: a touching pair can come or go with the last bits of a position.
    for (int v = 0; v < sewn.mesh.num_vertices(); ++v)
      for (int k = 0; k < 3; ++k) sewn.mesh.positions(v, k) = std::strtod(num(sewn.mesh.positions(v, k), kObjDigits).c_str(), nullptr);
    std::fprintf(stderr, "weft garment: counting the intersections of the garment as written\n");
    sewn.intersections = garment_intersections(sewn.mesh, body);
    const double sewing_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - sew_start).count();
    summary["stage"] = "sewn";
    summary["sewing"] = sewing_summary(pattern, placed, sewn, a, sewing_s);
    // Placing, sewing and counting the intersections, in CPU seconds of the whole process.
    summary["sewing"]["cpu_time_s"] = static_cast<double>(std::clock() - sew_cpu_start) / CLOCKS_PER_SEC;
    sewn_ok = sewn.sewn();
    stitches_open = !sewn.open_stitches.empty();
    if (!sewn_ok) unsewn = unsewn_headline(pattern, sewn) + "\n" + unsewn_report(pattern, sewn);
    // An unsewn garment is kept under a name that says so, unless asked for as it is.
    garment_file = sewn_ok || a.allow_open_seams ? "garment.obj" : "garment_unsewn.obj";
    summary["sewing"]["garment_file"] = garment_file;
    files.push_back(text_output(dir / garment_file, garment_obj(pattern, sewn)));
  }
  files.push_back(text_output(dir / "summary.json", summary.dump(2) + "\n"));
  write_files_atomically(std::move(files));
  // The other name, from an earlier run in DIR, would say the opposite of this one.
  if (!garment_file.empty()) {
    std::error_code ec;
    fs::remove(dir / (garment_file == "garment.obj" ? "garment_unsewn.obj" : "garment.obj"), ec);
  }

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
  if (summary.contains("sewing")) {
    const auto& sw = summary["sewing"];
    std::printf("  sewn: %ld vertices, %ld triangles; largest seam gap %.2f mm (placed: %.1f mm) after %.2f s "
                "simulated in %.1f s (CPU %.1f s); intersections: %ld with itself, %ld with the body\n",
                sw["garment"]["vertices"].get<long>(), sw["garment"]["triangles"].get<long>(),
                1e3 * sw["largest_seam_gap_m"].get<double>(), 1e3 * sw["largest_seam_gap_placed_m"].get<double>(),
                sw["simulated_time_s"].get<double>(), sw["time_s"].get<double>(), sw["cpu_time_s"].get<double>(),
                sw["intersections"]["self"].get<long>(), sw["intersections"]["body"].get<long>());
  }
  std::printf("  wrote %s (%spanels.obj, panels.svg, summary.json)\n", dir.string().c_str(),
              garment_file.empty() ? "" : (garment_file + ", ").c_str());
  if (sewn_ok) return kExitOk;
  std::fflush(stdout);  // the report above first, then what did not sew
  if (a.allow_open_seams) {
    std::fprintf(stderr, "weft garment: warning: %sWrote it as it is to %s (--allow-open-seams).\n", unsewn.c_str(),
                 (dir / garment_file).c_str());
    return kExitOk;
  }
  std::fprintf(stderr,
               "weft garment: error: %sWrote %s (the garment as far as it sewed%s), "
               "panels.obj, panels.svg and summary.json (sewing.sewn false); no garment.obj. --allow-open-seams "
               "writes it as garment.obj and exits 0.\n",
               unsewn.c_str(), (dir / garment_file).c_str(),
               stitches_open ? ": the open stitches not welded" : "");
  return kExitNotSewn;
}

RegisterCommand reg{
    {"", "garment", "Mesh a sewing pattern, place its panels around the mannequin and sew them",
     [](CLI::App& sub) {
       sub.footer(
           "Reads a GarmentCode or Garment-Pattern-Generator pattern (docs/patterns.md), meshes every panel\n"
           "with both sides of each stitch given matching boundary vertices, rolls each panel onto a\n"
           "cylinder about the torso, an arm, a leg or the head of the mannequin in its bind pose, and sews:\n"
           "springs pull the stitches shut (gravity off, the body and the cloth itself as colliders), then\n"
           "each stitch's vertex pairs are welded. Writes DIR/garment.obj (the sewn garment, texture\n"
           "coordinates = the flat panels' coordinates in metres, one group per panel; a scene takes it as\n"
           "cloth.mesh.obj), DIR/panels.obj (the panels laid flat at z = 0, one object per panel),\n"
           "DIR/panels.svg (the panels, their meshes and stitches) and DIR/summary.json. --no-sew stops\n"
           "after meshing.\n"
           "A garment is sewn when every stitch's gap is within the weld's 5 mm when sewing stops and the\n"
           "welded garment intersects neither itself nor the body. One that is not is written as\n"
           "DIR/garment_unsewn.obj (its open stitches not welded; no garment.obj), the stitches left open\n"
           "are named on stderr with their gaps and panels, and the exit status is 6 (--allow-open-seams:\n"
           "garment.obj and 0). Exit status 2 for a bad pattern or option (nothing written).");
       auto a = std::make_shared<GarmentArgs>();
       sub.add_option("pattern", a->pattern_file, "Pattern file (JSON)")->required();
       sub.add_option("--out,-o", a->out, "Output folder (created)")->required();
       sub.add_option("--edge-length", a->edge_length_m, "Target mesh edge length (m)")
           ->capture_default_str();
       sub.add_flag("--no-sew", a->no_sew, "Mesh the panels only (no placement, no sewing, no garment.obj)");
       sub.add_option("--clearance", a->clearance_m, "Gap between the body and the placed panels (m)")
           ->capture_default_str();
       sub.add_option("--material", a->material, "Fabric preset during sewing (data/materials). Presets - " + material_preset_listing())
           ->capture_default_str();
       sub.add_option("--panel-material", a->panel_materials,
                      "NAME=PRESET: panel NAME's fabric during sewing, in place of --material (repeatable)")
           ->allow_extra_args(false);
       sub.add_option("--panel-grain", a->panel_grains,
                      "NAME=DEGREES: panel NAME's grain, the warp's angle from the pattern's y axis, "
                      "counter-clockwise (default 0; repeatable)")
           ->allow_extra_args(false);
       sub.add_option("--seam-stiffness", a->seam_stiffness_N_m, "Spring pulling each seam vertex pair (N/m)")
           ->capture_default_str();
       sub.add_option("--sewing-time", a->sewing_time_s, "Most simulated seconds of sewing")
           ->capture_default_str();
       sub.add_flag("--allow-open-seams", a->allow_open_seams,
                    "Write a garment that did not sew (a stitch left open, an intersection left) as garment.obj "
                    "and exit 0, still saying on stderr what is open (default: garment_unsewn.obj, exit 6)");
       return std::function<int()>([a] { return run_garment(*a); });
     },
     60}};

}  // namespace
}  // namespace weft::app
