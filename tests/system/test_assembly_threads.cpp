// The step assembly runs on every thread allowed (docs/performance.md, "Threads"): its nodes in
// pieces, its membranes in pieces of ClothSystem::kMembranePiece triangles, grouped so that no
// two pieces of a group share a vertex. The pieces and their order do not depend on the thread
// count, so neither do the bits: forces, K w, every block of the step matrix and the energies.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <random>
#include <set>

#include "sim/simulation_core.hpp"
#include "support/cloth_step_problem.hpp"
#include "system/cloth.hpp"
#include "weft/material.hpp"
#include "weft/threads.hpp"

using namespace weft;

namespace {

// The benchmark's n x n cloth written as an OBJ whose faces come in a random order, so that
// the pieces of consecutive triangles are scattered over the cloth and share vertices with
// many others (the grouping cannot be a grid's two alternating rows).
Scene shuffled_cloth_scene(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<std::array<int, 3>> faces;
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      faces.push_back({a, b, d});
      faces.push_back({a, d, c});
    }
  std::shuffle(faces.begin(), faces.end(), rng);
  // One file per test (ctest runs tests in parallel, and each removes its file at the end).
  const std::string test_name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("weft_shuffled_" + test_name + "_" + std::to_string(seed) + ".obj"))
                               .string();
  std::ofstream out(path);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) out << "v " << double(i) / (n - 1) << " 1 " << double(j) / (n - 1) << "\n";
  for (const auto& f : faces) out << "f " << f[0] + 1 << " " << f[1] + 1 << " " << f[2] + 1 << "\n";
  out.close();
  return test::cloth_step_scene_from_obj(n, path, {0, n - 1});
}

struct Assembled {
  VecX force, stiffness_times_w;
  std::vector<Mat3> blocks;
  double elastic = 0, gravity = 0, power = 0;
};

// Lets the cloth fall for 0.05 s and assembles the next step, on `threads` threads.
Assembled assemble_on(const Scene& scene, int threads) {
  set_thread_count(threads);
  test::ClothStepProblem p;
  test::make_cloth_step_problem(scene, 0.05, p);
  set_thread_count(0);
  Assembled a;
  a.force = p.step.force;
  a.stiffness_times_w = p.step.stiffness_times_w;
  a.blocks.assign(p.step.matrix.block.begin(), p.step.matrix.block.end());
  a.elastic = p.step.elastic_energy;
  a.gravity = p.step.gravity_energy;
  a.power = p.step.viscous_power;
  return a;
}

void expect_same_bits_on_one_thread_and_on_two(const Scene& scene, const std::string& what) {
  SCOPED_TRACE(what);
  const Assembled one = assemble_on(scene, 1), two = assemble_on(scene, 2);
  EXPECT_TRUE(one.force == two.force);
  EXPECT_TRUE(one.stiffness_times_w == two.stiffness_times_w);
  ASSERT_EQ(one.blocks.size(), two.blocks.size());
  size_t differing = 0;
  for (size_t k = 0; k < one.blocks.size(); ++k) differing += one.blocks[k] == two.blocks[k] ? 0 : 1;
  EXPECT_EQ(differing, 0u);
  EXPECT_EQ(one.elastic, two.elastic);
  EXPECT_EQ(one.gravity, two.gravity);
  EXPECT_EQ(one.power, two.power);
  EXPECT_GT(one.elastic, 0.0) << "the cloth must be deformed";
}

