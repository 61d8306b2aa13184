// `weft experiment drape`: the Cusick drape test (weft/experiments/drape.hpp,
// docs/fabric-validation.md): drape coefficient, nodes and pictures of a draped specimen.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "command.hpp"
#include "experiment_common.hpp"
#include "weft/experiments/drape.hpp"
#include "fabric_common.hpp"
#include "weft/render/picture.hpp"
#include "weft/atomic_file.hpp"
#include "weft/gray_image.hpp"

namespace fs = std::filesystem;

namespace weft::app {
namespace {

struct DrapeArgs {
  std::string material = "cotton", out;
  DrapeOptions options;
  bool self_collision = false, no_pictures = false, quiet = false;
};

std::string fmt(const char* format, double v) {
  char b[64];
  std::snprintf(b, sizeof b, format, v);
  return b;
}

// The draped specimen seen from above (the shadow the meter measures) and from the side.
std::vector<RgbImage> pictures(const DrapeResult& r, const std::string& caption) {
  std::vector<double> xyz;
  render::Bounds box;
  for (int i = 0; i < r.mesh.num_vertices(); ++i) {
    const Vec3 p = r.mesh.positions.row(i).transpose();
    xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
    box.add(p);
  }
  std::vector<render::PictureMesh> meshes{{&xyz, &r.mesh.triangles, render::Surface::kCloth, {}, {}}};
  render::PictureOptions top;
  top.width = top.height = 720;
  top.scene_bounds = box;
  top.ground_y = box.lo.y() - 0.02;
  const double half = 0.5 * std::max(box.hi.x() - box.lo.x(), box.hi.z() - box.lo.z()) * 1.12;
  top.camera.fov_deg = 30;
  top.camera.target = Vec3(0, box.lo.y(), 0);
  top.camera.eye = Vec3(0, box.hi.y() + half / std::tan(15 * M_PI / 180), 0);
  top.camera.up = Vec3(0, 0, -1);  // x to the right, -z up the picture: the plan as drawn in the docs
  top.caption = caption;
  render::PictureOptions side = top;
  side.width = 960;
  side.camera = render::frame_camera(box, side.width, side.height, 30, 35, 25);
  return {render::render_picture(meshes, top), render::render_picture(meshes, side)};
}

int run_drape(const DrapeArgs& a) {
  const Material material = resolve_material(a.material);
  check_output_folder(a.out);
  DrapeOptions o = a.options;
  o.self_collision = a.self_collision;
  Progress progress("drape " + material.name, !a.quiet);
  const DrapeResult r = run_drape_test(material, o, [&](double f) { progress.update(f); });
  progress.finish();
  if (r.status != "ok") {
    std::fprintf(stderr, "weft: error: drape: the simulation became unstable at t = %.3g s (non-finite positions); "
                 "try a smaller --dt\n", r.simulated_time_s);
    return kExitUnstable;
  }

  nlohmann::json j;
  j["material"] = {{"name", material.name}, {"source", material.source}};
  j["options"] = {{"specimen_diameter_m", o.specimen_diameter_m}, {"support_diameter_m", o.support_diameter_m},
                  {"edge_length_m", o.edge_length_m},           {"grain_deg", o.grain_deg},
                  {"method", o.method}, {"dt_s", o.dt_s},                             {"max_time_s", o.max_time_s},
                  {"rest_speed_m_s", o.rest_speed_m_s},         {"rest_time_s", o.rest_time_s},
                  {"imperfection_m", o.imperfection_m},         {"seed", o.imperfection_seed},
                  {"bending_model", o.bending_model},           {"self_collision", o.self_collision},
                  {"pixel_m", o.pixel_m},                       {"node_prominence", o.node_prominence}};
  j["drape_coefficient"] = r.drape_coefficient;
  j["nodes"] = r.nodes;
  j["node_angles_deg"] = r.node_angles_deg;
  j["shadow_area_m2"] = r.shadow_area_m2;
  j["specimen_area_m2"] = r.specimen_area_m2;
  j["support_area_m2"] = r.support_area_m2;
  j["edge_radius_min_m"] = r.min_radius_m;
  j["edge_radius_max_m"] = r.max_radius_m;
  j["at_rest"] = r.at_rest;
  j["simulated_time_s"] = r.simulated_time_s;
  j["final_max_speed_m_s"] = r.max_speed_m_s;
  j["vertices"] = r.vertices;
  j["triangles"] = r.triangles;
  j["pinned_vertices"] = r.pinned;
  j["steps"] = r.steps;
  j["wall_seconds"] = r.wall_seconds;

  std::ostringstream md;
  md << "# Drape test: " << material.name << "\n\n"
     << "Cusick drape meter: a " << fmt("%.3g", 100 * o.specimen_diameter_m) << " cm specimen clamped on a "
     << fmt("%.3g", 100 * o.support_diameter_m) << " cm disk, draped under gravity (" << o.method << ", dt "
     << fmt("%.3g", 1000 * o.dt_s) << " ms), grain at " << fmt("%.3g", o.grain_deg)
     << " deg.\n\n| quantity | value |\n|---|---|\n"
     << "| drape coefficient | " << fmt("%.3f", r.drape_coefficient) << " |\n"
     << "| nodes (folds) | " << r.nodes << " |\n"
     << "| shadow area | " << fmt("%.2f", 1e4 * r.shadow_area_m2) << " cm^2 (specimen " << fmt("%.2f", 1e4 * r.specimen_area_m2)
     << ", disk " << fmt("%.2f", 1e4 * r.support_area_m2) << ") |\n"
     << "| edge radius | " << fmt("%.1f", 1000 * r.min_radius_m) << " to " << fmt("%.1f", 1000 * r.max_radius_m)
     << " mm |\n"
     << "| at rest | " << (r.at_rest ? "yes" : "no (stopped at the time limit)") << " after "
     << fmt("%.2f", r.simulated_time_s) << " s, largest speed " << fmt("%.2g", 1000 * r.max_speed_m_s) << " mm/s |\n"
     << "| mesh | " << r.vertices << " vertices, " << r.triangles << " triangles (edge " << fmt("%.3g", 1000 * o.edge_length_m)
     << " mm), " << r.pinned << " clamped, cloth-cloth contact " << (o.self_collision ? "on" : "off") << " |\n"
     << "| steps, wall time | " << r.steps << ", " << fmt("%.1f", r.wall_seconds) << " s |\n";
  if (!a.no_pictures) md << "\n![top view](top.png)\n![side view](side.png)\n";

  std::ostringstream edge;
  edge << "angle_deg,radius_m\n";
  for (size_t k = 0; k < r.edge_radius_m.size(); ++k)
    edge << fmt("%.6g", r.edge_angle_deg[k]) << ',' << fmt("%.9g", r.edge_radius_m[k]) << '\n';

  std::vector<PendingFile> files{text_file(fs::path(a.out) / "results.json", j.dump(2) + "\n"),
                                 text_file(fs::path(a.out) / "results.md", md.str()),
                                 text_file(fs::path(a.out) / "edge.csv", edge.str())};
  std::vector<RgbImage> images;
  if (!a.no_pictures) {
    images = pictures(r, material.name + "   drape " + fmt("%.3f", r.drape_coefficient) + ", " + std::to_string(r.nodes) + " nodes");
    files.push_back({fs::path(a.out) / "top.png", [&](const fs::path& t) { write_png(images[0], t); }});
    files.push_back({fs::path(a.out) / "side.png", [&](const fs::path& t) { write_png(images[1], t); }});
  }
  fs::create_directories(a.out);
  write_files_atomically(files);
  std::printf("drape test, %s: drape coefficient %.3f, %d nodes, %s after %.2f s (%ld steps, %.1f s wall)\n",
              material.name.c_str(), r.drape_coefficient, r.nodes, r.at_rest ? "at rest" : "NOT at rest",
              r.simulated_time_s, r.steps, r.wall_seconds);
  std::printf("results in %s (results.md, results.json, edge.csv%s)\n", a.out.c_str(),
              a.no_pictures ? "" : ", top.png, side.png");
  return kExitOk;
}

const RegisterCommand register_drape{CommandSpec{
    "experiment", "drape",
    "The Cusick drape test (BS 5058 / ISO 9073-9): a 30 cm disk of fabric clamped on an 18 cm disk drapes "
    "under gravity; reports the drape coefficient, the number of nodes (folds) and pictures",
    [](CLI::App& sub) {
      auto a = std::make_shared<DrapeArgs>();
      sub.add_option("--material,-m", a->material, "Preset name or material file (default: cotton). Presets - " + material_preset_listing());
      sub.add_option("--out,-o", a->out, "Output folder (created)")->required();
      sub.add_option("--edge-length", a->options.edge_length_m, "Mesh edge length (m; default 0.01)");
      sub.add_option("--grain-deg", a->options.grain_deg,
                     "Angle from the x axis to the weft, counter-clockwise from above (degrees; default 0)");
      sub.add_option("--specimen-diameter", a->options.specimen_diameter_m, "Specimen diameter (m; default 0.30)");
      sub.add_option("--support-diameter", a->options.support_diameter_m, "Support disk diameter (m; default 0.18)");
      sub.add_option("--method", a->options.method,
                     "Integrator, as a scene's integrator.method (default backward-euler: it damps the fast modes "
                     "and reaches rest sooner)");
      sub.add_option("--dt", a->options.dt_s, "Time step (s; default 0.005)");
      sub.add_option("--max-time", a->options.max_time_s, "Longest simulated time (s; default 8)");
      sub.add_option("--rest-speed", a->options.rest_speed_m_s,
                     "At rest when every vertex is slower than this (m/s; default 0.002) ...");
      sub.add_option("--rest-time", a->options.rest_time_s, "... for this long (s; default 0.3)");
      sub.add_option("--imperfection", a->options.imperfection_m,
                     "Start with the overhang lifted or lowered by a smooth random wave of at most this height "
                     "(m; default 0: flat)");
      sub.add_option("--seed", a->options.imperfection_seed, "Seed of the imperfection's wave (default 1)");
      sub.add_option("--bending-model", a->options.bending_model, "hinge (default) or plate");
      sub.add_option("--pixel", a->options.pixel_m, "Raster pixel of the shadow area (m; default 0.0005)");
      sub.add_flag("--self-collision", a->self_collision,
                   "Turn cloth-cloth contact on (off by default: the folds do not touch, and on meshes finer than "
                   "about 1 cm the 3 mm contact thickness crumples them)");
      sub.add_flag("--no-pictures", a->no_pictures, "Do not render top.png and side.png");
      sub.add_flag("--quiet,-q", a->quiet, "No progress bar");
      sub.footer(
          "The vertices on the support disk are held (the meter clamps the specimen between two disks); the\n"
          "rest falls from flat until every vertex is slower than --rest-speed for --rest-time, or --max-time.\n"
          "Drape coefficient = (shadow area - disk area) / (specimen area - disk area); the shadow is the union\n"
          "of the triangles' vertical projections, rasterised. Nodes are the maxima of the edge's distance from\n"
          "the axis that stand out by 20% of its range (and 2 mm).\n"
          "Writes DIR/results.{md,json}, DIR/edge.csv (the edge's radius against angle), DIR/top.png, DIR/side.png.");
      return std::function<int()>([a] { return run_drape(*a); });
    },
    66}};

}  // namespace
}  // namespace weft::app
