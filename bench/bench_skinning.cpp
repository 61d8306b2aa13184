// Skinning the 13,380-vertex mannequin for one frame of the walk: linear blend and dual quaternion,
// on one thread and on two.
#include <benchmark/benchmark.h>

#include "weft/body.hpp"
#include "weft/threads.hpp"

namespace {

const weft::WalkingBody& body() {
  static const weft::WalkingBody walking{weft::BodyColliderSpec{}};
  return walking;
}

template <void (*Skin)(const weft::Points&, const weft::SkinWeights&,
                       const std::vector<weft::BonePose>&, weft::Points&)>
void BM_Skin(benchmark::State& state) {
  weft::set_thread_count(static_cast<int>(state.range(0)));
  std::vector<weft::BonePose> poses;
  body().bone_poses(1.7, poses);
  weft::Points out;
  for (auto _ : state) {
    Skin(body().rest_positions(), body().weights(), poses, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * body().vertex_count());
  weft::set_thread_count(0);
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

BENCHMARK(BM_Skin<weft::skin_lbs>)->Name("SkinLBS")->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Skin<weft::skin_dqs>)->Name("SkinDQS")->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BonePoses)->Name("BonePosesWalk")->Unit(benchmark::kMicrosecond);
