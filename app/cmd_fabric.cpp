// `weft experiment tensile` and `weft experiment cantilever`: validation of the fabric model
// (docs/method.md 5, docs/fabric-validation.md). Each writes CSV tables, a gnuplot script and,
// when gnuplot is installed, the plot as PNG and SVG.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "command.hpp"
#include "fabric_common.hpp"
#include "weft/atomic_file.hpp"
#include "weft/error.hpp"
#include "weft/fabric_experiments.hpp"

namespace fs = std::filesystem;

namespace weft::app {
namespace {

std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}

std::vector<std::string> split_directions(const std::string& list, const std::vector<std::string>& allowed) {
  std::vector<std::string> out;
  std::stringstream ss(list);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  std::string names;
  for (const auto& a : allowed) names += (names.empty() ? "" : ", ") + a;
  if (out.empty()) throw InputError("--directions '" + list + "': expected a comma-separated list of " + names);
  for (const auto& d : out)
    if (std::find(allowed.begin(), allowed.end(), d) == allowed.end())
      throw InputError("--directions '" + list + "': unknown direction \"" + d + "\" (expected " + names + ")");
  return out;
}

fs::path prepare_out(const std::string& out) {
  if (out.empty()) throw InputError("--out: expected a folder name");
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec || !fs::is_directory(out)) throw InputError("--out '" + out + "': cannot create the folder" + (ec ? ": " + ec.message() : ""));
  return fs::path(out);
}

// Runs gnuplot on `script` in `dir`; the script writes NAME.png.tmp and NAME.svg.tmp, renamed
// into place only when gnuplot succeeded. Returns false (with a warning) when it is missing.
bool run_gnuplot(const fs::path& dir, const std::string& script, const std::string& name) {
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
    std::cerr << "weft: warning: gnuplot not found; wrote the CSV tables and " << script
              << " but no plot (install gnuplot and run `gnuplot " << script << "` in " << dir.string()
              << ")\n";
    return false;
  }
  const std::string cmd = "cd '" + dir.string() + "' && gnuplot '" + script + "'";
  if (std::system(cmd.c_str()) != 0) {
    std::cerr << "weft: warning: gnuplot failed on " << (dir / script).string() << "; no plot written\n";
    return false;
  }
  for (const char* ext : {".png", ".svg"}) {
    std::error_code ec;
    fs::rename(dir / (name + ext + std::string(".tmp")), dir / (name + ext), ec);
    if (ec) {
      std::cerr << "weft: warning: gnuplot did not write " << name << ext << "\n";
      return false;
    }
  }
  return true;
}

// Writes the same plot body to a PNG and an SVG terminal (temporary names, see run_gnuplot).
std::string gnuplot_two_terminals(const std::string& name, const std::string& body,
                                  const std::string& size = "900,640") {
  return "set terminal pngcairo size " + size + " enhanced font 'Sans,10'\nset output '" + name + ".png.tmp'\n" + body +
         "unset multiplot\nset terminal svg size " + size + " enhanced font 'Sans,10'\nset output '" + name + ".svg.tmp'\n" +
         body + "unset multiplot\nunset output\n";
}

// ------------------------------------------------------------------------------ tensile

struct TensileArgs {
  std::string material = "cotton", out, directions = "weft,warp,bias";
  TensileOptions options;
};

