// A mesh collider keeps, per cloth node, a lower bound on the node's distance from its surface
// (measured by a slightly wider search, shrunk by how far the node and the surface have moved
// since) and answers a query the bound rules out without searching. The bounds must never
// exceed the distance, and must change no answer: the queries, and the contact handling built
// on them, give the same bits with and without them. It keeps each node's last nearest
// triangle too, whose distance bounds the next search: a collider told the nodes' count keeps
// both, one that was not keeps neither, so the same comparison covers it.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "collision/colliders.hpp"
#include "collision/geometry.hpp"

using namespace weft;

namespace {

// A UV sphere of radius r about the origin (closed, wound outwards).
void uv_sphere(double r, int rings, int segments, Points& p, Triangles& t) {
  p.resize(2 + (rings - 1) * segments, 3);
  p.row(0) << 0, r, 0;
  p.row(1) << 0, -r, 0;
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const double th = M_PI * i / rings, ph = 2 * M_PI * j / segments;
      p.row(2 + (i - 1) * segments + j) << r * std::sin(th) * std::cos(ph), r * std::cos(th), r * std::sin(th) * std::sin(ph);
    }
  auto at = [&](int i, int j) { return 2 + (i - 1) * segments + (j % segments); };
  std::vector<std::array<int, 3>> list;
  for (int j = 0; j < segments; ++j) {
    list.push_back({0, at(1, j + 1), at(1, j)});
    list.push_back({1, at(rings - 1, j), at(rings - 1, j + 1)});
    for (int i = 1; i + 1 < rings; ++i) {
      list.push_back({at(i, j), at(i, j + 1), at(i + 1, j + 1)});
      list.push_back({at(i, j), at(i + 1, j + 1), at(i + 1, j)});
    }
  }
  t.resize(static_cast<Eigen::Index>(list.size()), 3);
  for (size_t f = 0; f < list.size(); ++f) t.row(static_cast<Eigen::Index>(f)) << list[f][0], list[f][1], list[f][2];
}

// The sphere's motion: carried along x at 0.4 m/s, bobbing, turning about y.
Vec3 centre_at(double t) { return Vec3(0.4 * t, 0.02 * std::sin(6 * t), 0); }
SurfaceMotion sphere_motion(const Points& rest) {
  return [rest](double t, Points& out) {
    const Mat3 turn = Eigen::AngleAxisd(2 * t, Vec3::UnitY()).toRotationMatrix();
    out.resize(rest.rows(), 3);
    for (Eigen::Index v = 0; v < rest.rows(); ++v) out.row(v) = (turn * rest.row(v).transpose() + centre_at(t)).transpose();
  };
}

// The moving sphere of radius 0.2 m as a mesh: its triangles, motion and spec.
struct MovingSphere {
  Points rest;
  Triangles tris;
  ColliderSpec spec;
  SurfaceMotion motion;
  MovingSphere(int rings, int segments) {
    uv_sphere(0.2, rings, segments, rest, tris);
    spec.shape = ColliderShape::kMesh;
    spec.thickness = 0.004;
    spec.friction = 0.3;
    motion = sphere_motion(rest);
  }
  std::unique_ptr<Collider> make() const { return make_mesh_collider(spec, tris, motion, true); }
};

double brute_distance(const Vec3& p, const Points& x, const Triangles& t) {
  double best = std::numeric_limits<double>::infinity();
  for (Eigen::Index f = 0; f < t.rows(); ++f)
    best = std::min(best, closest_point_triangle(p, x.row(t(f, 0)).transpose(), x.row(t(f, 1)).transpose(),
                                                 x.row(t(f, 2)).transpose())
                              .distance);
  return best;
}

