// The intersection checker on crafted meshes: crossing, touching, nearly touching, sharing a
// vertex; and on crumpled sheets against a brute-force count over every pair of triangles.
#include <gtest/gtest.h>

#include <random>

#include "collision/geometry.hpp"
#include "collision/intersections.hpp"
#include "mesh/mesh.hpp"

namespace weft {
namespace {

using Triangles3 = std::vector<std::array<int, 3>>;

struct Mesh {
  VecX x;
  Triangles3 triangles;
};

// A flat n x n grid of side `size` in z = 0, moved by `shift`, turned so that its normal is
// `axis` (2: z, 0: x).
Mesh grid(int n, double size, const Vec3& shift = Vec3::Zero(), int axis = 2) {
  const TriMesh g = make_grid(size, size, n, n);
  Mesh m;
  m.triangles = g.triangles;
  m.x.resize(3 * g.num_vertices());
  for (int i = 0; i < g.num_vertices(); ++i) {
    Vec3 p = g.positions.row(i).transpose();
    if (axis == 0) p = Vec3(p.z(), p.x(), p.y());
    m.x.segment<3>(3 * i) = p + shift;
  }
  return m;
}

// Two meshes as one (the second's vertices numbered after the first's).
Mesh merge(const Mesh& a, const Mesh& b) {
  Mesh m;
  m.x.resize(a.x.size() + b.x.size());
  m.x << a.x, b.x;
  m.triangles = a.triangles;
  const int offset = static_cast<int>(a.x.size() / 3);
  for (auto t : b.triangles) m.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  return m;
}

Vec3 vertex(const VecX& x, int i) { return x.segment<3>(3 * i); }

size_t brute_self_count(const Mesh& m) {
  size_t n = 0;
  for (size_t i = 0; i < m.triangles.size(); ++i)
    for (size_t j = i + 1; j < m.triangles.size(); ++j) {
      const auto &s = m.triangles[i], &t = m.triangles[j];
      bool shared = false;
      for (int a : s)
        for (int b : t) shared |= a == b;
      if (!shared && triangles_intersect(vertex(m.x, s[0]), vertex(m.x, s[1]), vertex(m.x, s[2]), vertex(m.x, t[0]),
                                         vertex(m.x, t[1]), vertex(m.x, t[2])))
        ++n;
    }
  return n;
}

size_t self_count(const Mesh& m) { return self_intersections(m.x.data(), m.triangles).count; }

size_t cross_count(const Mesh& a, const Mesh& b) {
  const AabbTree ta(a.triangles, a.x.data()), tb(b.triangles, b.x.data());
  return mesh_intersections(a.x.data(), ta, b.x.data(), tb).count;
}

TEST(SelfIntersections, FlatSheetHasNone) { EXPECT_EQ(self_count(grid(17, 1.0)), 0u); }

TEST(SelfIntersections, CrossingSheetsOfOneMesh) {
  // A vertical sheet (x = 0.37) through a horizontal one: every pair found is a real,
  // non-adjacent intersection, and the count is the brute-force one.
  const Mesh m = merge(grid(9, 1.0), grid(9, 1.0, Vec3(0.37, 0.1, -0.5), 0));
  const IntersectionCount r = self_intersections(m.x.data(), m.triangles, 5);
  EXPECT_GT(r.count, 0u);
  EXPECT_EQ(r.count, brute_self_count(m));
  ASSERT_EQ(r.examples.size(), 5u);
  for (const auto& [i, j] : r.examples) {
    EXPECT_LT(i, j);
    const auto &s = m.triangles[i], &t = m.triangles[j];
    EXPECT_TRUE(triangles_intersect(vertex(m.x, s[0]), vertex(m.x, s[1]), vertex(m.x, s[2]), vertex(m.x, t[0]),
                                    vertex(m.x, t[1]), vertex(m.x, t[2])));
  }
}

TEST(SelfIntersections, TouchingCountsNearlyTouchingDoesNot) {
  // A second layer lying exactly on the first (its own vertices): touching, so counted.
  EXPECT_GT(self_count(merge(grid(5, 1.0), grid(5, 1.0))), 0u);
  // The same a micrometre above: nothing.
  EXPECT_EQ(self_count(merge(grid(5, 1.0), grid(5, 1.0, Vec3(0, 0, 1e-6)))), 0u);
  // A vertical sheet whose lower edge rests on the horizontal one, and one just above it.
  EXPECT_GT(self_count(merge(grid(5, 1.0), grid(5, 0.5, Vec3(0.3, 0.1, 0), 0))), 0u);
  EXPECT_EQ(self_count(merge(grid(5, 1.0), grid(5, 0.5, Vec3(0.3, 0.1, 1e-6), 0))), 0u);
}

TEST(SelfIntersections, TrianglesSharingAVertexAreLeftOut) {
  // Two triangles sharing vertex 0 and crossing each other (a fold through itself).
  Mesh fold;
  fold.x.resize(15);
  fold.x << 0, 0, 0, 1, 0, 0, 0, 1, 0,  // triangle in z = 0
      0.6, 0.2, -0.5, 0.2, 0.6, 0.5;     // with vertex 0: a triangle through the first
  fold.triangles = {{0, 1, 2}, {0, 3, 4}};
  const Vec3 v0 = vertex(fold.x, 0), v3 = vertex(fold.x, 3), v4 = vertex(fold.x, 4);
  ASSERT_TRUE(triangles_intersect(vertex(fold.x, 0), vertex(fold.x, 1), vertex(fold.x, 2), v0, v3, v4));
  EXPECT_EQ(self_count(fold), 0u);
  // The same with the second triangle's corner a separate vertex at the same place: counted.
  Mesh apart = fold;
  apart.x.conservativeResize(18);
  apart.x.tail<3>() = v0;
  apart.triangles = {{0, 1, 2}, {5, 3, 4}};
  EXPECT_EQ(self_count(apart), 1u);
}

TEST(SelfIntersections, CrumpledSheetsMatchBruteForce) {
  std::mt19937 rng(17);
  std::normal_distribution<double> g(0, 1);
  for (double crumple : {0.0, 0.02, 0.08, 0.3}) {
    Mesh m = grid(15, 1.0);
    for (int i = 0; i < m.x.size(); ++i) m.x[i] += crumple * g(rng) / 14;
    EXPECT_EQ(self_count(m), brute_self_count(m)) << crumple;
  }
}

TEST(MeshIntersections, ClothAgainstABody) {
  const Mesh cloth = grid(9, 1.0);
  // A body through the cloth, touching it, and just beside it.
  const Mesh through = grid(6, 0.6, Vec3(0.43, 0.2, -0.3), 0);
  const size_t n = cross_count(cloth, through);
  EXPECT_GT(n, 0u);
  // Brute force: the body's pairs with the cloth in one merged mesh, less the cloth's own.
  EXPECT_EQ(n, brute_self_count(merge(cloth, through)) - brute_self_count(cloth) - brute_self_count(through));
  EXPECT_GT(cross_count(cloth, grid(6, 0.6, Vec3(0.43, 0.2, 0), 0)), 0u);
  EXPECT_EQ(cross_count(cloth, grid(6, 0.6, Vec3(0.43, 0.2, 1e-6), 0)), 0u);
}

}  // namespace
}  // namespace weft
