#include "weft/scene.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "io/json_util.hpp"
#include "system/cloth.hpp"
#include "weft/error.hpp"

namespace weft {

using json_util::Reader;
namespace fs = std::filesystem;

double default_damping_ratio(Method method, double alpha) {
  // Implicit Midpoint (and the alpha family below 1) and the BDF-2 variants are damped by
  // default; backward Euler, forward Euler and the Runge-Kutta references are not.
  if (method == Method::Bdf2) return 0.05;
  if (method == Method::AlphaFamily && alpha < 1.0) return 0.05;
  return 0.0;
}

double Scene::effective_damping_ratio() const {
  return damping_ratio ? *damping_ratio : default_damping_ratio(integrator.method, integrator.alpha);
}

int Scene::steps_per_frame() const {
  return static_cast<int>(std::lround(frame_interval / integrator.dt));
}

void set_method(Scene& scene, const std::string& name, std::optional<double> alpha, const std::string& where) {
  const MethodInfo* info = find_method(name);
  if (!info) throw InputError(where + ": unknown method '" + name + "' (expected one of: " + method_names() + ")");
  scene.method_name = name;
  scene.integrator.method = info->method;
  if (info->fixed_alpha) {
    if (alpha && std::abs(*alpha - *info->fixed_alpha) > 1e-15)
      throw InputError(where + ": method '" + name + "' fixes alpha = " + nlohmann::json(*info->fixed_alpha).dump() +
                       "; use method 'alpha' or 'bdf2-alpha' to choose alpha");
    scene.integrator.alpha = *info->fixed_alpha;
  } else {
    scene.integrator.alpha = alpha.value_or(info->default_alpha);
  }
  if (!(scene.integrator.alpha >= 0.0 && scene.integrator.alpha <= 1.0))
    throw InputError(where + ": alpha must be in [0, 1], got " + nlohmann::json(scene.integrator.alpha).dump());
  if (info->method == Method::Bdf2 && !(scene.integrator.alpha > 0.0))
    throw InputError(where + ": BDF-2 needs alpha > 0, got 0");
}

void validate_timing(const Scene& s, const std::string& where) {
  auto bad = [&](const std::string& what, double v) {
    throw InputError(where + ": " + what + " must be a positive finite number, got " + nlohmann::json(v).dump());
  };
  if (!(s.integrator.dt > 0) || !std::isfinite(s.integrator.dt)) bad("dt", s.integrator.dt);
  if (!(s.duration > 0) || !std::isfinite(s.duration)) bad("duration", s.duration);
  if (!(s.frame_interval > 0) || !std::isfinite(s.frame_interval)) bad("frame_interval", s.frame_interval);
  if (!(s.integrator.cg_tolerance > 0 && s.integrator.cg_tolerance < 1))
    throw InputError(where + ": tolerance must be in (0, 1), got " + nlohmann::json(s.integrator.cg_tolerance).dump());
  if (!(s.integrator.error_tolerance > 0 && s.integrator.error_tolerance < 1))
    throw InputError(where + ": tolerance must be in (0, 1), got " + nlohmann::json(s.integrator.error_tolerance).dump());
  if (s.integrator.method != Method::Rk45) {
    const double ratio = s.frame_interval / s.integrator.dt;
    if (ratio < 1 - 1e-9 || std::abs(ratio - std::round(ratio)) > 1e-6 * ratio)
      throw InputError(where + ": frame_interval " + nlohmann::json(s.frame_interval).dump() +
                       " s is not a whole number of steps of dt " + nlohmann::json(s.integrator.dt).dump() + " s");
  }
  const double frames = s.duration / s.frame_interval;
  if (frames > 1e7) throw InputError(where + ": duration / frame_interval is absurdly large (" + nlohmann::json(frames).dump() + " frames)");
  if (s.duration / s.integrator.dt > 1e9)
    throw InputError(where + ": duration / dt is absurdly large (" + nlohmann::json(s.duration / s.integrator.dt).dump() + " steps)");
  if (s.damping_ratio && !(*s.damping_ratio >= 0 && *s.damping_ratio <= 10))
    throw InputError(where + ": damping ratio must be in [0, 10], got " + nlohmann::json(*s.damping_ratio).dump());
}

namespace {

void parse_cloth(const Reader& r, const std::string& base_dir, ClothSpec& c) {
  r.allow_only({"mesh", "placement", "material", "bending_model", "pins", "initial_velocity"});
  if (r.has("bending_model")) {
    c.bending_model = r.string("bending_model");
    parse_bending_model(c.bending_model, r.where("bending_model"));
  }
  const Reader mesh = r.object("mesh");
  mesh.allow_only({"grid", "obj", "uv_scale"});
  if (mesh.has("grid") == mesh.has("obj")) mesh.fail("grid", "give exactly one of 'grid' or 'obj'");
  if (mesh.has("grid")) {
    const Reader g = mesh.object("grid");
    g.allow_only({"size", "vertices", "pattern"});
    const auto& size = g.raw("size");
    const auto& verts = g.raw("vertices");
    if (!size.is_array() || size.size() != 2 || !size[0].is_number() || !size[1].is_number())
      g.fail("size", "expected [size_u, size_v] in metres, got " + json_util::describe(size));
    if (!verts.is_array() || verts.size() != 2 || !verts[0].is_number_integer() || !verts[1].is_number_integer())
      g.fail("vertices", "expected [count_u, count_v] integers, got " + json_util::describe(verts));
    GridSpec gs{size[0].get<double>(), size[1].get<double>(), verts[0].get<int>(), verts[1].get<int>()};
    if (!(gs.size_u > 0 && gs.size_v > 0 && std::isfinite(gs.size_u) && std::isfinite(gs.size_v) && gs.size_u < 1e4 && gs.size_v < 1e4))
      g.fail("size", "sizes must be positive and below 10 km, got " + json_util::describe(size));
    if (gs.vertices_u < 2 || gs.vertices_v < 2 || static_cast<long>(gs.vertices_u) * gs.vertices_v > 4'000'000)
      g.fail("vertices", "need at least 2 per side and at most 4 million in all, got " + json_util::describe(verts));
    if (g.has("pattern")) {
      const std::string pat = g.string("pattern");
      if (pat == "alternating-diagonals") {
        gs.pattern = GridPattern::kAlternatingDiagonals;
      } else if (pat == "shifted-rows") {
        gs.pattern = GridPattern::kShiftedRows;
      } else {
        g.fail("pattern", "unknown grid pattern '" + pat + "' (expected alternating-diagonals or shifted-rows)");
      }
    }
    c.grid = gs;
  } else {
    const std::string p = mesh.string("obj");
    const fs::path path = fs::path(p).is_absolute() ? fs::path(p) : fs::path(base_dir) / p;
    if (!fs::exists(path)) mesh.fail("obj", "mesh file '" + path.string() + "' does not exist");
    c.obj_path = path.string();
    if (mesh.has("uv_scale")) c.uv_scale = mesh.number_in("uv_scale", 0, 1e6, true);
  }
  if (r.has("placement")) {
    const Reader p = r.object("placement");
    p.allow_only({"rotation_deg", "translation"});
    if (p.has("rotation_deg")) c.rotation_deg = p.vec3("rotation_deg");
    if (p.has("translation")) c.translation = p.vec3("translation");
  }
  if (r.has("initial_velocity")) c.initial_velocity = r.vec3("initial_velocity");
  if (r.has("material")) {
    c.material = parse_material(r.raw("material"), r.where("material"), base_dir);
  }
  if (r.has("pins")) {
    const Reader p = r.object("pins");
    p.allow_only({"vertices", "grid"});
    if (p.has("vertices")) {
      const auto& v = p.raw("vertices");
      if (!v.is_array()) p.fail("vertices", "expected an array of vertex indices, got " + json_util::describe(v));
      for (const auto& e : v) {
        if (!e.is_number_integer() || e.get<long>() < 0)
          p.fail("vertices", "expected non-negative integer vertex indices, got " + json_util::describe(e));
        c.pin_vertices.push_back(e.get<int>());
      }
    }
    if (p.has("grid")) {
      const auto& v = p.raw("grid");
      if (!c.grid) p.fail("grid", "grid pins need a grid mesh");
      if (!v.is_array()) p.fail("grid", "expected an array of [i, j] pairs, got " + json_util::describe(v));
      for (const auto& e : v) {
        if (!e.is_array() || e.size() != 2 || !e[0].is_number_integer() || !e[1].is_number_integer())
          p.fail("grid", "expected [i, j] integer pairs, got " + json_util::describe(e));
        const int i = e[0].get<int>(), j = e[1].get<int>();
        if (i >= c.grid->vertices_u || i < -c.grid->vertices_u || j >= c.grid->vertices_v || j < -c.grid->vertices_v)
          p.fail("grid", "node " + e.dump() + " is outside the " + std::to_string(c.grid->vertices_u) + " x " +
                             std::to_string(c.grid->vertices_v) + " grid");
        c.pin_grid_nodes.emplace_back(i, j);
      }
    }
  }
}

}  // namespace

Scene parse_scene(const nlohmann::json& j, const std::string& file, const std::string& base_dir) {
  Reader r(j, file, "");
  r.allow_only({"weft_scene", "description", "duration", "frame_interval", "gravity", "integrator", "damping",
                "cloth", "colliders", "patterns"});
  Scene s;
  s.file = file;
  const long version = r.integer("weft_scene");
  if (version != kSceneFormatVersion)
    r.fail("weft_scene", "unsupported scene format version " + std::to_string(version) + " (this weft reads version " +
                             std::to_string(kSceneFormatVersion) + ")");
  if (r.has("description")) s.description = r.string("description");
  s.duration = r.number_in("duration", 0, 1e7, true);
  s.frame_interval = r.number_in("frame_interval", 0, 1e7, true);
  if (r.has("gravity")) s.gravity = r.vec3("gravity");

  const Reader in = r.object("integrator");
  in.allow_only({"method", "alpha", "dt", "tolerance", "max_iterations", "preconditioner", "ssor_relaxation",
                 "ssor_precision"});
  std::optional<double> alpha;
  if (in.has("alpha")) alpha = in.number("alpha");
  set_method(s, in.string("method"), alpha, in.where("method"));
  s.integrator.dt = in.number_in("dt", 0, 1e3, true);
  if (in.has("tolerance")) {
    const double tol = in.number_in("tolerance", 0, 1, true);
    (s.integrator.method == Method::Rk45 ? s.integrator.error_tolerance : s.integrator.cg_tolerance) = tol;
  }
  if (in.has("max_iterations")) {
    const long it = in.integer("max_iterations");
    if (it < 1 || it > 1'000'000) in.fail("max_iterations", "must be in [1, 1000000], got " + std::to_string(it));
    s.integrator.cg_max_iterations = static_cast<int>(it);
  }
  if (in.has("preconditioner")) {
    const std::string name = in.string("preconditioner");
    const auto p = parse_preconditioner(name);
    if (!p) in.fail("preconditioner", "unknown preconditioner '" + name + "' (expected auto, block-jacobi, ssor or multigrid)");
    s.integrator.preconditioner = *p;
  }
  if (in.has("ssor_relaxation")) {
    const double w = in.number("ssor_relaxation");
    if (!(w > 0 && w < 2)) in.fail("ssor_relaxation", "must be in (0, 2), got " + nlohmann::json(w).dump());
    s.integrator.ssor_relaxation = w;
  }
  if (in.has("ssor_precision")) {
    const std::string precision = in.string("ssor_precision");
    if (precision != "single" && precision != "double")
      in.fail("ssor_precision", "unknown precision '" + precision + "' (expected single or double)");
    s.integrator.ssor_single_precision = precision == "single";
  }
  if (r.has("damping")) {
    const Reader d = r.object("damping");
    d.allow_only({"ratio"});
    s.damping_ratio = d.number_in("ratio", 0, 10, false);
  }
  parse_cloth(r.object("cloth"), base_dir, s.cloth);
  if (r.has("colliders")) {
    const auto& c = r.raw("colliders");
    if (!c.is_array()) r.fail("colliders", "expected an array, got " + json_util::describe(c));
    for (size_t k = 0; k < c.size(); ++k) {
      const std::string where = file + ": key colliders[" + std::to_string(k) + "]";
      if (!c[k].is_object() || !c[k].contains("type") || !c[k]["type"].is_string())
        throw InputError(where + ": expected an object with a \"type\" string");
      const std::string type = c[k]["type"].get<std::string>();
      if (type != "body") throw InputError(where + ".type: unknown collider type '" + type + "' (expected: body)");
      s.bodies.push_back(parse_body_collider(c[k], where, base_dir));
    }
  }
  if (r.has("patterns")) {
    const auto& p = r.raw("patterns");
    if (!p.is_array() || !p.empty()) r.fail("patterns", "sewing patterns are reserved for a later version; leave the array empty");
  }
  validate_timing(s, file);
  return s;
}

Scene load_scene(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open scene file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    // e.byte gives the position; turn it into a line number.
    std::ifstream again(path);
    std::string text((std::istreambuf_iterator<char>(again)), std::istreambuf_iterator<char>());
    const size_t upto = std::min<size_t>(e.byte, text.size());
    const long line = 1 + std::count(text.begin(), text.begin() + static_cast<long>(upto), '\n');
    std::string msg = e.what();
    const auto pos = msg.find("parse error");
    throw InputError(path + ":" + std::to_string(line) + ": malformed JSON: " + (pos == std::string::npos ? msg : msg.substr(pos)));
  }
  const std::string base = fs::path(path).parent_path().string();
  return parse_scene(j, path, base.empty() ? "." : base);
}