int run_tensile(const TensileArgs& a) {
  const Material material = resolve_material(a.material);
  const auto directions = split_directions(a.directions, {"weft", "warp", "bias"});
  const auto& o = a.options;
  if (!(o.length_m > 0) || !(o.width_m > 0) || !std::isfinite(o.length_m) || !std::isfinite(o.width_m))
    throw InputError("--length " + num(o.length_m) + " / --width " + num(o.width_m) + ": expected positive lengths in metres");
  if (o.cells_along < 4) throw InputError("--cells-along " + std::to_string(o.cells_along) + ": expected at least 4");
  if (o.cells_across < 1) throw InputError("--cells-across " + std::to_string(o.cells_across) + ": expected at least 1");
  if (o.increments < 1) throw InputError("--increments " + std::to_string(o.increments) + ": expected at least 1");
  if (!std::isfinite(o.max_strain) || o.max_strain < 0 || o.max_strain > 1)
    throw InputError("--max-strain " + num(o.max_strain) + ": expected a Green strain in [0, 1] (0 = end of the curve)");
  if (a.out.empty()) throw InputError("--out: expected a folder name");

  std::vector<TensileResult> results;
  for (const auto& d : directions) results.push_back(run_tensile_test(material, d, o));
  const fs::path dir = prepare_out(a.out);

  std::ostringstream table, model_curves;
  table << "direction,angle_deg,clamp_strain,gauge_strain,reaction_N,measured_stress_N_m,"
           "expected_stress_N_m,input_curve_stress_N_m,relative_error,newton_iterations,converged\n";
  model_curves << "direction,strain,expected_stress_N_m,input_curve_stress_N_m\n";
  bool all_converged = true;
  for (const auto& r : results) {
    for (const auto& p : r.points) {
      table << r.direction << ',' << num(r.angle_deg) << ',' << num(p.clamp_strain) << ',' << num(p.gauge_strain) << ','
            << num(p.reaction_N) << ',' << num(p.measured_stress) << ',' << num(p.expected_stress) << ','
            << (std::isnan(p.input_curve_stress) ? std::string("") : num(p.input_curve_stress)) << ','
            << num(p.expected_stress != 0 ? p.measured_stress / p.expected_stress - 1 : 0.0) << ','
            << p.newton_iterations << ',' << (p.converged ? 1 : 0) << '\n';
      all_converged = all_converged && p.converged;
    }
    for (int k = 0; k <= 200; ++k) {
      const double e = r.max_strain * k / 200;
      const double curve = r.direction == "weft"   ? material.weft.stress(e)
                           : r.direction == "warp" ? material.warp.stress(e)
                                                   : std::nan("");
      model_curves << r.direction << ',' << num(e) << ',' << num(uniaxial_response(material, r.angle_deg, e)) << ','
                   << (std::isnan(curve) ? std::string("") : num(curve)) << '\n';
    }
  }
  // One data block per direction (gnuplot index) for the plot.
  std::ostringstream dat;
  for (const auto& r : results) {
    dat << "# " << r.direction << ": strain expected input_curve | measured points follow in the next block\n";
    for (int k = 0; k <= 200; ++k) {
      const double e = r.max_strain * k / 200;
      const double curve = r.direction == "weft"   ? material.weft.stress(e)
                           : r.direction == "warp" ? material.warp.stress(e)
                                                   : uniaxial_response(material, r.angle_deg, e);
      dat << num(100 * e) << ' ' << num(uniaxial_response(material, r.angle_deg, e)) << ' ' << num(curve) << '\n';
    }
    dat << "\n\n";
    for (const auto& p : r.points) dat << num(100 * p.gauge_strain) << ' ' << num(p.measured_stress) << '\n';
    dat << "\n\n";
  }
  std::ostringstream plot;
  plot << "plot \\\n";
  const char* colours[] = {"#1f77b4", "#d62728", "#2ca02c"};
  for (size_t i = 0; i < results.size(); ++i) {
    const auto& r = results[i];
    const std::string c = colours[i % 3];
    const std::string curve_title = r.direction == "bias" ? "bias: model uniaxial response at 45 deg"
                                                          : r.direction + ": input curve";
    plot << "  'tensile.dat' index " << 2 * i << " using 1:3 with lines lw 2 lc rgb '" << c << "' title '"
         << curve_title << "', \\\n";
    if (r.direction != "bias" && material.poisson_ratio != 0.0)
      plot << "  'tensile.dat' index " << 2 * i << " using 1:2 with lines dt 2 lc rgb '" << c << "' title '"
           << r.direction << ": uniaxial response with Poisson coupling', \\\n";
    plot << "  'tensile.dat' index " << 2 * i + 1 << " using 1:2 with points pt 7 ps 1.1 lc rgb '" << c
         << "' title '" << r.direction << ": simulated strip'" << (i + 1 < results.size() ? ", \\\n" : "\n");
  }
  std::ostringstream body;
  body << "set multiplot layout 1,2 title 'weft tensile test: " << material.name
       << " (sliding clamps, quasi-static equilibria)' noenhanced\n"
          "set xlabel 'Green strain (%)'\nset ylabel 'stress S (N/m)'\nset key top left Left reverse font ',9'\n"
          "set grid\nset datafile commentschars '#'\n"
       << plot.str() << "set logscale y\nset key bottom right Right noreverse font ',9'\n"
       << "set ylabel 'stress S (N/m), logarithmic'\n" << plot.str() << "unset logscale y\n";
  write_files_atomically({
            text_file(dir / "tensile.csv", table.str()),
            text_file(dir / "tensile_model.csv", model_curves.str()),
            text_file(dir / "tensile.dat", dat.str()),
            text_file(dir / "tensile.gp", gnuplot_two_terminals("tensile", body.str(), "1400,620")),
  });
  const bool plotted = run_gnuplot(dir, "tensile.gp", "tensile");

  std::printf("tensile test, material %s (Poisson %.3g): strip %.3g x %.3g m, %d x %d cells, %d increments\n",
              material.name.c_str(), material.poisson_ratio, o.length_m, o.width_m, o.cells_along, o.cells_across,
              o.increments);
  for (const auto& r : results)
    std::printf("  %-4s (%2.0f deg): Green strain to %.4g; largest deviation from the model's uniaxial response "
                "%.3g%%%s\n",
                r.direction.c_str(), r.angle_deg, r.max_strain, 100 * r.max_relative_error,
                std::isnan(r.max_relative_error_input_curve)
                    ? ""
                    : (", from the input curve " + num(100 * r.max_relative_error_input_curve) + "%").c_str());
  if (!all_converged) std::printf("  warning: some equilibria did not reach the force tolerance (see tensile.csv)\n");
  std::printf("  wrote %s (tensile.csv, tensile_model.csv, tensile.gp%s)\n", dir.string().c_str(),
              plotted ? ", tensile.png, tensile.svg" : "");
  return kExitOk;
}

