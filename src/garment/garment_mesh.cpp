#include "weft/garment/garment_mesh.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <utility>

#include "mesh/panel_mesher.hpp"
#include "weft/error.hpp"

namespace weft {
namespace {

/// The outline vertices of one edge, from the edge's start to its end.
std::vector<int> edge_vertex_indices(const SampledOutline& outline, const EdgeSpan& span) {
  const int n = static_cast<int>(outline.points_m.size());
  std::vector<int> out;
  out.reserve(static_cast<size_t>(span.segments) + 1);
  for (int k = 0; k <= span.segments; ++k) out.push_back((span.first + k) % n);
  // A clockwise panel's outline walks its edges backwards.
  if (outline.reversed) std::reverse(out.begin(), out.end());
  return out;
}

std::string format_length(double metres) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", metres);
  return b;
}

}  // namespace

GarmentMesh mesh_garment(const Pattern& pattern, const GarmentMeshOptions& options) {
  const std::string file = pattern.file.empty() ? pattern.name : pattern.file;
  if (!(options.target_edge_m > 0) || !std::isfinite(options.target_edge_m))
    throw InputError(file + ": mesh edge length " + format_length(options.target_edge_m) +
                     " m: expected a positive length");
  for (const auto& [name, angle] : options.grain_angle_rad) {
    bool found = false;
    for (const Panel& panel : pattern.panels) found = found || panel.name == name;
    if (!found) throw InputError(file + ": grain for panel '" + name + "': the pattern has no such panel");
    if (!std::isfinite(angle))
      throw InputError(file + ": grain for panel '" + name + "': expected a finite angle, got " + format_length(angle));
  }
  GarmentMesh mesh;
  mesh.segment_counts = edge_segment_counts(pattern, options.target_edge_m);
  const std::vector<SampledOutline> outlines = pattern_outlines(pattern, mesh.segment_counts);

  PanelMeshOptions mesher;
  mesher.target_edge_m = options.target_edge_m;
  mesher.min_angle_deg = options.min_angle_deg;
  for (size_t p = 0; p < pattern.panels.size(); ++p) {
    const Panel& panel = pattern.panels[p];
    const SampledOutline& outline = outlines[p];
    PanelMesh pm;
    try {
      pm = mesh_panel(PanelOutline{outline.points_m, {}}, mesher);
    } catch (const InputError& e) {
      throw InputError(file + ": panel '" + panel.name + "': meshing at " +
                       format_length(options.target_edge_m) + " m: " + e.what());
    }
    GarmentPanelMesh out;
    out.name = panel.name;
    out.vertices_m = std::move(pm.vertices);
    out.triangles = std::move(pm.triangles);
    out.boundary_vertices = pm.boundary_vertices;
    if (const auto grain = options.grain_angle_rad.find(panel.name); grain != options.grain_angle_rad.end())
      out.grain_angle_rad = grain->second;
    for (const EdgeSpan& span : outline.edges)
      out.edge_vertices.push_back(edge_vertex_indices(outline, span));
    mesh.panels.push_back(std::move(out));
  }

  for (const Stitch& s : pattern.stitches) {
    StitchVertexPairs st;
    st.panel_a = s.a.panel;
    st.edge_a = s.a.edge;
    st.panel_b = s.b.panel;
    st.edge_b = s.b.edge;
    const std::vector<int>& a =
        mesh.panels[static_cast<size_t>(s.a.panel)].edge_vertices[static_cast<size_t>(s.a.edge)];
    const std::vector<int>& b =
        mesh.panels[static_cast<size_t>(s.b.panel)].edge_vertices[static_cast<size_t>(s.b.edge)];
    // edge_segment_counts gives stitched edges one count, so the sides have equal lengths.
    const size_t n = a.size();
    for (size_t k = 0; k < n; ++k)
      st.pairs.push_back({a[k], s.same_direction ? b[k] : b[n - 1 - k]});
    mesh.stitches.push_back(std::move(st));
  }
  return mesh;
}

