#include "weft/garment/sewing.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <stdexcept>

#include "collision/cloth_contacts.hpp"
#include "collision/colliders.hpp"
#include "integrate/integrator.hpp"
#include "system/cloth.hpp"
#include "weft/error.hpp"
#include "weft/scene.hpp"

namespace weft {
namespace {

Points as_points(const VecX& x) {
  Points p(x.size() / 3, 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i) p.row(i) = x.segment<3>(3 * i).transpose();
  return p;
}

}  // namespace

FrameIntersections garment_intersections(const TriMesh& mesh, const BindBody& body) {
  std::vector<double> cloth(3 * mesh.num_vertices()), skin(3 * body.positions.rows());
  for (int i = 0; i < mesh.num_vertices(); ++i)
    for (int k = 0; k < 3; ++k) cloth[3 * i + k] = mesh.positions(i, k);
  for (Eigen::Index i = 0; i < body.positions.rows(); ++i)
    for (int k = 0; k < 3; ++k) skin[3 * i + k] = body.positions(i, k);
  std::vector<std::array<int, 3>> body_triangles(body.triangles.rows());
  for (Eigen::Index f = 0; f < body.triangles.rows(); ++f)
    body_triangles[f] = {body.triangles(f, 0), body.triangles(f, 1), body.triangles(f, 2)};
  FrameChecker checker;
  return checker.check({cloth.data(), &mesh.triangles}, {{skin.data(), &body_triangles}});
}

EdgeUse edge_use(const std::vector<std::array<int, 3>>& triangles) {
  std::map<std::pair<int, int>, std::array<int, 2>> uses;  // (min, max) -> {forward, backward}
  for (const auto& t : triangles)
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      auto& u = uses[std::minmax(a, b)];
      ++u[a < b ? 0 : 1];
    }
  EdgeUse out;
  for (const auto& [edge, u] : uses) {
    const int n = u[0] + u[1];
    if (n == 1) ++out.boundary;
    else if (n == 2) {
      ++out.interior;
      if (u[0] != 1) ++out.inconsistent;
    } else {
      ++out.non_manifold;
    }
  }
  return out;
}