// ------------------------------------------------------------------------------ cantilever

struct CantileverArgs {
  std::string material = "cotton", out, directions = "weft,warp";
  CantileverOptions options;
};

int run_cantilever(const CantileverArgs& a) {
  const Material material = resolve_material(a.material);
  const auto directions = split_directions(a.directions, {"weft", "warp"});
  const auto& o = a.options;
  if (!(o.width_m > 0) || !std::isfinite(o.width_m)) throw InputError("--width " + num(o.width_m) + ": expected a positive width in metres");
  if (o.cells_along < 4) throw InputError("--cells-along " + std::to_string(o.cells_along) + ": expected at least 4");
  if (o.cells_across < 1) throw InputError("--cells-across " + std::to_string(o.cells_across) + ": expected at least 1");
  if (o.clamp_cells < 1) throw InputError("--clamp-cells " + std::to_string(o.clamp_cells) + ": expected at least 1");
  if (o.sweep_points < 2) throw InputError("--sweep-points " + std::to_string(o.sweep_points) + ": expected at least 2");
  if (a.out.empty()) throw InputError("--out: expected a folder name");

  std::vector<CantileverResult> results;
  for (const auto& d : directions) results.push_back(run_cantilever_test(material, d, o));
  const fs::path dir = prepare_out(a.out);

  std::ostringstream summary, sweep, dat, body;
  summary << "direction,bending_rigidity_Nm,weight_N_m2,analytic_bending_length_m,overhang_at_target_m,"
             "bending_length_m,relative_error,effective_rigidity_ratio\n";
  sweep << "direction,overhang_m,overhang_over_analytic_c,chord_angle_deg,elastica_angle_deg,converged\n";
  bool all_converged = true;
  for (const auto& r : results) {
    summary << r.direction << ',' << num(r.rigidity_Nm) << ',' << num(r.weight_N_m2) << ','
            << num(r.analytic_bending_length_m) << ',' << num(r.overhang_m) << ',' << num(r.bending_length_m) << ','
            << num(r.relative_error) << ',' << num(r.effective_rigidity_ratio) << '\n';
    for (const auto& p : r.sweep) {
      sweep << r.direction << ',' << num(p.overhang_m) << ',' << num(p.overhang_m / r.analytic_bending_length_m) << ','
            << num(p.chord_angle_deg) << ',' << num(p.elastica_angle_deg) << ',' << (p.converged ? 1 : 0) << '\n';
      all_converged = all_converged && p.converged;
    }
  }
  double ratio_max = 0;
  for (const auto& r : results)
    for (const auto& p : r.sweep) ratio_max = std::max(ratio_max, p.overhang_m / r.analytic_bending_length_m);
  // The table also reaches far enough for the elastica drawn at the effective rigidity.
  double table_max = ratio_max;
  if (!results.empty() && results[0].bending_length_m > 0)
    table_max = ratio_max * std::max(1.0, results[0].analytic_bending_length_m / results[0].bending_length_m);
  dat << "# overhang / analytic bending length, exact elastica chord angle (deg)\n";
  for (int k = 0; k <= 160; ++k) {
    const double ratio = table_max * k / 160;
    dat << num(ratio) << ' ' << num(ratio > 0 ? elastica_chord_angle_deg(ratio) : 0.0) << '\n';
  }
  dat << "\n\n";
  for (const auto& r : results) {
    dat << "# " << r.direction << ": overhang / c, simulated chord angle (deg)\n";
    for (const auto& p : r.sweep) dat << num(p.overhang_m / r.analytic_bending_length_m) << ' ' << num(p.chord_angle_deg) << '\n';
    dat << "\n\n";
  }
  body << "set title 'weft cantilever test (ASTM D1388): " << material.name << "' noenhanced\n"
       << "set xlabel 'overhang L / analytic bending length (B/(w g))^{1/3}  (-)'\n"
       << "set ylabel 'chord angle clamp edge to tip (deg below horizontal)'\nset key bottom right font ',9'\nset grid\n"
       << "set xrange [0:" << num(1.05 * ratio_max) << "]\n"
       << "set arrow from graph 0, first " << o.target_angle_deg << " to graph 1, first " << o.target_angle_deg
       << " nohead dt 3 lc rgb '#777777'\n"
       << "plot 'cantilever.dat' index 0 using 1:2 with lines lw 2 lc rgb 'black' title 'exact elastica', \\\n";
  if (!results.empty() && std::isfinite(results[0].bending_length_m) &&
      std::abs(results[0].relative_error) > 0.01) {
    // The elastica of a strip whose rigidity is the effective one: if the simulated points lie on
    // it, the large-deflection shape is right and only the rigidity is off.
    const double scale = results[0].bending_length_m / results[0].analytic_bending_length_m;
    char title[160];
    std::snprintf(title, sizeof title, "exact elastica with B x %.3g (effective rigidity of the %s strip)",
                  results[0].effective_rigidity_ratio, results[0].direction.c_str());
    body << "  'cantilever.dat' index 0 using ($1*" << num(scale) << "):2 with lines dt 2 lw 1.5 lc rgb '#555555' title '"
         << title << "', \\\n";
  }
  const char* colours[] = {"#1f77b4", "#d62728"};
  for (size_t i = 0; i < results.size(); ++i) {
    char title[200];
    std::snprintf(title, sizeof title, "%s strip: c = %.2f mm (analytic %.2f mm, %+.2f%%)", results[i].direction.c_str(),
                  1e3 * results[i].bending_length_m, 1e3 * results[i].analytic_bending_length_m,
                  100 * results[i].relative_error);
    body << "  'cantilever.dat' index " << i + 1 << " using 1:2 with points pt " << (i % 2 ? "6 ps 1.8" : "7 ps 1.1")
         << " lc rgb '" << colours[i % 2]
         << "' title '" << title << "'" << (i + 1 < results.size() ? ", \\\n" : "\n");
  }
  write_files_atomically({
            text_file(dir / "cantilever.csv", summary.str()),
            text_file(dir / "cantilever_sweep.csv", sweep.str()),
            text_file(dir / "cantilever.dat", dat.str()),
            text_file(dir / "cantilever.gp", gnuplot_two_terminals("cantilever", body.str())),
  });
  const bool plotted = run_gnuplot(dir, "cantilever.gp", "cantilever");

  std::printf("cantilever test (ASTM D1388, chord at %.4g deg), material %s: strip width %.3g m, %d cells along the "
              "overhang, %d across\n",
              o.target_angle_deg, material.name.c_str(), o.width_m, o.cells_along, o.cells_across);
  for (const auto& r : results)
    std::printf("  %s strip: B = %.4g N m, w g = %.4g N/m^2: bending length %.5g m (overhang %.5g m), analytic %.5g m, "
                "error %+.3f%% (the strip behaves as if B were %.3g times the material's)\n",
                r.direction.c_str(), r.rigidity_Nm, r.weight_N_m2, r.bending_length_m, r.overhang_m,
                r.analytic_bending_length_m, 100 * r.relative_error, r.effective_rigidity_ratio);
  if (!all_converged) std::printf("  warning: some equilibria did not reach the force tolerance (see cantilever_sweep.csv)\n");
  std::printf("  wrote %s (cantilever.csv, cantilever_sweep.csv, cantilever.gp%s)\n", dir.string().c_str(),
              plotted ? ", cantilever.png, cantilever.svg" : "");
  return kExitOk;
}

