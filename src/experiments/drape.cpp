// The drape test (weft/experiments/drape.hpp, docs/fabric-validation.md).
#include "weft/experiments/drape.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>

#include "mesh/panel_mesher.hpp"
#include "weft/error.hpp"
#include "sim/simulation_core.hpp"

namespace weft {
namespace {

std::vector<Vec2> circle(double radius, int points) {
  std::vector<Vec2> c;
  for (int k = 0; k < points; ++k) {
    const double a = 2 * M_PI * k / points;
    c.emplace_back(radius * std::cos(a), radius * std::sin(a));
  }
  return c;
}

std::string number(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

// Messages name each option as `weft experiment drape` spells it.
void check_options(const DrapeOptions& o) {
  auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (!positive(o.specimen_diameter_m) || !positive(o.support_diameter_m) ||
      !(o.support_diameter_m < o.specimen_diameter_m))
    throw InputError("--support-diameter " + number(o.support_diameter_m) + " / --specimen-diameter " +
                     number(o.specimen_diameter_m) + ": expected positive diameters (m), the support disk's smaller");
  const double overhang = (o.specimen_diameter_m - o.support_diameter_m) / 2;
  if (!positive(o.edge_length_m) || o.edge_length_m > overhang / 2)
    throw InputError("--edge-length " + number(o.edge_length_m) + ": expected a positive length (m) at most half the overhang (" +
                     number(overhang / 2) + " m)");
  if (!std::isfinite(o.grain_deg)) throw InputError("--grain-deg " + number(o.grain_deg) + ": expected a finite angle");
  if (!positive(o.dt_s) || o.dt_s > o.frame_interval_s)
    throw InputError("--dt " + number(o.dt_s) + ": expected a positive step (s) at most " + number(o.frame_interval_s));
  if (!positive(o.max_time_s)) throw InputError("--max-time " + number(o.max_time_s) + ": expected a positive time (s)");
  if (!positive(o.frame_interval_s)) throw InputError("drape: the check interval must be positive");
  if (!positive(o.rest_speed_m_s)) throw InputError("--rest-speed " + number(o.rest_speed_m_s) + ": expected a positive speed (m/s)");
  if (!(o.rest_time_s >= 0) || !std::isfinite(o.rest_time_s))
    throw InputError("--rest-time " + number(o.rest_time_s) + ": expected a time >= 0 (s)");
  if (!positive(o.pixel_m) || o.pixel_m > o.edge_length_m)
    throw InputError("--pixel " + number(o.pixel_m) + ": expected a positive size (m) at most the edge length");
  if (!(o.node_prominence >= 0 && o.node_prominence < 1))
    throw InputError("drape: the node prominence must be in [0, 1)");
  if (!(o.imperfection_m >= 0) || !(o.imperfection_m <= 0.25 * (o.specimen_diameter_m - o.support_diameter_m)))
    throw InputError("--imperfection " + number(o.imperfection_m) + ": expected a height (m) from 0 to half the overhang (" +
                     number(0.25 * (o.specimen_diameter_m - o.support_diameter_m)) + " m)");
  if (o.bending_model != "hinge" && o.bending_model != "plate")
    throw InputError("--bending-model \"" + o.bending_model + "\": expected hinge or plate");
}

/// A number in [0, 1) from the generator's next 53 bits (the same on every platform, unlike
/// the standard distributions).
double unit_draw(std::mt19937_64& g) { return static_cast<double>(g() >> 11) * 0x1p-53; }

/// Lifts the overhang by the imperfection of DrapeOptions::imperfection_m (y up).
void add_imperfection(const DrapeOptions& o, Points& x) {
  if (o.imperfection_m == 0) return;
  constexpr int kModes = 12;
  std::mt19937_64 g(o.imperfection_seed);
  double a[kModes], phi[kModes], sum = 0;
  for (int k = 0; k < kModes; ++k) {
    a[k] = 2 * unit_draw(g) - 1;
    phi[k] = 2 * M_PI * unit_draw(g);
    sum += std::abs(a[k]);
  }
  const double R = o.specimen_diameter_m / 2, r = o.support_diameter_m / 2;
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    const double rho = std::hypot(x(i, 0), x(i, 2));
    if (rho <= r) continue;
    const double theta = std::atan2(-x(i, 2), x(i, 0));
    double wave = 0;
    for (int k = 0; k < kModes; ++k) wave += a[k] * std::cos((k + 1) * theta + phi[k]);
    x(i, 1) = o.imperfection_m * std::min(1.0, (rho - r) / (R - r)) * wave / sum;
  }
}

}  // namespace

TriMesh drape_specimen_mesh(const DrapeOptions& o, std::vector<int>& support, std::vector<int>& edge) {
  const double R = o.specimen_diameter_m / 2, r = o.support_diameter_m / 2, h = o.edge_length_m;
  const int n_outer = std::max(12, static_cast<int>(std::ceil(2 * M_PI * R / h)));
  const int n_ring = std::max(8, static_cast<int>(std::ceil(2 * M_PI * r / h)));
  PanelMeshOptions mo;
  mo.target_edge_m = h;
  // The overhanging annulus and the clamped disk meshed apart, sharing the ring on the
  // disk's edge, so that the clamp ends exactly on the support's edge.
  PanelOutline annulus{circle(R, n_outer), {circle(r, n_ring)}};
  const PanelMesh outer = mesh_panel(annulus, mo);
  const PanelMesh inner = mesh_panel(PanelOutline{circle(r, n_ring), {}}, mo);
  std::vector<Vec2> points = outer.vertices;
  std::vector<int> inner_index(inner.vertices.size());
  for (size_t k = 0; k < inner.vertices.size(); ++k) {
    if (static_cast<int>(k) < n_ring) {
      inner_index[k] = n_outer + static_cast<int>(k);  // the shared ring: the annulus's hole
    } else {
      inner_index[k] = static_cast<int>(points.size());
      points.push_back(inner.vertices[k]);
    }
  }
  TriMesh m;
  m.positions.resize(static_cast<Eigen::Index>(points.size()), 3);
  m.pattern.resize(points.size());
  const double g = o.grain_deg * M_PI / 180;
  // Exact on quarter turns, so that a balanced fabric turned by 90 degrees is the same problem.
  const bool quarter = std::fmod(o.grain_deg, 90.0) == 0.0;
  const double c = quarter ? std::round(std::cos(g)) : std::cos(g), s = quarter ? std::round(std::sin(g)) : std::sin(g);
  for (size_t i = 0; i < points.size(); ++i) {
    const Vec2& p = points[i];
    // Seen from above (+y) the plane's axes are x and -z, so counter-clockwise stays so.
    m.positions.row(static_cast<Eigen::Index>(i)) << p.x(), 0.0, -p.y();
    // The weft at grain_deg from x: pattern coordinates along the weft and the warp.
    m.pattern[i] = Vec2(c * p.x() + s * p.y(), -s * p.x() + c * p.y());
  }
  m.triangles = outer.triangles;
  for (const auto& t : inner.triangles) m.triangles.push_back({inner_index[t[0]], inner_index[t[1]], inner_index[t[2]]});
  support.clear();
  edge.clear();
  for (int i = 0; i < n_outer; ++i) edge.push_back(i);
  // Clamped: the ring on the disk's edge (the annulus's hole) and the disk's inside.
  for (int i = n_outer; i < n_outer + n_ring; ++i) support.push_back(i);
  for (size_t i = outer.vertices.size(); i < points.size(); ++i) support.push_back(static_cast<int>(i));
  return m;
}

double projected_area(const Points& x, const std::vector<std::array<int, 3>>& triangles, double pixel) {
  if (triangles.empty()) return 0;
  double lo_x = x.col(0).minCoeff(), hi_x = x.col(0).maxCoeff();
  double lo_z = x.col(2).minCoeff(), hi_z = x.col(2).maxCoeff();
  const int nx = static_cast<int>(std::ceil((hi_x - lo_x) / pixel)) + 1;
  const int nz = static_cast<int>(std::ceil((hi_z - lo_z) / pixel)) + 1;
  std::vector<char> covered(static_cast<size_t>(nx) * static_cast<size_t>(nz), 0);
  for (const auto& t : triangles) {
    const Vec2 a(x(t[0], 0), x(t[0], 2)), b(x(t[1], 0), x(t[1], 2)), c(x(t[2], 0), x(t[2], 2));
    const double area2 = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
    if (area2 == 0) continue;  // seen edge-on: covers no pixel centre's area
    const double sign = area2 > 0 ? 1 : -1;
    auto side = [sign](const Vec2& p, const Vec2& q, const Vec2& r) {
      return sign * ((q - p).x() * (r - p).y() - (q - p).y() * (r - p).x());
    };
    const int i0 = std::max(0, static_cast<int>(std::floor((std::min({a.x(), b.x(), c.x()}) - lo_x) / pixel - 0.5)));
    const int i1 = std::min(nx - 1, static_cast<int>(std::ceil((std::max({a.x(), b.x(), c.x()}) - lo_x) / pixel)));
    const int j0 = std::max(0, static_cast<int>(std::floor((std::min({a.y(), b.y(), c.y()}) - lo_z) / pixel - 0.5)));
    const int j1 = std::min(nz - 1, static_cast<int>(std::ceil((std::max({a.y(), b.y(), c.y()}) - lo_z) / pixel)));
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const Vec2 p(lo_x + (i + 0.5) * pixel, lo_z + (j + 0.5) * pixel);
        if (side(a, b, p) >= 0 && side(b, c, p) >= 0 && side(c, a, p) >= 0)
          covered[static_cast<size_t>(j) * static_cast<size_t>(nx) + static_cast<size_t>(i)] = 1;
      }
  }
  const double count = static_cast<double>(std::count(covered.begin(), covered.end(), 1));
  return count * pixel * pixel;
}