SewnGarment weld_seams(const PlacedGarment& placed, const Points& positions, const std::vector<int>& open_stitches) {
  const TriMesh& in = placed.mesh;
  const int n = in.num_vertices();
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (size_t q = 0; q < placed.seam_pairs.size(); ++q) {
    if (q < placed.seam_stitch.size() &&
        std::find(open_stitches.begin(), open_stitches.end(), placed.seam_stitch[q]) != open_stitches.end())
      continue;
    const auto& p = placed.seam_pairs[q];
    const int a = find(p[0]), b = find(p[1]);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  SewnGarment out;
  out.welded_vertex.assign(n, -1);
  std::vector<int> index_of_root(n, -1);
  int count = 0;
  for (int i = 0; i < n; ++i) {
    const int r = find(i);
    if (index_of_root[r] < 0) index_of_root[r] = count++;
    out.welded_vertex[i] = index_of_root[r];
  }
  TriMesh& m = out.mesh;
  m.positions = Points::Zero(count, 3);
  m.pattern.assign(count, Vec2::Zero());
  std::vector<int> members(count, 0);
  for (int i = n - 1; i >= 0; --i) {  // the lowest old index gives the vertex's pattern place
    const int w = out.welded_vertex[i];
    m.positions.row(w) += positions.row(i);
    m.pattern[w] = in.pattern[i];
    ++members[w];
  }
  for (int w = 0; w < count; ++w) m.positions.row(w) /= members[w];
  bool several_places = false;
  for (size_t t = 0; t < in.triangles.size(); ++t) {
    const auto& tri = in.triangles[t];
    const std::array<int, 3> w{out.welded_vertex[tri[0]], out.welded_vertex[tri[1]], out.welded_vertex[tri[2]]};
    if (w[0] == w[1] || w[1] == w[2] || w[0] == w[2]) continue;  // collapsed where a dart closes
    m.triangles.push_back(w);
    m.corner_pattern.push_back({in.corner(t, 0), in.corner(t, 1), in.corner(t, 2)});
    out.panel_of_triangle.push_back(placed.panel_of_triangle[t]);
    for (int k = 0; k < 3; ++k) several_places = several_places || m.corner_pattern.back()[k] != m.pattern[w[k]];
  }
  if (!several_places) m.corner_pattern.clear();
  return out;
}

namespace {
/// Backward Euler at the sewing's step, quasi-static: the velocities are reset after every
/// interval, so neither the halving of solves that overshoot nor the automatic Newton
/// iterations (each weighed against a motion's energy) apply. The energy guard is off, so the
/// integrator needs no energy scale.
IntegratorSettings sewing_integrator(const SewingOptions& options) {
  const MethodInfo& method = *find_method("backward-euler");
  IntegratorSettings settings;
  settings.method = method.method;
  settings.alpha = method.fixed_alpha.value_or(method.default_alpha);
  settings.guard = method.guard;
  settings.dt = options.dt_s;
  settings.halve_overshooting_solves = false;
  settings.backward_euler_newton = false;
  settings.max_step_motion = options.max_step_motion_m;
  return settings;
}

/// Throws std::invalid_argument for options the sewing cannot take (they come from code).
void check_options(const SewingOptions& o) {
  auto positive = [](double v) { return v > 0 && std::isfinite(v); };
  if (!positive(o.dt_s) || !positive(o.interval_s) || !positive(o.max_time_s))
    throw std::invalid_argument("sew_garment: the step, the interval and the sewing time must be positive");
  if (!(o.max_step_motion_m > 0)) throw std::invalid_argument("sew_garment: the step's motion limit must be positive");
  const double steps = o.interval_s / o.dt_s;
  if (steps < 1 - 1e-9 || std::abs(steps - std::round(steps)) > 1e-6 * steps)
    throw std::invalid_argument("sew_garment: the interval must be a whole number of steps");
}
}  // namespace

/// The time over which a body placed with its legs apart brings them back together (s).
constexpr double kLegsTogether_s = 0.2;

SewnGarment sew_garment(const PlacedGarment& placed, const BindBody& body, const SewingOptions& options,
                        const std::function<void(double, double)>& progress) {
  check_options(options);
  // The cloth: the placed mesh, each panel in its fabric, its seam pairs zero-length springs;
  // no gravity, no pins, no adaptive damping.
  std::vector<Seam> seams;
  for (const auto& p : placed.seam_pairs) seams.push_back({p[0], p[1], options.seam_stiffness_N_m});
  const TriangleMaterials materials = options.panel_materials.empty()
                                          ? TriangleMaterials{{options.material}, {}}
                                          : TriangleMaterials{options.panel_materials, placed.panel_of_triangle};
  const ClothModel cloth = build_cloth_model(placed.mesh, materials, Vec3::Zero(), {}, BendingModel::kHinge, seams);
  ClothSystem system(cloth, DampingSettings{});
  Integrator integrator(system, sewing_integrator(options));
  // The body standing still in its bind pose, a closed mesh collider without friction (the
  // seams slide over it while they close).
  ColliderSpec spec;
  spec.shape = ColliderShape::kBody;
  spec.name = "body";
  spec.thickness = options.body_thickness_m;
  spec.friction = 0.0;
  std::vector<std::unique_ptr<Collider>> colliders;
  // Trousers were placed on the body with its legs apart: it stays so while the seams come
  // together, then brings its legs back over kLegsTogether_s (smoothstep) while the cloth
  // follows and sewing goes on.
  const bool apart = placed.legs_apart && body.legs_apart_positions.rows() == body.positions.rows();
  double together_from = std::numeric_limits<double>::infinity();
  colliders.push_back(make_mesh_collider(
      spec, body.triangles,
      [&body, apart, &together_from](double t, Points& out) {
        if (!apart) {
          out = body.positions;
          return;
        }
        const double a = std::clamp((t - together_from) / kLegsTogether_s, 0.0, 1.0), s = a * a * (3 - 2 * a);
        out = (1 - s) * body.legs_apart_positions + s * body.positions;
      },
      true));
  // The contacts as a scene's cloth has them: its default thickness and friction between layers,
  // the two sides of a seam one point.
  const ClothSpec defaults;
  const std::vector<char> held(cloth.num_vertices(), 0);  // nothing pinned
  const ClothContacts contacts =
      add_cloth_contacts(integrator, colliders, cloth.mass, held, cloth.mesh.triangles, cloth.initial_positions(),
                         {options.self_collision, defaults.thickness, defaults.friction},
                         seam_groups(cloth.num_vertices(), seams));
  State state;
  state.x = cloth.initial_positions();
  state.v = VecX::Zero(state.x.size());
  StepStatistics statistics;

  SewnGarment out;
  out.largest_gap_placed_m = largest_seam_gap(placed.mesh.positions, placed.seam_pairs);
  double gap = out.largest_gap_placed_m;
  const int intervals = static_cast<int>(std::ceil(options.max_time_s / options.interval_s - 1e-9));
  // Stops when the gap is small, or when it has not shrunk by a tenth over the last 0.2 s (or
  // the time is up). With the legs apart, the legs come back together first: once the gap
  // shrinks by less than a tenth in an interval (the seams have come together), or when sewing
  // would stop; the time of bringing them back is added to the time allowed, and the rule of
  // 0.2 s counts from when they are back.
  std::vector<double> history;
  const size_t window = static_cast<size_t>(std::max(1.0, std::round(0.2 / options.interval_s)));
  const int together_intervals = apart ? static_cast<int>(std::ceil(kLegsTogether_s / options.interval_s - 1e-9)) : 0;
  int back_at = apart ? -1 : 0;  // the interval at whose start the legs are back (-1: not yet set)
  for (int k = 1;; ++k) {
    const bool stop = gap <= options.gap_m || k > intervals + together_intervals ||
                      (history.size() > window && gap > 0.9 * history[history.size() - 1 - window]);
    const bool slowing = history.size() >= 2 && gap > 0.9 * history[history.size() - 2];
    if (back_at < 0 && (stop || slowing)) {
      together_from = (k - 1) * options.interval_s;
      back_at = k + together_intervals;
    }
    if (stop && k >= back_at) break;
    if (k == back_at) history.clear();
    integrator.advance(state, k * options.interval_s, statistics);
    state.v.setZero();  // quasi-static: the seams close without swinging
    gap = largest_seam_gap(as_points(state.x), placed.seam_pairs);
    if (k >= back_at) history.push_back(gap);
    out.sewing_time_s = k * options.interval_s;
    if (progress) progress(out.sewing_time_s, gap);
  }
  out.steps = static_cast<int>(statistics.steps);
  out.largest_gap_m = gap;
  out.converged = gap <= options.gap_m;
  out.sewn_positions = as_points(state.x);
  out.weld_gap_m = options.weld_gap_m;
  for (size_t q = 0; q < placed.seam_pairs.size() && q < placed.seam_stitch.size(); ++q) {
    const size_t s = static_cast<size_t>(placed.seam_stitch[q]);
    if (s >= out.stitch_gap_m.size()) out.stitch_gap_m.resize(s + 1, 0.0);
    const auto& pr = placed.seam_pairs[q];
    out.stitch_gap_m[s] = std::max(out.stitch_gap_m[s], (out.sewn_positions.row(pr[0]) - out.sewn_positions.row(pr[1])).norm());
  }
  for (size_t s = 0; s < out.stitch_gap_m.size(); ++s)
    if (out.stitch_gap_m[s] > options.weld_gap_m) out.open_stitches.push_back(static_cast<int>(s));
  SewnGarment welded = weld_seams(placed, out.sewn_positions, out.open_stitches);
  out.mesh = std::move(welded.mesh);
  out.panel_of_triangle = std::move(welded.panel_of_triangle);
  out.welded_vertex = std::move(welded.welded_vertex);
  out.intersections = garment_intersections(out.mesh, body);
  return out;
}

namespace {
std::string mm(double m) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f mm", 1e3 * m);
  return b;
}
size_t body_intersections(const SewnGarment& sewn) {
  size_t n = 0;
  for (const auto& b : sewn.intersections.cloth_body) n += b.count;
  return n;
}
}  // namespace

