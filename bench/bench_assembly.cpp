#include <benchmark/benchmark.h>

#include "support/cloth_step_problem.hpp"
#include "weft/threads.hpp"

using namespace weft;

namespace {

// One Implicit Midpoint step's assembly alone, on one thread and on two (forces, K w and the step matrix) on the
// benchmark cloth, at the state reached after 0.05 s, repeated on that state.
void Assemble(benchmark::State& bs) {
  const int n = static_cast<int>(bs.range(0));
  set_thread_count(static_cast<int>(bs.range(1)));
  test::ClothStepProblem p;
  test::make_cloth_step_problem(n, 0.05, p);
  State& st = p.sim->core().state();
  System& sys = p.sim->core().system();
  const VecX w = p.sim->scene().integrator.dt * st.v;
  for (auto _ : bs) {
    sys.assemble_step(st.x, st.v, w, p.step);
    benchmark::DoNotOptimize(p.step.matrix.block.data());
  }
  const double triangles = static_cast<double>(p.sim->core().model().mesh.triangles.size());
  bs.counters["triangles"] = triangles;
  // Seconds per triangle (printed with an SI prefix, e.g. 85n).
  bs.counters["per_triangle"] =
      benchmark::Counter(triangles, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  set_thread_count(0);
}

}  // namespace

BENCHMARK(Assemble)
    ->ArgsProduct({{33, 65, 129}, {1, 2}})
    ->ArgNames({"n", "threads"})
    ->Unit(benchmark::kMicrosecond);