const RegisterCommand register_tensile{CommandSpec{
    "experiment", "tensile",
    "Quasi-static tensile test of a strip along weft, warp and bias (45 deg): measured stress against "
    "the material's curves (CSV + gnuplot PNG/SVG).",
    [](CLI::App& sub) {
      auto a = std::make_shared<TensileArgs>();
      sub.add_option("--material", a->material, "Preset name or material file (default cotton). Presets - " + material_preset_listing());
      sub.add_option("--out", a->out, "Output folder")->required();
      sub.add_option("--directions", a->directions, "Comma-separated: weft, warp, bias (default all)");
      sub.add_option("--length", a->options.length_m, "Strip length (m, default 0.2)");
      sub.add_option("--width", a->options.width_m, "Strip width (m, default 0.05)");
      sub.add_option("--cells-along", a->options.cells_along, "Cells along the strip (default 40)");
      sub.add_option("--cells-across", a->options.cells_across, "Cells across the strip (default 10)");
      sub.add_option("--increments", a->options.increments, "Clamp displacement increments (default 16)");
      sub.add_option("--max-strain", a->options.max_strain,
                     "Largest Green strain (default 0: the end of the direction's curve)");
      return [a] { return run_tensile(*a); };
    },
    70}};

const RegisterCommand register_cantilever{CommandSpec{
    "experiment", "cantilever",
    "Cantilever bending test (ASTM D1388): overhang at which the strip's chord reaches 41.5 deg, "
    "bending length against (B / (w g))^(1/3) (CSV + gnuplot PNG/SVG).",
    [](CLI::App& sub) {
      auto a = std::make_shared<CantileverArgs>();
      sub.add_option("--material", a->material, "Preset name or material file (default cotton). Presets - " + material_preset_listing());
      sub.add_option("--out", a->out, "Output folder")->required();
      sub.add_option("--directions", a->directions, "Comma-separated strip axes: weft, warp (default both)");
      sub.add_option("--width", a->options.width_m, "Strip width (m, default 0.025)");
      sub.add_option("--cells-along", a->options.cells_along, "Cells along the overhang (default 20)");
      sub.add_option("--cells-across", a->options.cells_across, "Cells across the strip with --mesh grid (default 6; equilateral meshes follow the width)");
      sub.add_option("--clamp-cells", a->options.clamp_cells, "Cells held flat behind the clamp edge (default 1)");
      sub.add_option("--bending-model", a->options.bending_model, "Bending element: hinge (default) or plate")
          ->check(CLI::IsMember({"hinge", "plate"}));
      sub.add_option("--mesh", a->options.mesh,
                     "Strip triangulation: equilateral (default; rows follow from the width) or grid")
          ->check(CLI::IsMember({"equilateral", "grid"}));
      sub.add_option("--sweep-points", a->options.sweep_points, "Overhangs swept for the plot (default 8)");
      return [a] { return run_cantilever(*a); };
    },
    71}};

}  // namespace
}  // namespace weft::app