// Forwards everything to a collider that was never told the nodes' count, so it keeps no bounds.
class Unbounded : public Collider {
 public:
  explicit Unbounded(std::unique_ptr<Collider> inner) : Collider(inner->spec()), inner_(std::move(inner)) {}
  void prepare(double t0, double t1) override { inner_->prepare(t0, t1); }
  bool closest(const Vec3& p, double reach, bool end, int node, SurfacePoint& out) const override {
    return inner_->closest(p, reach, end, node, out);
  }
  double step_motion() const override { return inner_->step_motion(); }
  const AabbTree* end_tree() const override { return inner_->end_tree(); }
  const AabbTree* swept_tree() const override { return inner_->swept_tree(); }
  const Points* end_vertices() const override { return inner_->end_vertices(); }
  const Points* start_vertices() const override { return inner_->start_vertices(); }
  Vec3 end_vertex_normal(int v) const override { return inner_->end_vertex_normal(v); }
  const std::vector<std::array<int, 3>>* triangle_list() const override { return inner_->triangle_list(); }
  void surface(double t, Points& positions, Triangles& triangles) const override {
    inner_->surface(t, positions, triangles);
  }

 private:
  std::unique_ptr<Collider> inner_;
};

void expect_same(const SurfacePoint& a, const SurfacePoint& b) {
  EXPECT_EQ(a.distance, b.distance);
  EXPECT_EQ(a.normal, b.normal);
  EXPECT_EQ(a.point, b.point);
  EXPECT_EQ(a.displacement, b.displacement);
}

}  // namespace

TEST(DistanceBounds, AreNeverAboveTheDistanceAndChangeNoAnswerOfAMovingMeshCollider) {
  const MovingSphere sphere(16, 24);
  const Triangles& tris = sphere.tris;
  const SurfaceMotion& motion = sphere.motion;
  auto bounded = sphere.make();
  auto plain = sphere.make();
  constexpr int kNodes = 60;
  bounded->reserve_nodes(kNodes);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(-1, 1);
  // Nodes from just inside the surface to 15 cm off it, each wandering up to 3 mm a step while
  // following the sphere.
  std::vector<Vec3> node(kNodes);
  for (auto& p : node) {
    Vec3 d(unit(rng), unit(rng), unit(rng));
    p = d.normalized() * (0.19 + 0.16 * (0.5 + 0.5 * unit(rng)));
  }
  const double dt = 0.005;
  long queries = 0, ruled_out = 0;
  Points x;
  auto check = [&](double t0, double t1) {
    for (int q = 0; q < 2; ++q) {
      const bool end = q == 1;
      motion(end ? t1 : t0, x);
      for (int i = 0; i < kNodes; ++i) {
        const double reach = 0.008 + 0.012 * (0.5 + 0.5 * unit(rng));
        const double bound = bounded->distance_bound(node[i], i, end);
        const double distance = brute_distance(node[i], x, tris);
        ASSERT_LE(bound, distance) << "node " << i << " at t = " << t0;
        SurfacePoint a, b;
        const bool found_a = bounded->closest(node[i], reach, end, i, a);
        const bool found_b = plain->closest(node[i], reach, end, i, b);
        ASSERT_EQ(found_a, found_b) << "node " << i << " at t = " << t0;
        EXPECT_EQ(found_a, distance <= reach);
        if (found_a) expect_same(a, b);
        ++queries;
        if (bound > reach) ++ruled_out;
      }
    }
  };
  for (int k = 0; k < 200; ++k) {
    const double t0 = k * dt, t1 = t0 + dt;
    bool retried = false;
    if (k % 50 == 49) {
      // A step first tried as a half (it follows the last step's end, so the bounds stand),
      // then prepared whole: its end is not the half's, so every bound is void until measured
      // again.
      bounded->prepare(t0, t0 + 0.5 * dt);
      plain->prepare(t0, t0 + 0.5 * dt);
      check(t0, t0 + 0.5 * dt);
      retried = true;
    }
    bounded->prepare(t0, t1);
    plain->prepare(t0, t1);
    if (retried)
      for (int i = 0; i < kNodes; ++i) EXPECT_EQ(bounded->distance_bound(node[i], i, false), 0.0);
    check(t0, t1);
    for (auto& p : node) p += 0.003 * Vec3(unit(rng), unit(rng), unit(rng)) / std::sqrt(3.0) + centre_at(t1) - centre_at(t0);
  }
  // The bounds rule out a good share of the queries (half the nodes are more than 7 cm off).
  EXPECT_GT(ruled_out, queries / 5) << ruled_out << " of " << queries;
}

