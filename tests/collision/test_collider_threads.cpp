// Mesh colliders answer the cloth's nodes on several threads (ColliderContacts::query_nodes):
// the contacts found and the fail-safe's corrections must be the same bits on one thread and
// on two.
#include <gtest/gtest.h>

#include <cmath>

#include "collision/colliders.hpp"
#include "weft/threads.hpp"

using namespace weft;

namespace {

// A UV sphere of radius r about the origin (closed, wound outwards), rising at 0.5 m/s.
std::unique_ptr<Collider> rising_sphere(double r, int around, int rings) {
  Points p((rings - 1) * around + 2, 3);
  p.row(0) << 0, r, 0;
  for (int j = 1; j < rings; ++j)
    for (int i = 0; i < around; ++i) {
      const double polar = M_PI * j / rings, azimuth = 2 * M_PI * i / around;
      p.row(1 + (j - 1) * around + i) << r * std::sin(polar) * std::cos(azimuth), r * std::cos(polar),
          -r * std::sin(polar) * std::sin(azimuth);
    }
  const int south = static_cast<int>(p.rows()) - 1;
  p.row(south) << 0, -r, 0;
  std::vector<std::array<int, 3>> tris;
  for (int i = 0; i < around; ++i) {
    const int a = 1 + i, b = 1 + (i + 1) % around;
    tris.push_back({0, a, b});
    const int c = 1 + (rings - 2) * around + i, d = 1 + (rings - 2) * around + (i + 1) % around;
    tris.push_back({south, d, c});
  }
  for (int j = 1; j + 1 < rings; ++j)
    for (int i = 0; i < around; ++i) {
      const int a = 1 + (j - 1) * around + i, b = 1 + (j - 1) * around + (i + 1) % around;
      const int c = a + around, d = b + around;
      tris.push_back({a, c, d});
      tris.push_back({a, d, b});
    }
  Triangles t(static_cast<Eigen::Index>(tris.size()), 3);
  for (size_t k = 0; k < tris.size(); ++k) t.row(static_cast<Eigen::Index>(k)) << tris[k][0], tris[k][1], tris[k][2];
  ColliderSpec spec;
  spec.shape = ColliderShape::kMesh;
  spec.thickness = 0.004;
  spec.friction = 0.3;
  return make_mesh_collider(spec, t, [p](double time, Points& out) {
    out = p;
    out.col(1).array() += 0.5 * time;
  }, true);
}

}  // namespace

TEST(ColliderThreads, ContactsAndCorrectionsAreTheSameBitsOnOneThreadAndOnTwo) {
  // A 50 x 50 sheet (2,500 nodes: ten chunks of queries) draped low over the sphere's cap,
  // some nodes inside the thickness, falling at 1 m/s onto the rising sphere.
  const int n = 50;
  VecX x(3 * n * n), v(3 * n * n), mass = VecX::Constant(n * n, 1e-4);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double u = 0.5 * i / (n - 1) - 0.25, w = 0.5 * j / (n - 1) - 0.25;
      const double rho2 = u * u + w * w;
      const double cap = rho2 < 0.04 ? std::sqrt(0.04 - rho2) : 0.0;
      x.segment<3>(3 * (j * n + i)) = Vec3(u, cap + 0.002 * std::sin(37.0 * u + 11.0 * w), w);
      v.segment<3>(3 * (j * n + i)) = Vec3(0.1 * std::cos(5.0 * w), -1.0, 0.1 * std::sin(7.0 * u));
    }
  std::vector<char> fixed(n * n, 0);
  fixed[0] = 1;
  std::vector<std::array<int, 3>> triangles;
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      triangles.push_back({a, b, d});
      triangles.push_back({a, d, c});
    }
  struct Outcome {
    std::vector<NodeContact> start, end;
    VecX x1, v1;
    long moves = 0;
  };
  auto run = [&](int threads) {
    set_thread_count(threads);
    auto sphere = rising_sphere(0.2, 48, 24);
    ColliderContacts contacts({sphere.get()}, mass, fixed, triangles);
    Outcome o;
    const double dt = 0.005;
    contacts.detect(x, v, 0.0, dt, o.start);
    o.x1 = x + dt * v;
    o.v1 = v;
    std::vector<char> held(n * n, 0);
    contacts.detect_end(x, o.x1, 0.0, dt, held, o.end);
    ContactReport report;
    contacts.finish_step(x, o.x1, o.v1, 0.0, dt, report);
    o.moves = report.fail_safe_moves;
    return o;
  };
  const Outcome one = run(1), two = run(2);
  set_thread_count(0);
  ASSERT_GT(one.start.size(), 300u) << "the case must hold many nodes";
  ASSERT_GT(one.moves, 0) << "and move some";
  for (const auto* lists : {&one.start, &one.end}) {
    const auto& other = lists == &one.start ? two.start : two.end;
    ASSERT_EQ(lists->size(), other.size());
    for (size_t k = 0; k < lists->size(); ++k) {
      EXPECT_EQ((*lists)[k].node, other[k].node);
      EXPECT_TRUE((*lists)[k].normal == other[k].normal);
      EXPECT_EQ((*lists)[k].normal_displacement, other[k].normal_displacement);
    }
  }
  EXPECT_EQ(one.moves, two.moves);
  EXPECT_TRUE(one.x1 == two.x1);
  EXPECT_TRUE(one.v1 == two.v1);
}