// The pieces cover the triangles the four-wide pass takes exactly once, each a multiple of 4
// of at most kMembranePiece, and no two pieces of a group share a vertex.
void expect_a_valid_partition(const Scene& scene, const std::string& what, size_t* groups = nullptr) {
  SCOPED_TRACE(what);
  Simulation sim(scene);
  const auto& system = dynamic_cast<const ClothSystem&>(sim.core().system());
  const auto& c = system.constants();
  const auto& triangles = sim.core().model().mesh.triangles;
  const size_t count = triangles.size(), batched = count - count % 4;
  std::vector<int> covered(count, 0);
  for (const auto& [begin, end] : c.membrane_pieces) {
    EXPECT_EQ(begin % 4, 0);
    EXPECT_EQ((end - begin) % 4, 0);
    EXPECT_LE(end - begin, ClothSystem::kMembranePiece);
    for (int t = begin; t < end; ++t) ++covered[t];
  }
  for (size_t t = 0; t < count; ++t) EXPECT_EQ(covered[t], t < batched ? 1 : 0) << "triangle " << t;
  ASSERT_GE(c.membrane_groups.size(), 2u);
  EXPECT_EQ(c.membrane_groups.front(), 0);
  EXPECT_EQ(c.membrane_groups.back(), static_cast<int>(c.membrane_pieces.size()));
  for (size_t g = 0; g + 1 < c.membrane_groups.size(); ++g) {
    std::set<int> seen;
    for (int k = c.membrane_groups[g]; k < c.membrane_groups[g + 1]; ++k) {
      std::set<int> mine;
      for (int t = c.membrane_pieces[k].first; t < c.membrane_pieces[k].second; ++t)
        for (int i : triangles[t]) mine.insert(i);
      for (int i : mine) EXPECT_EQ(seen.count(i), 0u) << "group " << g << ", vertex " << i;
      seen.insert(mine.begin(), mine.end());
    }
  }
  if (groups) *groups = c.membrane_groups.size() - 1;
}

}  // namespace

TEST(AssemblyThreads, LinearClothIsTheSameBitsOnOneThreadAndOnTwo) {
  expect_same_bits_on_one_thread_and_on_two(test::cloth_step_scene(65), "65 x 65, four-wide pass");
}

TEST(AssemblyThreads, StiffeningClothWithLeftOverTrianglesIsTheSameBitsOnOneThreadAndOnTwo) {
  Scene s = test::cloth_step_scene(34);  // 2,178 triangles: 2 after the last batch of four
  s.cloth.material = material_preset("cotton");
  expect_same_bits_on_one_thread_and_on_two(s, "34 x 34 cotton, one triangle at a time");
}

TEST(AssemblyThreads, ShuffledMeshIsTheSameBitsOnOneThreadAndOnTwo) {
  const Scene s = shuffled_cloth_scene(33, 5);
  expect_same_bits_on_one_thread_and_on_two(s, "33 x 33, faces in random order");
  std::filesystem::remove(s.cloth.obj_path);
}

TEST(AssemblyThreads, PiecesOfAGroupShareNoVertex) {
  size_t grid_groups = 0, shuffled_groups = 0;
  expect_a_valid_partition(test::cloth_step_scene(65), "65 x 65", &grid_groups);
  expect_a_valid_partition(test::cloth_step_scene(34), "34 x 34");
  const Scene s = shuffled_cloth_scene(33, 5);
  expect_a_valid_partition(s, "shuffled", &shuffled_groups);
  std::filesystem::remove(s.cloth.obj_path);
  // A grid's triangles come row by row: a piece of 256 triangles spans two rows of the 65 x 65
  // grid and touches only its neighbouring pieces, so two groups take them all.
  EXPECT_EQ(grid_groups, 2u);
  EXPECT_GT(shuffled_groups, 2u);
}

TEST(AssemblyThreads, ARunIsTheSameBitsOnOneThreadAndOnTwo) {
  Scene s = test::cloth_step_scene(33);
  s.cloth.material = material_preset("cotton");
  auto run = [&](int threads) {
    set_thread_count(threads);
    Simulation sim(s);
    sim.advance_to(0.2);
    set_thread_count(0);
    return std::make_pair(sim.core().state().x, sim.core().state().v);
  };
  const auto one = run(1), two = run(2);
  EXPECT_TRUE(one.first == two.first);
  EXPECT_TRUE(one.second == two.second);
}