std::vector<int> profile_nodes(const std::vector<double>& r, double min_prominence) {
  const int n = static_cast<int>(r.size());
  std::vector<int> nodes;
  if (n < 3) return nodes;
  auto at = [&](int k) { return r[static_cast<size_t>(((k % n) + n) % n)]; };
  for (int i = 0; i < n; ++i) {
    // A maximum; on a plateau only its first point counts.
    if (!(at(i) > at(i - 1) && at(i) >= at(i + 1))) continue;
    if (at(i) == at(i + 1)) {
      int k = i + 1;
      while (k < i + n && at(k) == at(i)) ++k;
      if (at(k) > at(i)) continue;
    }
    // Walk each way until a higher point (or all the way round), keeping the lowest point.
    double low_left = at(i), low_right = at(i);
    bool higher_left = false, higher_right = false;
    for (int k = 1; k < n; ++k) {
      if (at(i - k) > at(i)) {
        higher_left = true;
        break;
      }
      low_left = std::min(low_left, at(i - k));
    }
    for (int k = 1; k < n; ++k) {
      if (at(i + k) > at(i)) {
        higher_right = true;
        break;
      }
      low_right = std::min(low_right, at(i + k));
    }
    double base;
    if (higher_left && higher_right) base = std::max(low_left, low_right);
    else if (higher_left) base = low_left;
    else if (higher_right) base = low_right;
    else base = std::min(low_left, low_right);  // the highest point: its prominence is the range
    if (at(i) - base >= min_prominence) nodes.push_back(i);
  }
  return nodes;
}