Vec2 warp_direction(const GarmentPanelMesh& panel) {
  return Vec2(-std::sin(panel.grain_angle_rad), std::cos(panel.grain_angle_rad));
}

Vec2 weft_direction(const GarmentPanelMesh& panel) {
  const Vec2 warp = warp_direction(panel);
  return Vec2(warp.y(), -warp.x());
}

std::vector<Vec2> material_coordinates(const GarmentPanelMesh& panel) {
  if (panel.grain_angle_rad == 0) return panel.vertices_m;
  const Vec2 u = weft_direction(panel), v = warp_direction(panel);
  std::vector<Vec2> out;
  out.reserve(panel.vertices_m.size());
  for (const Vec2& x : panel.vertices_m) out.emplace_back(x.dot(u), x.dot(v));
  return out;
}

std::vector<Vec2> flat_layout_offsets(const GarmentMesh& mesh, double gap_m) {
  const size_t n = mesh.panels.size();
  std::vector<Vec2> lo(n), hi(n);
  double box_area = 0;
  for (size_t p = 0; p < n; ++p) {
    lo[p] = Vec2::Constant(std::numeric_limits<double>::infinity());
    hi[p] = -lo[p];
    for (const Vec2& x : mesh.panels[p].vertices_m) {
      lo[p] = lo[p].cwiseMin(x);
      hi[p] = hi[p].cwiseMax(x);
    }
    box_area += (hi[p] - lo[p]).prod();
  }
  const double row_width = 1.6 * std::sqrt(box_area);
  // Rows are laid from the top down (reading order), then everything is raised to y >= 0.
  std::vector<Vec2> offsets(n);
  double x = 0, row_top = 0, row_height = 0;
  for (size_t p = 0; p < n; ++p) {
    const Vec2 size = hi[p] - lo[p];
    if (x > 0 && x + size.x() > row_width) {
      row_top -= row_height + gap_m;
      x = 0;
      row_height = 0;
    }
    offsets[p] = Vec2(x - lo[p].x(), row_top - hi[p].y());
    x += size.x() + gap_m;
    row_height = std::max(row_height, size.y());
  }
  const double bottom = row_top - row_height;
  for (Vec2& o : offsets) o.y() -= bottom;
  return offsets;
}

PanelMeshStats panel_mesh_stats(const GarmentPanelMesh& panel) {
  PanelMeshStats stats;
  stats.smallest_angle_deg = 180;
  std::set<std::pair<int, int>> edges;
  const auto& v = panel.vertices_m;
  for (const auto& t : panel.triangles) {
    const Vec2 &a = v[static_cast<size_t>(t[0])], &b = v[static_cast<size_t>(t[1])],
               &c = v[static_cast<size_t>(t[2])];
    const Vec2 ab = b - a, ac = c - a;
    stats.area_m2 += 0.5 * (ab.x() * ac.y() - ab.y() * ac.x());
    for (int i = 0; i < 3; ++i) {
      const Vec2& p = v[static_cast<size_t>(t[i])];
      const Vec2 e1 = v[static_cast<size_t>(t[(i + 1) % 3])] - p,
                 e2 = v[static_cast<size_t>(t[(i + 2) % 3])] - p;
      const double angle = std::atan2(std::abs(e1.x() * e2.y() - e1.y() * e2.x()), e1.dot(e2));
      stats.smallest_angle_deg = std::min(stats.smallest_angle_deg, angle * 180 / M_PI);
      edges.insert(std::minmax(t[i], t[(i + 1) % 3]));
    }
  }
  double total = 0;
  for (const auto& e : edges)
    total += (v[static_cast<size_t>(e.first)] - v[static_cast<size_t>(e.second)]).norm();
  stats.mean_edge_m = edges.empty() ? 0 : total / static_cast<double>(edges.size());
  if (panel.triangles.empty()) stats.smallest_angle_deg = 0;
  return stats;
}

}  // namespace weft