TriMesh build_cloth_mesh(const ClothSpec& spec) {
  TriMesh m = spec.grid ? make_grid(spec.grid->size_u, spec.grid->size_v, spec.grid->vertices_u, spec.grid->vertices_v,
                                    spec.grid->pattern)
                        : load_obj(spec.obj_path, spec.uv_scale);
  const Vec3 r = spec.rotation_deg * (M_PI / 180.0);
  const Mat3 R = (Eigen::AngleAxisd(r.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(r.y(), Vec3::UnitY()) *
                  Eigen::AngleAxisd(r.x(), Vec3::UnitX())).toRotationMatrix();
  for (int i = 0; i < m.num_vertices(); ++i)
    m.positions.row(i) = (R * m.positions.row(i).transpose() + spec.translation).transpose();
  return m;
}

std::vector<int> resolve_pins(const ClothSpec& spec, const TriMesh& mesh) {
  std::vector<int> pins = spec.pin_vertices;
  for (int p : pins)
    if (p >= mesh.num_vertices())
      throw InputError("cloth.pins.vertices: vertex " + std::to_string(p) + " does not exist (the mesh has " +
                       std::to_string(mesh.num_vertices()) + " vertices)");
  for (auto [i, j] : spec.pin_grid_nodes) {
    const int nu = spec.grid->vertices_u, nv = spec.grid->vertices_v;
    pins.push_back(((j + nv) % nv) * nu + (i + nu) % nu);
  }
  return pins;
}

}  // namespace weft
