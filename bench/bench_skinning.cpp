// Skinning the 13,380-vertex mannequin for one frame of the walk: linear blend and dual quaternion.
#include <benchmark/benchmark.h>

#include "weft/body.hpp"

namespace {

const weft::WalkingBody& body() {
  static const weft::WalkingBody walking{weft::BodyColliderSpec{}};
  return walking;
}

template <void (*Skin)(const weft::Points&, const weft::SkinWeights&,
                       const std::vector<weft::BonePose>&, weft::Points&)>
void BM_Skin(benchmark::State& state) {
  std::vector<weft::BonePose> poses;
  body().bone_poses(1.7, poses);
  weft::Points out;
  for (auto _ : state) {
    Skin(body().rest_positions(), body().weights(), poses, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * body().vertex_count());
}

void BM_BonePoses(benchmark::State& state) {
  std::vector<weft::BonePose> poses;
  double t = 0;
  for (auto _ : state) {
    body().bone_poses(t, poses);
    benchmark::DoNotOptimize(poses.data());
    t = t > 3.9 ? 0 : t + 0.01;
  }
}

}  // namespace

BENCHMARK(BM_Skin<weft::skin_lbs>)->Name("SkinLBS")->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Skin<weft::skin_dqs>)->Name("SkinDQS")->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BonePoses)->Name("BonePosesWalk")->Unit(benchmark::kMicrosecond);
