#include "weft/scene.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>

#include "weft/exports.hpp"
#include "weft/input_file.hpp"
#include "io/json_util.hpp"
#include "io/obj_file.hpp"
#include "system/cloth.hpp"
#include "weft/error.hpp"

namespace weft {

using json_util::Reader;
namespace fs = std::filesystem;

double default_damping_ratio(Method method, double alpha) {
  // Implicit Midpoint (and the alpha family below 1) and the BDF-2 variants are damped by
  // default; backward Euler, forward Euler and the Runge-Kutta references are not.
  if (method == Method::kBdf2) return 0.05;
  if (method == Method::kAlphaFamily && alpha < 1.0) return 0.05;
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
  scene.integrator.guard = info->guard;
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
  if (info->method == Method::kBdf2 && !(scene.integrator.alpha > 0.0))
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
  if (s.integrator.method != Method::kRk45) {
    const double ratio = s.frame_interval / s.integrator.dt;
    if (ratio < 1 - 1e-9 || std::abs(ratio - std::round(ratio)) > 1e-6 * ratio)
      throw InputError(where + ": frame_interval " + nlohmann::json(s.frame_interval).dump() +
                       " s is not a whole number of steps of dt " + nlohmann::json(s.integrator.dt).dump() + " s");
  }
  const double frames = s.duration / s.frame_interval;
  if (frames > 1e7) throw InputError(where + ": duration / frame_interval is absurdly large (" + nlohmann::json(frames).dump() + " frames)");
  // Frames are written at whole intervals, and the run ends at the last one: a duration between
  // two would be cut to the earlier (nothing at all below one interval).
  if (frames < 1 - 1e-9 || std::abs(frames - std::round(frames)) > 1e-6 * frames) {
    const auto num = [](double v) {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%.9g", v);
      return std::string(buf);
    };
    const double below = std::floor(frames + 1e-6) * s.frame_interval, above = std::ceil(frames - 1e-6) * s.frame_interval;
    throw InputError(where + ": duration " + num(s.duration) + " s is not a whole number of frame_interval " +
                     num(s.frame_interval) + " s (" + num(frames) + " frames); frames are written at whole intervals, so choose " +
                     (below > 0 ? num(below) + " or " : std::string()) + num(above) + " s");
  }
  if (s.duration / s.integrator.dt > 1e9)
    throw InputError(where + ": duration / dt is absurdly large (" + nlohmann::json(s.duration / s.integrator.dt).dump() + " steps)");
  if (s.damping_ratio && !(*s.damping_ratio >= 0 && *s.damping_ratio <= 10))
    throw InputError(where + ": damping ratio must be in [0, 10], got " + nlohmann::json(*s.damping_ratio).dump());
}

void apply_overrides(Scene& scene, const SceneOverrides& o, const std::string& where) {
  if (!o.method.empty() || o.alpha) set_method(scene, o.method.empty() ? scene.method_name : o.method, o.alpha, where);
  if (o.dt) scene.integrator.dt = *o.dt;
  if (o.duration) scene.duration = *o.duration;
  if (o.tolerance)
    (scene.integrator.method == Method::kRk45 ? scene.integrator.error_tolerance : scene.integrator.cg_tolerance) = *o.tolerance;
  if (o.damping_ratio) scene.damping_ratio = *o.damping_ratio;
  if (o.newton) {
    if (!(*o.newton >= 0 && *o.newton <= 100 && *o.newton == std::floor(*o.newton)))
      throw InputError(where + ": --newton " + nlohmann::json(*o.newton).dump() + ": expected an integer from 0 to 100");
    scene.integrator.newton_iterations = static_cast<int>(*o.newton);
  }
  if (!o.preconditioner.empty()) {
    const auto p = parse_preconditioner(o.preconditioner);
    if (!p)
      throw InputError(where + ": --preconditioner '" + o.preconditioner +
                       "': expected auto, block-jacobi, ssor or multigrid");
    scene.integrator.preconditioner = *p;
  }
  validate_timing(scene, where);
}

namespace {

constexpr double kMaxThickness_m = 0.1;  ///< contact thickness: beyond, not a cloth's
constexpr double kMaxFriction = 10;

// The "vertices" and "grid" keys of a pins or clamp object.
void parse_node_list(const Reader& p, const ClothSpec& c, std::vector<int>& vertices,
                     std::vector<std::pair<int, int>>& grid_nodes, const char* what) {
  if (p.has("vertices")) {
    const auto& v = p.raw("vertices");
    if (!v.is_array()) p.fail("vertices", "expected an array of vertex indices, got " + json_util::describe(v));
    for (const auto& e : v) {
      const std::optional<long> i = json_util::integer_value(e);
      if (!i || *i < 0 || *i > std::numeric_limits<int>::max())
        p.fail("vertices", "expected vertex indices, integers in [0, " +
                               std::to_string(std::numeric_limits<int>::max()) + "], got " + json_util::describe(e));
      vertices.push_back(static_cast<int>(*i));
    }
  }
  if (p.has("grid")) {
    const auto& v = p.raw("grid");
    if (!c.grid) p.fail("grid", std::string("grid ") + what + " need a grid mesh");
    if (!v.is_array()) p.fail("grid", "expected an array of [i, j] pairs, got " + json_util::describe(v));
    for (const auto& e : v) {
      const std::optional<long> ni = e.is_array() && e.size() == 2 ? json_util::integer_value(e[0]) : std::nullopt;
      const std::optional<long> nj = e.is_array() && e.size() == 2 ? json_util::integer_value(e[1]) : std::nullopt;
      if (!ni || !nj) p.fail("grid", "expected [i, j] integer pairs, got " + json_util::describe(e));
      const long i = *ni, j = *nj;
      if (i >= c.grid->vertices_u || i < -c.grid->vertices_u || j >= c.grid->vertices_v || j < -c.grid->vertices_v)
        p.fail("grid", "node " + e.dump() + " is outside the " + std::to_string(c.grid->vertices_u) + " x " +
                           std::to_string(c.grid->vertices_v) + " grid");
      grid_nodes.emplace_back(static_cast<int>(i), static_cast<int>(j));
    }
  }
}

RigidMotion parse_motion(const Reader& m);

// The contact handling's tunables (`contacts`, docs/scene-format.md): each within the range
// its guarantees hold in.
void parse_contacts(const Reader& r, ContactSettings& c) {
  r.allow_only({"hold_margin", "held_rest_speed", "self_passes", "self_zone_rounds", "self_repulsion_time",
                "self_hold_reach", "self_hold_reach_speed", "fail_safe_energy_factor"});
  if (r.has("hold_margin")) c.hold_margin = r.number_in("hold_margin", 1, 3, false);
  if (r.has("held_rest_speed")) c.held_rest_speed = r.number_in("held_rest_speed", 0, 10, false);
  if (r.has("self_passes")) c.self_passes = static_cast<int>(r.integer_in("self_passes", 0, 100));
  if (r.has("self_zone_rounds")) c.self_zone_rounds = static_cast<int>(r.integer_in("self_zone_rounds", 0, 100));
  if (r.has("self_repulsion_time")) c.self_repulsion_time = r.number_in("self_repulsion_time", 0, 10, true);
  if (r.has("self_hold_reach")) c.self_hold_reach = r.number_in("self_hold_reach", 1, 3, false);
  if (r.has("self_hold_reach_speed")) c.self_hold_reach_speed = r.number_in("self_hold_reach_speed", 0, 10, false);
  if (r.has("fail_safe_energy_factor"))
    c.fail_safe_energy_factor = r.number_in("fail_safe_energy_factor", 0, 1e6, true);
}

void parse_cloth(const Reader& r, const std::string& base_dir, ClothSpec& c) {
  r.allow_only({"mesh", "placement", "material", "bending_model", "pins", "clamps", "initial_velocity", "thickness",
                "friction", "self_collision"});
  if (r.has("thickness")) c.thickness = r.number_in("thickness", 0, kMaxThickness_m, true);
  if (r.has("friction")) c.friction = r.number_in("friction", 0, kMaxFriction, false);
  if (r.has("self_collision")) c.self_collision = r.boolean("self_collision");
  if (r.has("bending_model")) {
    c.bending_model = r.string("bending_model");
    parse_bending_model(c.bending_model, r.where("bending_model"));
  }
  const Reader mesh = r.object("mesh");
  mesh.allow_only({"grid", "obj", "uv_scale", "pattern"});
  if (int(mesh.has("grid")) + int(mesh.has("obj")) + int(mesh.has("pattern")) != 1)
    mesh.fail("grid", "give exactly one of 'grid', 'obj' or 'pattern'");
  if (mesh.has("pattern")) {
    const Reader g = mesh.object("pattern");
    g.allow_only({"file", "edge_length", "clearance", "panels", "seam_stiffness", "sewing_time", "sewing_step_limit",
                 "allow_open_seams"});
    GarmentSpec gs;
    const std::string p = g.string("file");
    const fs::path path = fs::path(p).is_absolute() ? fs::path(p) : fs::path(base_dir) / p;
    if (!fs::exists(path)) g.fail("file", "pattern file '" + path.string() + "' does not exist");
    gs.pattern_file = path.lexically_normal().string();
    if (g.has("edge_length")) gs.edge_length_m = g.number_in("edge_length", 0.002, 0.5, false);
    if (g.has("clearance")) gs.clearance_m = g.number_in("clearance", 0.002, 0.2, false);
    if (g.has("seam_stiffness")) gs.seam_stiffness_N_m = g.number_in("seam_stiffness", 0, 1e7, true);
    if (g.has("sewing_time")) gs.sewing_time_s = g.number_in("sewing_time", 0, 60, true);
    if (g.has("sewing_step_limit")) gs.sewing_step_limit_m = g.number_in("sewing_step_limit", 0, 1, false);
    if (g.has("allow_open_seams")) gs.allow_open_seams = g.boolean("allow_open_seams");
    if (g.has("panels")) {
      // The names are checked against the pattern's panels where the pattern is read, when the
      // garment is sewn (sim/model_data.cpp): reading a scene reads no pattern.
      const Reader panels = g.object("panels");
      for (const auto& [name, value] : panels.json().items()) {
        const Reader o = panels.object(name.c_str());
        o.allow_only({"part", "angle_deg", "shift", "material", "grain_deg"});
        PanelPlacementOverride po;
        if (o.has("part")) po.part = parse_body_part(o.string("part"), o.where("part"));
        if (o.has("angle_deg")) po.angle_deg = o.number_in("angle_deg", -360, 360, false);
        if (o.has("shift")) po.shift_m = o.number_in("shift", -2, 2, false);
        gs.panels[name] = po;
        if (o.has("material")) gs.panel_materials[name] = parse_material(o.raw("material"), o.where("material"), base_dir);
        if (o.has("grain_deg")) gs.panel_grain_deg[name] = o.number_in("grain_deg", -360, 360, false);
      }
    }
    c.garment = gs;
  } else if (mesh.has("grid")) {
    const Reader g = mesh.object("grid");
    g.allow_only({"size", "vertices", "pattern"});
    const auto& size = g.raw("size");
    const auto& verts = g.raw("vertices");
    if (!size.is_array() || size.size() != 2 || !size[0].is_number() || !size[1].is_number())
      g.fail("size", "expected [size_u, size_v] in metres, got " + json_util::describe(size));
    const std::optional<long> count_u = verts.is_array() && verts.size() == 2 ? json_util::integer_value(verts[0]) : std::nullopt;
    const std::optional<long> count_v = verts.is_array() && verts.size() == 2 ? json_util::integer_value(verts[1]) : std::nullopt;
    if (!count_u || !count_v)
      g.fail("vertices", "expected [count_u, count_v] integers, got " + json_util::describe(verts));
    const double size_u = size[0].get<double>(), size_v = size[1].get<double>();
    if (!(size_u > 0 && size_v > 0 && size_u <= kMaxLength_m && size_v <= kMaxLength_m))
      g.fail("size", "sizes must be positive and at most " + nlohmann::json(kMaxLength_m).dump() + " m, got " +
                         json_util::describe(size));
    // Checked before narrowing to int: [4294967307, 11] must not wrap round to 11 x 11.
    if (*count_u < 2 || *count_v < 2 || *count_u > kMaxGridVertices || *count_v > kMaxGridVertices ||
        *count_u * *count_v > kMaxGridVertices)
      g.fail("vertices", "need at least 2 per side and at most " + std::to_string(kMaxGridVertices) +
                             " in all, got " + json_util::describe(verts));
    GridSpec gs{size_u, size_v, static_cast<int>(*count_u), static_cast<int>(*count_v)};
    check_memory_estimate(static_cast<long>(gs.vertices_u) * gs.vertices_v, g.where("vertices") + ": a " + std::to_string(gs.vertices_u) + " x " +
                              std::to_string(gs.vertices_v) + " grid");
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
    if (p.has("rotation_deg")) c.rotation_deg = p.vec3_within("rotation_deg", kMaxRotation_deg, "degrees");
    if (p.has("translation")) c.translation = p.vec3_within("translation", kMaxLength_m, "m");
  }
  if (r.has("initial_velocity")) c.initial_velocity = r.vec3_within("initial_velocity", kMaxSpeed_m_s, "m/s");
  if (r.has("material")) {
    c.material = parse_material(r.raw("material"), r.where("material"), base_dir);
  }
  if (r.has("pins")) {
    const Reader p = r.object("pins");
    p.allow_only({"vertices", "grid"});
    parse_node_list(p, c, c.pin_vertices, c.pin_grid_nodes, "pins");
  }
  if (r.has("clamps")) {
    const auto& list = r.raw("clamps");
    if (!list.is_array()) r.fail("clamps", "expected an array of clamps, got " + json_util::describe(list));
    for (size_t k = 0; k < list.size(); ++k) {
      const Reader e(list[k], r.file(), r.path() + ".clamps[" + std::to_string(k) + "]");
      if (!list[k].is_object())
        r.fail("clamps", "entry " + std::to_string(k) + ": expected an object, got " + json_util::describe(list[k]));
      e.allow_only({"vertices", "grid", "motion"});
      ClampSpec clamp;
      parse_node_list(e, c, clamp.vertices, clamp.grid_nodes, "clamps");
      if (clamp.vertices.empty() && clamp.grid_nodes.empty())
        e.fail(e.has("grid") ? "grid" : "vertices", "a clamp needs at least one vertex");
      if (e.has("motion")) clamp.motion = parse_motion(e.object("motion"));
      c.clamps.push_back(std::move(clamp));
    }
  }
}

RigidMotion parse_motion(const Reader& m) {
  RigidMotion motion;
  m.allow_only({"linear_velocity", "angular_velocity_deg", "centre", "keyframes"});
  const bool velocity = m.has("linear_velocity") || m.has("angular_velocity_deg") || m.has("centre");
  if (velocity && m.has("keyframes"))
    m.fail("keyframes", "give either keyframes or linear_velocity/angular_velocity_deg/centre, not both");
  if (velocity) {
    motion.kind = RigidMotion::Kind::kVelocity;
    if (m.has("linear_velocity")) motion.linear_velocity = m.vec3_within("linear_velocity", kMaxSpeed_m_s, "m/s");
    if (m.has("angular_velocity_deg"))
      motion.angular_velocity = m.vec3_within("angular_velocity_deg", 360 * 1000.0, "deg/s") * (M_PI / 180.0);
    if (m.has("centre")) motion.centre = m.vec3_within("centre", kMaxLength_m, "m");
  } else if (m.has("keyframes")) {
    motion.kind = RigidMotion::Kind::kKeyframes;
    const auto& keys = m.raw("keyframes");
    if (!keys.is_array() || keys.empty()) m.fail("keyframes", "expected a non-empty array of {time, translation, rotation_deg}");
    for (size_t k = 0; k < keys.size(); ++k) {
      const Reader key(keys[k], m.file(), m.path() + ".keyframes[" + std::to_string(k) + "]");
      if (!keys[k].is_object()) m.fail("keyframes", "entry " + std::to_string(k) + " is not an object");
      key.allow_only({"time", "translation", "rotation_deg"});
      RigidMotion::Key kf;
      kf.time = key.number_in("time", 0, 1e7, false);
      if (!motion.keys.empty() && !(kf.time > motion.keys.back().time))
        key.fail("time", "keyframe times must increase, got " + nlohmann::json(kf.time).dump() + " after " +
                             nlohmann::json(motion.keys.back().time).dump());
      if (key.has("translation")) kf.translation = key.vec3_within("translation", kMaxLength_m, "m");
      if (key.has("rotation_deg")) kf.rotation_deg = key.vec3_within("rotation_deg", kMaxRotation_deg, "degrees");
      motion.keys.push_back(kf);
    }
  }
  return motion;
}

ColliderSpec parse_collider(const nlohmann::json& j, const std::string& file, const std::string& path,
                            const std::string& base_dir, std::vector<BodyColliderSpec>& bodies) {
  const Reader r(j, file, path);
  const std::string type = r.string("type");
  ColliderSpec c;
  c.name = path + " (" + type + ")";
  const std::initializer_list<const char*> common = {"type", "thickness", "friction", "motion"};
  auto allow = [&](std::initializer_list<const char*> own) {
    std::vector<const char*> all(common);
    all.insert(all.end(), own.begin(), own.end());
    for (const auto& item : j.items()) {
      const std::string& key = item.key();
      if (std::find_if(all.begin(), all.end(), [&key](const char* a) { return key == a; }) == all.end()) {
        std::string expected;
        for (const char* a : all) expected += (expected.empty() ? "" : ", ") + std::string(a);
        throw InputError(file + ": key " + path + "." + key + ": unknown key for a " + type + " collider (expected " +
                         expected + ")");
      }
    }
  };
  if (r.has("thickness")) c.thickness = r.number_in("thickness", 0, kMaxThickness_m, true);
  if (r.has("friction")) c.friction = r.number_in("friction", 0, kMaxFriction, false);
  if (r.has("motion") && type != "body") c.motion = parse_motion(r.object("motion"));  // a body's is its BVH file
  auto positive_length = [&](const char* key) { return r.number_in(key, 0, kMaxLength_m, true); };
  if (type == "plane") {
    allow({"point", "normal"});
    c.shape = ColliderShape::kPlane;
    if (r.has("point")) c.point = r.vec3_within("point", kMaxLength_m, "m");
    if (r.has("normal")) {
      c.normal = r.vec3_within("normal", 1e6, "");
      if (!(c.normal.norm() > 1e-12)) r.fail("normal", "must not be zero");
      c.normal.normalize();
    }
  } else if (type == "sphere") {
    allow({"centre", "radius"});
    c.shape = ColliderShape::kSphere;
    c.centre = r.vec3_within("centre", kMaxLength_m, "m");
    c.radius = positive_length("radius");
  } else if (type == "capsule") {
    allow({"ends", "radius"});
    c.shape = ColliderShape::kCapsule;
    const auto& ends = r.raw("ends");
    if (!ends.is_array() || ends.size() != 2) r.fail("ends", "expected [[x, y, z], [x, y, z]], got " + json_util::describe(ends));
    const nlohmann::json pair = {{"a", ends[0]}, {"b", ends[1]}};
    const Reader e(pair, file, path + ".ends");
    c.end_a = e.vec3_within("a", kMaxLength_m, "m");
    c.end_b = e.vec3_within("b", kMaxLength_m, "m");
    c.radius = positive_length("radius");
  } else if (type == "box") {
    allow({"centre", "half_extents", "rotation_deg", "edge_radius"});
    c.shape = ColliderShape::kBox;
    c.centre = r.vec3_within("centre", kMaxLength_m, "m");
    c.half_extents = r.vec3_within("half_extents", kMaxLength_m, "m");
    if (!(c.half_extents.minCoeff() > 0)) r.fail("half_extents", "must all be positive");
    if (r.has("edge_radius")) {
      c.edge_radius = r.number_in("edge_radius", 0, kMaxLength_m, false);
      if (!(c.edge_radius < c.half_extents.minCoeff()))
        r.fail("edge_radius", "expected a radius below the smallest half extent (" +
                                  nlohmann::json(c.half_extents.minCoeff()).dump() + " m), got " +
                                  nlohmann::json(c.edge_radius).dump());
    }
    if (r.has("rotation_deg")) c.rotation_deg = r.vec3_within("rotation_deg", kMaxRotation_deg, "degrees");
  } else if (type == "mesh") {
    allow({"obj", "scale", "rotation_deg", "translation", "closed"});
    c.shape = ColliderShape::kMesh;
    const fs::path obj = r.string("obj");
    if (obj.empty()) r.fail("obj", "expected an OBJ file name, got \"\"");
    c.obj_path = (obj.is_absolute() ? obj : fs::path(base_dir) / obj).lexically_normal().string();
    std::error_code ec;
    if (!fs::is_regular_file(c.obj_path, ec)) r.fail("obj", "no such file: " + c.obj_path);
    if (r.has("scale")) c.scale = r.number_in("scale", 0, 1e6, true);
    if (r.has("rotation_deg")) c.rotation_deg = r.vec3_within("rotation_deg", kMaxRotation_deg, "degrees");
    if (r.has("translation")) c.translation = r.vec3_within("translation", kMaxLength_m, "m");
    if (r.has("closed")) c.closed = r.boolean("closed");
  } else if (type == "body") {
    c.shape = ColliderShape::kBody;
    nlohmann::json body = j;
    body.erase("thickness");
    body.erase("friction");
    bodies.push_back(parse_body_collider(body, file + ": key " + path, base_dir));
    c.body = static_cast<int>(bodies.size()) - 1;
  } else {
    r.fail("type", "unknown collider type '" + type + "' (expected plane, sphere, capsule, box, mesh or body)");
  }
  return c;
}

}  // namespace

Scene parse_scene(const nlohmann::json& j, const std::string& file, const std::string& base_dir) {
  Reader r(j, file, "");
  r.allow_only({"weft_scene", "description", "duration", "frame_interval", "gravity", "integrator", "damping",
                "cloth", "contacts", "colliders", "patterns", "output"});
  Scene s;
  s.file = file;
  const long version = r.integer("weft_scene");
  if (version != kSceneFormatVersion)
    r.fail("weft_scene", "unsupported scene format version " + std::to_string(version) + " (this weft reads version " +
                             std::to_string(kSceneFormatVersion) + ")");
  if (r.has("description")) s.description = r.string("description");
  s.duration = r.number_in("duration", 0, 1e7, true);
  s.frame_interval = r.number_in("frame_interval", 0, 1e7, true);
  if (r.has("gravity")) s.gravity = r.vec3_within("gravity", kMaxGravity_m_s2, "m/s^2");

  const Reader in = r.object("integrator");
  in.allow_only({"method", "alpha", "dt", "tolerance", "max_iterations", "preconditioner", "ssor_relaxation",
                 "ssor_precision", "newton_iterations", "newton_tolerance", "automatic_newton", "contact_solve",
                 "max_step_halvings", "runaway_energy_factor"});
  std::optional<double> alpha;
  if (in.has("alpha")) alpha = in.number("alpha");
  set_method(s, in.string("method"), alpha, in.where("method"));
  s.integrator.dt = in.number_in("dt", 0, 1e3, true);
  if (in.has("tolerance")) {
    const double tol = in.number_in("tolerance", 0, 1, true);
    (s.integrator.method == Method::kRk45 ? s.integrator.error_tolerance : s.integrator.cg_tolerance) = tol;
  }
  if (in.has("max_iterations")) {
    s.integrator.cg_max_iterations = static_cast<int>(in.integer_in("max_iterations", 1, 1'000'000));
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
  if (in.has("newton_iterations")) {
    s.integrator.newton_iterations = static_cast<int>(in.integer_in("newton_iterations", 0, 100));
  }
  if (in.has("newton_tolerance")) s.integrator.newton_tolerance = in.number_in("newton_tolerance", 0, 1, true);
  if (in.has("automatic_newton")) s.integrator.backward_euler_newton = in.boolean("automatic_newton");
  if (in.has("contact_solve")) {
    const std::string name = in.string("contact_solve");
    if (name != "active-set" && name != "bounds")
      in.fail("contact_solve", "unknown contact solve '" + name + "' (expected active-set or bounds)");
    s.integrator.contact_solve = name == "bounds" ? ContactSolve::kBounds : ContactSolve::kActiveSet;
  }
  if (in.has("max_step_halvings"))
    s.integrator.max_step_halvings = static_cast<int>(in.integer_in("max_step_halvings", 0, 10));
  if (in.has("runaway_energy_factor"))
    s.integrator.runaway_energy_factor = in.number_in("runaway_energy_factor", 1, 1e9, true);
  if (r.has("damping")) {
    const Reader d = r.object("damping");
    d.allow_only({"ratio"});
    s.damping_ratio = d.number_in("ratio", 0, 10, false);
  }
  parse_cloth(r.object("cloth"), base_dir, s.cloth);
  if (r.has("contacts")) parse_contacts(r.object("contacts"), s.contacts);
  if (r.has("colliders")) {
    const auto& c = r.raw("colliders");
    if (!c.is_array()) r.fail("colliders", "expected an array, got " + json_util::describe(c));
    for (size_t k = 0; k < c.size(); ++k) {
      const std::string where = file + ": key colliders[" + std::to_string(k) + "]";
      if (!c[k].is_object() || !c[k].contains("type") || !c[k]["type"].is_string())
        throw InputError(where + ": expected an object with a \"type\" string");
      s.colliders.push_back(parse_collider(c[k], file, "colliders[" + std::to_string(k) + "]", base_dir, s.bodies));
    }
  }
  if (r.has("patterns")) {
    const auto& p = r.raw("patterns");
    if (!p.is_array() || !p.empty())
      r.fail("patterns", "a garment's sewing pattern goes in cloth.mesh.pattern (docs/scene-format.md); this key, "
                         "kept for older scenes, must be an empty array");
  }
  if (s.cloth.garment) {
    if (s.bodies.empty())
      throw InputError(file + ": key cloth.mesh.pattern: a garment is placed and sewn on the body; the scene has no "
                              "collider of type body");
    const BodyColliderSpec& b = s.bodies.front();
    if (!(b.bind_pose_hold + b.blend > 0))
      throw InputError(file + ": key cloth.mesh.pattern: the garment is sewn on the body in its bind pose, so the "
                              "body must start in it: give its collider a bind_pose_hold or blend above 0");
    if (r.object("cloth").has("placement"))
      throw InputError(file + ": key cloth.placement: a garment is placed on the body; leave placement out (move "
                              "panels with cloth.mesh.pattern.panels)");
  }
  if (r.has("output")) {
    const Reader o = r.object("output");
    o.allow_only({"formats"});
    const auto& f = o.raw("formats");
    if (!f.is_array()) o.fail("formats", "expected an array of format names (" + std::string(kOutputFormatNames) +
                                             "), got " + json_util::describe(f));
    std::vector<std::string> names;
    for (const auto& name : f) {
      if (!name.is_string()) o.fail("formats", "expected format names (" + std::string(kOutputFormatNames) +
                                                   "), got " + json_util::describe(name));
      names.push_back(name.get<std::string>());
    }
    s.output_formats = checked_output_formats(names, o.where("formats"));
  }
  validate_timing(s, file);
  return s;
}

Scene parse_scene_text(std::string_view text, const std::string& file, const std::string& base_dir) {
  return parse_scene(json_util::parse_json(text, file), file, base_dir);
}

Scene load_scene(const std::string& path) {
  const std::string base = fs::path(path).parent_path().string();
  return parse_scene_text(read_input_file(path, "scene file"), path, base.empty() ? "." : base);
}

double estimated_run_bytes(long vertices) { return kRunBytesPerVertex * static_cast<double>(vertices); }

void check_memory_estimate(long vertices, const std::string& what) {
  const double need = estimated_run_bytes(vertices);
  const double pages = static_cast<double>(::sysconf(_SC_PHYS_PAGES)), page = static_cast<double>(::sysconf(_SC_PAGE_SIZE));
  const double physical = pages > 0 && page > 0 ? pages * page : 0.0;
  auto gb = [](double bytes) {
    char text[32];
    std::snprintf(text, sizeof text, "%.1f GB", bytes / 1e9);
    return std::string(text);
  };
  const std::string size = " (" + std::to_string(vertices) + " vertices) needs about " + gb(need) + " to simulate";
  if (need > kMaxRunBytes)
    throw InputError(what + size + ", more than the " + gb(kMaxRunBytes) + " weft allows a run");
  if (physical > 0 && need > physical)
    throw InputError(what + size + ", more than this machine's " + gb(physical) + " of memory");
}

TriMesh build_cloth_mesh(const ClothSpec& spec) {
  TriMesh m = spec.mesh ? *spec.mesh
            : spec.grid ? make_grid(spec.grid->size_u, spec.grid->size_v, spec.grid->vertices_u, spec.grid->vertices_v,
                                    spec.grid->pattern)
                        : load_obj(spec.obj_path, spec.uv_scale);
  if (!spec.grid && !spec.mesh)
    check_memory_estimate(m.num_vertices(), spec.obj_path + ": the mesh");
  const Vec3 r = spec.rotation_deg * (M_PI / 180.0);
  const Mat3 R = (Eigen::AngleAxisd(r.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(r.y(), Vec3::UnitY()) *
                  Eigen::AngleAxisd(r.x(), Vec3::UnitX())).toRotationMatrix();
  for (int i = 0; i < m.num_vertices(); ++i)
    m.positions.row(i) = (R * m.positions.row(i).transpose() + spec.translation).transpose();
  return m;
}

std::vector<std::vector<int>> resolve_clamps(const ClothSpec& spec, const TriMesh& mesh, const std::vector<int>& pins) {
  std::vector<char> taken(static_cast<size_t>(mesh.num_vertices()), 0);
  for (int p : pins) taken[p] = 1;
  std::vector<std::vector<int>> clamps;
  for (size_t k = 0; k < spec.clamps.size(); ++k) {
    const ClampSpec& c = spec.clamps[k];
    const std::string key = "cloth.clamps[" + std::to_string(k) + "]";
    std::vector<int> nodes = c.vertices;
    for (int v : nodes)
      if (v >= mesh.num_vertices())
        throw InputError(key + ".vertices: vertex " + std::to_string(v) + " does not exist (the mesh has " +
                         std::to_string(mesh.num_vertices()) + " vertices)");
    for (auto [i, j] : c.grid_nodes) {
      const int nu = spec.grid->vertices_u, nv = spec.grid->vertices_v;
      nodes.push_back(((j + nv) % nv) * nu + (i + nu) % nu);
    }
    std::sort(nodes.begin(), nodes.end());
    nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
    for (int v : nodes) {
      if (taken[v])
        throw InputError(key + ": vertex " + std::to_string(v) + " is already pinned or in another clamp");
      taken[v] = 1;
    }
    clamps.push_back(std::move(nodes));
  }
  return clamps;
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
