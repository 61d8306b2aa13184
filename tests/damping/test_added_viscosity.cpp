// The added viscosity written per vertex in PLY frames (docs/damping.md): the area-weighted
// mean, over the triangles around the vertex, of the viscosity adaptive damping added to
// each triangle's largest mode.
#include <gtest/gtest.h>

#include "mesh/mesh.hpp"
#include "system/cloth.hpp"

using namespace weft;

TEST(AddedViscosity, PerVertexValueIsTheAreaWeightedMeanOverItsTriangles) {
  // A grid whose interior pattern vertices are moved, so that the triangles around a vertex
  // differ in area (and in the viscosity damping adds to them).
  TriMesh mesh = make_grid(0.3, 0.2, 6, 5);
  for (int j = 1; j < 4; ++j)
    for (int i = 1; i < 5; ++i) mesh.pattern[j * 6 + i] += Vec2(0.012 * ((i + j) % 3 - 1), 0.009 * ((i * j) % 3 - 1));
  Material mat;
  mat.viscosity_Ns_m = 1e-4;
  mat.weft = StressCurve::linear(400);
  mat.warp = StressCurve::linear(150);
  const ClothModel m = build_cloth_model(mesh, mat, Vec3(0, -9.81, 0), {});
  ClothSystem sys(m, DampingSettings{0.2, 0.0});
  const VecX x = m.initial_positions();
  sys.begin_step(x, VecX::Zero(x.size()), 0.01);
  const auto& eta = sys.membrane_viscosity();
  const int n = m.num_vertices();
  std::vector<double> sum(n, 0.0), area(n, 0.0);
  double smallest = 1e300, largest = 0;
  for (size_t t = 0; t < m.membranes.size(); ++t) {
    const double a = m.membranes[t].area;
    smallest = std::min(smallest, a);
    largest = std::max(largest, a);
    const double added = eta[t].maxCoeff() - mat.viscosity_Ns_m;
    for (int k : m.mesh.triangles[t]) {
      sum[k] += a * added;
      area[k] += a;
    }
  }
  ASSERT_GT(largest, 1.2 * smallest);
  const VecX per_vertex = sys.added_viscosity_per_vertex();
  ASSERT_EQ(per_vertex.size(), n);
  for (int i = 0; i < n; ++i) {
    ASSERT_GT(sum[i], 0) << "vertex " << i << ": damping should have raised its triangles";
    EXPECT_NEAR(per_vertex[i], sum[i] / area[i], 1e-12 * sum[i] / area[i]) << "vertex " << i;
  }
}