TEST(DistanceBounds, ContactHandlingOnAMovingMeshColliderIsTheSameWithThem) {
  // A 16 x 16 sheet (4 cm cells) dropped onto the moving sphere, stepped by hand: detection,
  // the end-of-step detection and the fail-safe (nodes, faces over the sphere's vertices,
  // edges across its edges) against a collider with bounds and one without give the same
  // contacts, positions and velocities in every step.
  const MovingSphere sphere(12, 16);
  auto bounded = sphere.make();
  Unbounded plain(sphere.make());
  constexpr int n = 16;
  const int nodes = n * n;
  VecX x(3 * nodes), v = VecX::Zero(3 * nodes), mass = VecX::Constant(nodes, 1e-3);
  std::vector<std::array<int, 3>> faces;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      node(x, i * n + j) = Vec3(-0.3 + 0.04 * j, 0.22, -0.3 + 0.04 * i);
      if (i + 1 < n && j + 1 < n) {
        faces.push_back({i * n + j, i * n + j + 1, (i + 1) * n + j + 1});
        faces.push_back({i * n + j, (i + 1) * n + j + 1, (i + 1) * n + j});
      }
    }
  const std::vector<char> fixed(nodes, 0);
  ColliderContacts with({bounded.get()}, mass, fixed, faces);
  ColliderContacts without({&plain}, mass, fixed, faces);
  const double dt = 0.005;
  const Vec3 g(0, -9.81, 0);
  long held = 0, moved = 0;
  for (int k = 0; k < 120; ++k) {
    const double t = k * dt;
    std::vector<NodeContact> a, b;
    with.detect(x, v, t, dt, a);
    without.detect(x, v, t, dt, b);
    ASSERT_EQ(a.size(), b.size()) << "step " << k;
    for (size_t c = 0; c < a.size(); ++c) {
      EXPECT_EQ(a[c].node, b[c].node);
      EXPECT_EQ(a[c].normal, b[c].normal);
      EXPECT_EQ(a[c].normal_displacement, b[c].normal_displacement);
    }
    held += static_cast<long>(a.size());
    // A crude step: free fall, the held nodes moved by their prescribed displacement.
    VecX v1 = v;
    for (int i = 0; i < nodes; ++i) node(v1, i) += dt * g;
    VecX x1 = x + dt * v1;
    for (const NodeContact& c : a) {
      const Vec3 d = node(x1, c.node) - node(x, c.node);
      node(x1, c.node) += (c.normal_displacement - d.dot(c.normal)) * c.normal;
    }
    std::vector<char> is_held(nodes, 0);
    for (const NodeContact& c : a) is_held[c.node] = 1;
    std::vector<NodeContact> ea, eb;
    with.detect_end(x, x1, t, dt, is_held, ea);
    without.detect_end(x, x1, t, dt, is_held, eb);
    ASSERT_EQ(ea.size(), eb.size()) << "step " << k;
    for (size_t c = 0; c < ea.size(); ++c) EXPECT_EQ(ea[c].normal_displacement, eb[c].normal_displacement);
    VecX xa = x1, va = v1, xb = x1, vb = v1;
    ContactReport ra, rb;
    with.finish_step(x, xa, va, t, dt, ra);
    without.finish_step(x, xb, vb, t, dt, rb);
    ASSERT_EQ(ra.fail_safe_moves, rb.fail_safe_moves) << "step " << k;
    ASSERT_TRUE(xa == xb && va == vb) << "step " << k;
    moved += ra.fail_safe_moves;
    x = xa;
    v = va;
  }
  // The sheet reached the sphere: contacts were held and the fail-safe moved nodes.
  EXPECT_GT(held, 0);
  EXPECT_GT(moved, 0);
}