std::string unsewn_report(const Pattern& pattern, const SewnGarment& sewn) {
  std::string out;
  auto side = [&](const StitchSide& s) {
    const std::string panel = s.panel >= 0 && static_cast<size_t>(s.panel) < pattern.panels.size()
                                  ? pattern.panels[static_cast<size_t>(s.panel)].name
                                  : "#" + std::to_string(s.panel);
    return "panel '" + panel + "' edge " + std::to_string(s.edge);
  };
  for (int s : sewn.open_stitches) {
    const size_t i = static_cast<size_t>(s);
    out += "  stitch " + std::to_string(s);
    if (i < pattern.stitches.size()) out += " (" + side(pattern.stitches[i].a) + " to " + side(pattern.stitches[i].b) + ")";
    out += ": gap " + mm(i < sewn.stitch_gap_m.size() ? sewn.stitch_gap_m[i] : 0.0) + "\n";
  }
  const size_t self = sewn.intersections.cloth_self.count, body = body_intersections(sewn);
  if (self + body > 0)
    out += "  intersecting triangle pairs left in the garment: " + std::to_string(self) + " with itself, " +
           std::to_string(body) + " with the body\n";
  return out;
}

std::string unsewn_headline(const Pattern& pattern, const SewnGarment& sewn) {
  std::string out = pattern.name + " did not sew:";
  std::string sep = " ";
  if (!sewn.open_stitches.empty()) {
    char b[64];
    std::snprintf(b, sizeof b, "%.2f", sewn.sewing_time_s);
    out += sep + std::to_string(sewn.open_stitches.size()) + " of " + std::to_string(pattern.stitches.size()) +
           " stitches left open (their gap above the weld's " + mm(sewn.weld_gap_m) + " after " + b +
           " s of sewing)";
    sep = "; ";
  }
  const size_t self = sewn.intersections.cloth_self.count, body = body_intersections(sewn);
  if (self + body > 0)
    out += sep + "the garment " + (sewn.open_stitches.empty() ? "" : "as far as it sewed ") + "intersects itself in " +
           std::to_string(self) + " triangle pairs and the body in " + std::to_string(body);
  return out;
}

}  // namespace weft