DrapeResult run_drape_test(const Material& material, const DrapeOptions& o, const DrapeProgress& progress) {
  check_options(o);
  DrapeResult res;
  std::vector<int> support, edge;
  auto mesh = std::make_shared<TriMesh>(drape_specimen_mesh(o, support, edge));
  add_imperfection(o, mesh->positions);  // the rest shape is the pattern's: the start only

  Scene scene = parse_scene_text(
      R"({"weft_scene": 1, "duration": 1, "frame_interval": 0.05, "gravity": [0, -9.81, 0],
          "integrator": {"method": "implicit-midpoint", "dt": 0.005},
          "cloth": {"mesh": {"grid": {"size": [0.1, 0.1], "vertices": [2, 2]}}}})",
      "drape test", ".");
  scene.description = "Cusick drape test of " + material.name;
  scene.duration = o.max_time_s;
  set_method(scene, o.method, std::nullopt, "--method");
  scene.integrator.dt = o.dt_s;
  scene.frame_interval = o.frame_interval_s;
  scene.cloth.grid.reset();
  scene.cloth.mesh = mesh;
  scene.cloth.material = material;
  scene.cloth.pin_vertices = support;
  scene.cloth.bending_model = o.bending_model;
  scene.cloth.self_collision = o.self_collision;

  const auto start = std::chrono::steady_clock::now();
  Simulation sim(scene);
  const int n = mesh->num_vertices();
  double quiet_since = 0;
  bool quiet = false;
  const long frames = static_cast<long>(std::ceil(o.max_time_s / o.frame_interval_s - 1e-9));
  for (long f = 1; f <= frames; ++f) {
    const double t = std::min(o.max_time_s, f * o.frame_interval_s);
    sim.advance_to(t);
    const State& s = sim.core().state();
    if (!s.x.allFinite() || !s.v.allFinite()) {
      res.status = "unstable";
      break;
    }
    double vmax = 0;
    for (int i = 0; i < n; ++i) vmax = std::max(vmax, s.v.segment<3>(3 * i).norm());
    res.max_speed_m_s = vmax;
    if (vmax < o.rest_speed_m_s) {
      if (!quiet) quiet_since = t;
      quiet = true;
    } else {
      quiet = false;
    }
    if (progress) progress(t / o.max_time_s);
    if (quiet && t - quiet_since >= o.rest_time_s - 1e-12) {
      res.at_rest = true;
      break;
    }
  }
  res.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  res.simulated_time_s = sim.core().state().t;
  res.steps = sim.core().statistics().steps;
  res.vertices = n;
  res.triangles = static_cast<int>(mesh->triangles.size());
  res.pinned = static_cast<int>(support.size());
  res.mesh = *mesh;
  for (int i = 0; i < n; ++i) res.mesh.positions.row(i) = sim.core().state().x.segment<3>(3 * i).transpose();

  const double R = o.specimen_diameter_m / 2, r = o.support_diameter_m / 2;
  res.specimen_area_m2 = M_PI * R * R;
  res.support_area_m2 = M_PI * r * r;
  if (res.status == "ok") {
    res.shadow_area_m2 = projected_area(res.mesh.positions, res.mesh.triangles, o.pixel_m);
    res.drape_coefficient = (res.shadow_area_m2 - res.support_area_m2) / (res.specimen_area_m2 - res.support_area_m2);
    for (int i : edge) {
      const double x = res.mesh.positions(i, 0), z = res.mesh.positions(i, 2);
      res.edge_angle_deg.push_back(std::atan2(-z, x) * 180 / M_PI);
      res.edge_radius_m.push_back(std::hypot(x, z));
    }
    res.min_radius_m = *std::min_element(res.edge_radius_m.begin(), res.edge_radius_m.end());
    res.max_radius_m = *std::max_element(res.edge_radius_m.begin(), res.edge_radius_m.end());
    const double prominence = std::max(0.002, o.node_prominence * (res.max_radius_m - res.min_radius_m));
    for (int k : profile_nodes(res.edge_radius_m, prominence)) res.node_angles_deg.push_back(res.edge_angle_deg[k]);
    res.nodes = static_cast<int>(res.node_angles_deg.size());
  }
  return res;
}

}  // namespace weft
