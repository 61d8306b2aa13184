// Panel meshing (mesh/panel_mesher.hpp) at the garment's target edge of 1.5 cm: one square
// metre, and a coat's worth of panels (8 star-shaped panels of about 0.16 m^2, about 13,000
// triangles in all).
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "mesh/panel_mesher.hpp"
#include "mesh/test_panel_mesher_shapes.hpp"

namespace {

using namespace weft;

void BM_PanelMeshSquareMetre(benchmark::State& state) {
  const PanelMeshOptions options;
  const PanelOutline square{
      test::sampled_polygon({{0, 0}, {1, 0}, {1, 1}, {0, 1}}, options.target_edge_m), {}};
  size_t triangles = 0;
  for (auto _ : state) {
    const PanelMesh mesh = mesh_panel(square, options);
    triangles = mesh.triangles.size();
    benchmark::DoNotOptimize(mesh.vertices.data());
  }
  state.counters["triangles"] = static_cast<double>(triangles);
}
BENCHMARK(BM_PanelMeshSquareMetre)->Unit(benchmark::kMillisecond);

void BM_PanelMeshCoat(benchmark::State& state) {
  const PanelMeshOptions options;
  std::vector<PanelOutline> panels;
  for (unsigned seed = 1; seed <= 8; ++seed) {
    std::mt19937 rng(seed);
    panels.push_back(
        {test::random_star(rng, std::sqrt(0.16 / test::kPanelPi), options.target_edge_m), {}});
  }
  size_t triangles = 0;
  for (auto _ : state) {
    triangles = 0;
    for (const PanelOutline& panel : panels)
      triangles += mesh_panel(panel, options).triangles.size();
  }
  state.counters["triangles"] = static_cast<double>(triangles);
}
BENCHMARK(BM_PanelMeshCoat)->Unit(benchmark::kMillisecond);

}  // namespace
