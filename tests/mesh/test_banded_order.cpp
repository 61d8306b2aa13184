// banded_order (mesh/mesh.hpp): rows across the pattern whatever the vertex numbering, and
// the SSOR solves that start from it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <numeric>
#include <random>

#include "mesh/mesh.hpp"
#include "sim/simulation_core.hpp"

namespace weft {
namespace {

// The grid with its vertices renumbered by `perm` (new index of old vertex i is perm[i]).
TriMesh renumbered(const TriMesh& m, const std::vector<int>& perm) {
  TriMesh r = m;
  for (int i = 0; i < m.num_vertices(); ++i) {
    r.positions.row(perm[i]) = m.positions.row(i);
    r.pattern[perm[i]] = m.pattern[i];
  }
  for (auto& t : r.triangles)
    for (int& v : t) v = perm[v];
  return r;
}

std::vector<int> shuffled(int n, unsigned seed) {
  std::vector<int> p(n);
  std::iota(p.begin(), p.end(), 0);
  std::mt19937 rng(seed);
  std::shuffle(p.begin(), p.end(), rng);
  return p;
}

TEST(BandedOrder, IsTheGridsNumberingAndUndoesAScrambledOne) {
  for (GridPattern pattern : {GridPattern::kAlternatingDiagonals, GridPattern::kShiftedRows}) {
    const TriMesh grid = make_grid(0.6, 0.4, 13, 9, pattern);
    std::vector<int> identity(grid.num_vertices());
    std::iota(identity.begin(), identity.end(), 0);
    EXPECT_EQ(banded_order(grid), identity);
    // Scrambled: the order visits the same pattern points in the same sequence.
    const TriMesh scrambled = renumbered(grid, shuffled(grid.num_vertices(), 3));
    const std::vector<int> order = banded_order(scrambled);
    ASSERT_EQ(order.size(), identity.size());
    for (int k = 0; k < grid.num_vertices(); ++k)
      EXPECT_EQ(scrambled.pattern[order[k]], grid.pattern[k]) << k;
  }
}

// Separate pieces come one after the other (by their lowest vertex index), each in its own
// rows even where their patterns overlap.
TEST(BandedOrder, TakesPiecesOneAfterTheOther) {
  const TriMesh a = make_grid(0.3, 0.3, 4, 4);
  TriMesh two = a;
  const int n = a.num_vertices();
  two.positions.conservativeResize(2 * n, 3);
  two.positions.bottomRows(n) = a.positions;
  for (int i = 0; i < n; ++i) two.pattern.push_back(a.pattern[i] + Vec2(0.01, 0.0));  // overlapping
  for (auto t : a.triangles) two.triangles.push_back({t[0] + n, t[1] + n, t[2] + n});
  // Interleave the two pieces' numbering: piece membership alternates with the index.
  std::vector<int> perm(2 * n);
  for (int i = 0; i < n; ++i) perm[i] = 2 * i, perm[n + i] = 2 * i + 1;
  const TriMesh mixed = renumbered(two, perm);
  const std::vector<int> order = banded_order(mixed);
  for (int k = 0; k < n; ++k) {
    EXPECT_EQ(order[k] % 2, 0) << "piece of vertex 0 first";
    EXPECT_EQ(order[n + k] % 2, 1);
  }
}

// Writes the grid as an OBJ with texture coordinates (metres) in the given numbering.
std::string write_grid_obj(const TriMesh& m, const std::string& path) {
  std::ofstream f(path);
  for (int i = 0; i < m.num_vertices(); ++i)
    f << "v " << m.positions(i, 0) << ' ' << m.positions(i, 1) << ' ' << m.positions(i, 2) << '\n';
  for (int i = 0; i < m.num_vertices(); ++i) f << "vt " << m.pattern[i].x() << ' ' << m.pattern[i].y() << '\n';
  for (const auto& t : m.triangles)
    f << "f " << t[0] + 1 << '/' << t[0] + 1 << ' ' << t[1] + 1 << '/' << t[1] + 1 << ' ' << t[2] + 1 << '/'
      << t[2] + 1 << '\n';
  return path;
}

// The SSOR solves take the nodes in the model's banded order, so a scrambled OBJ numbering
// costs no extra iterations. (Taken in the scrambled numbering, SSOR needs about twice the
// iterations: docs/performance.md.)
TEST(BandedOrder, ScrambledObjNumberingSolvesInTheSameIterations) {
  const auto dir = std::filesystem::temp_directory_path() / "weft_banded_order";
  std::filesystem::create_directories(dir);
  const TriMesh grid = make_grid(1.0, 1.0, 33, 33);
  const std::vector<int> perm = shuffled(grid.num_vertices(), 7);
  double iterations[2];
  for (int k = 0; k < 2; ++k) {
    const TriMesh m = k == 0 ? grid : renumbered(grid, perm);
    Scene s;
    s.duration = 0.1;
    s.frame_interval = 0.005;
    s.cloth.obj_path = write_grid_obj(m, (dir / (k == 0 ? "grid.obj" : "scrambled.obj")).string());
    s.cloth.rotation_deg = Vec3(-90, 0, 0);
    s.cloth.pin_vertices = {k == 0 ? 0 : perm[0], k == 0 ? 32 : perm[32]};  // the same two corners
    s.cloth.material.surface_density_kg_m2 = 0.15;
    s.cloth.material.weft = StressCurve::linear(100);
    s.cloth.material.warp = StressCurve::linear(100);
    s.cloth.material.shear = StressCurve::linear(10);
    set_method(s, "implicit-midpoint", std::nullopt, "test");
    s.integrator.dt = 0.005;
    s.integrator.preconditioner = Preconditioner::kSsor;
    Simulation sim(s);
    sim.advance_to(0.1);
    iterations[k] = static_cast<double>(sim.core().statistics().cg_iterations) / sim.core().statistics().cg_solves;
  }
  EXPECT_LE(iterations[1], 1.1 * iterations[0]) << "natural " << iterations[0] << ", scrambled " << iterations[1];
  EXPECT_GE(iterations[1], 0.9 * iterations[0]) << "natural " << iterations[0] << ", scrambled " << iterations[1];
}

}  // namespace
}  // namespace weft
