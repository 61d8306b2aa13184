// Sewing as a preparation stage (sew_garment): a placed mesh in, a sewn and welded mesh out.
// Two flat panels facing each other across a box are sewn along both long edges into a tube.
#include <gtest/gtest.h>

#include <cmath>

#include "weft/garment/sewing.hpp"

namespace weft {
namespace {

/// A closed box from lo to hi, its triangles wound counter-clockwise seen from outside.
BindBody box_body(const Vec3& lo, const Vec3& hi) {
  BindBody body;
  body.positions.resize(8, 3);
  for (int c = 0; c < 8; ++c)
    body.positions.row(c) = Vec3(c & 1 ? hi.x() : lo.x(), c & 2 ? hi.y() : lo.y(), c & 4 ? hi.z() : lo.z()).transpose();
  const int quads[6][4] = {{0, 2, 6, 4}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 5, 7, 6}};
  const Vec3 centre = 0.5 * (lo + hi);
  body.triangles.resize(12, 3);
  for (int q = 0; q < 6; ++q)
    for (int h = 0; h < 2; ++h) {
      int t[3] = {quads[q][0], quads[q][1 + h], quads[q][2 + h]};
      const Vec3 a = body.positions.row(t[0]), b = body.positions.row(t[1]), c = body.positions.row(t[2]);
      if ((b - a).cross(c - a).dot((a + b + c) / 3 - centre) < 0) std::swap(t[1], t[2]);
      body.triangles.row(2 * q + h) << t[0], t[1], t[2];
    }
  return body;
}

/// Two nu by nv panels of w by h, the front at z = +d facing +z and the back at z = -d facing
/// -z (its pattern mirrored, so that every triangle is counter-clockwise in the pattern), with
/// stitch 0 joining their edges at the smallest x and stitch 1 those at the largest.
PlacedGarment two_panels(int nu, int nv, double w, double h, double d) {
  const TriMesh grid = make_grid(w, h, nu, nv);
  const int n = grid.num_vertices();
  PlacedGarment placed;
  TriMesh& m = placed.mesh;
  m.positions.resize(2 * n, 3);
  for (int side = 0; side < 2; ++side)
    for (int i = 0; i < n; ++i) {
      m.positions.row(side * n + i) = grid.positions.row(i);
      m.positions(side * n + i, 2) = side == 0 ? d : -d;
      const Vec2 p = grid.pattern[i];
      m.pattern.push_back(side == 0 ? p : Vec2(2 * w - p.x(), p.y()));
    }
  for (int side = 0; side < 2; ++side)
    for (const auto& t : grid.triangles) {
      m.triangles.push_back(side == 0 ? t : std::array<int, 3>{n + t[0], n + t[2], n + t[1]});
      placed.panel_of_triangle.push_back(side);
    }
  placed.panel_first_vertex = {0, n, 2 * n};
  for (int j = 0; j < nv; ++j)
    for (int stitch = 0; stitch < 2; ++stitch) {
      const int i = j * nu + (stitch == 0 ? 0 : nu - 1);
      placed.seam_pairs.push_back({i, n + i});
      placed.seam_stitch.push_back(stitch);
    }
  return placed;
}

TEST(SewingStage, ATwoPanelTubeClosesBelowTheGapAndEachWeldedVertexIsTheMeanOfItsSides) {
  const int nu = 9, nv = 5;
  const double d = 0.02;
  const PlacedGarment placed = two_panels(nu, nv, 0.16, 0.08, d);
  const Vec3 lo = placed.mesh.positions.colwise().minCoeff().transpose(),
             hi = placed.mesh.positions.colwise().maxCoeff().transpose();
  const BindBody body = box_body(Vec3(lo.x() + 0.05, lo.y() - 0.02, -0.008), Vec3(hi.x() - 0.05, hi.y() + 0.02, 0.008));
  SewingOptions options;
  options.material = material_preset("cotton");
  options.max_time_s = 0.5;
  const SewnGarment sewn = sew_garment(placed, body, options);

  EXPECT_NEAR(sewn.largest_gap_placed_m, 2 * d, 1e-12);
  EXPECT_TRUE(sewn.converged);
  EXPECT_LE(sewn.largest_gap_m, options.gap_m);
  EXPECT_TRUE(sewn.open_stitches.empty());
  EXPECT_TRUE(sewn.sewn()) << sewn.intersections.count() << " intersecting pairs";
  // Whole intervals of sewing, within the sewing time, each of its steps of dt at least.
  EXPECT_GT(sewn.sewing_time_s, 0);
  EXPECT_LE(sewn.sewing_time_s, options.max_time_s);
  EXPECT_NEAR(std::remainder(sewn.sewing_time_s, options.interval_s), 0.0, 1e-12);
  EXPECT_GE(sewn.steps, std::lround(sewn.sewing_time_s / options.dt_s));

  // One tube: the two edges' vertices merged pairwise, both panels' triangles kept, the seams
  // interior edges oriented alike on both sides, the two openings its only boundary.
  const int n = nu * nv;
  ASSERT_EQ(sewn.mesh.num_vertices(), 2 * n - 2 * nv);
  EXPECT_EQ(sewn.mesh.triangles.size(), placed.mesh.triangles.size());
  const EdgeUse use = edge_use(sewn.mesh.triangles);
  EXPECT_EQ(use.boundary, 4 * (nu - 1));
  EXPECT_EQ(use.non_manifold, 0);
  EXPECT_EQ(use.inconsistent, 0);

  // Every welded vertex is the mean of the sewn vertices it merges; each seam pair's two sides
  // were apart by at most the gap, so each moved by at most half of it.
  for (int v = 0; v < sewn.mesh.num_vertices(); ++v) {
    Vec3 sum = Vec3::Zero();
    int count = 0;
    for (int i = 0; i < 2 * n; ++i)
      if (sewn.welded_vertex[i] == v) {
        sum += sewn.sewn_positions.row(i).transpose();
        ++count;
      }
    ASSERT_GT(count, 0);
    const Vec3 welded = sewn.mesh.positions.row(v).transpose();
    EXPECT_LE((welded - sum / count).norm(), 1e-15) << "vertex " << v;
  }
  for (const auto& p : placed.seam_pairs) {
    const Vec3 a = sewn.sewn_positions.row(p[0]).transpose(), b = sewn.sewn_positions.row(p[1]).transpose();
    EXPECT_EQ(sewn.welded_vertex[p[0]], sewn.welded_vertex[p[1]]);
    EXPECT_LE((a - b).norm(), sewn.largest_gap_m);
    EXPECT_LE((Vec3(sewn.mesh.positions.row(sewn.welded_vertex[p[0]]).transpose()) - a).norm(), 0.5 * sewn.largest_gap_m + 1e-15);
  }
  // The seams closed where the panels met, clear of the box (its half thickness 8 mm, the
  // collider's 3 mm beyond).
  for (const auto& p : placed.seam_pairs) {
    const Vec3 a = sewn.sewn_positions.row(p[0]).transpose();
    EXPECT_LT(std::abs(a.z()), 0.25 * d);
  }
}

}  // namespace
}  // namespace weft
