// Time per step of a 1 m x 1 m cloth pinned at two corners, at 33x33, 65x65 and 129x129
// vertices, Implicit Midpoint and backward Euler at dt = 5 ms, one thread; arguments:
// vertices per side, conjugate-gradient tolerance 10^-t, preconditioner (0 block-Jacobi,
// 1 multigrid, 2 SSOR).
// Counters: CG iterations per step, assembly and solve milliseconds per step, and memory
// (process peak resident set, and the bytes of the step's matrices and vectors).
// Run one configuration per process for a clean peak-memory figure, e.g.
//   build/weft_bench --benchmark_filter='Step/ImplicitMidpoint/33'
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <cmath>

#include "support/cloth_step_problem.hpp"
#include "weft/simulation.hpp"

using namespace weft;

namespace {

Scene bench_scene(int n, const std::string& method, int tolerance_exponent, int preconditioner) {
  // The cloth of the solver tests and benchmarks (tests/support/cloth_step_problem.hpp): the
  // default scene's cotton-like linear material.
  Scene s = test::cloth_step_scene(n);
  set_method(s, method, std::nullopt, "benchmark");
  s.integrator.cg_tolerance = std::pow(10.0, -tolerance_exponent);
  s.integrator.preconditioner = preconditioner == 2   ? Preconditioner::kSsor
                                : preconditioner == 1 ? Preconditioner::kMultigrid
                                                      : Preconditioner::kBlockJacobi;
  return s;
}

void Step(benchmark::State& bs, const std::string& method) {
  const int n = static_cast<int>(bs.range(0));
  const int tolerance_exponent = static_cast<int>(bs.range(1));
  const int preconditioner = static_cast<int>(bs.range(2));
  Simulation sim(bench_scene(n, method, tolerance_exponent, preconditioner));
  // Let the cloth start moving so the measured steps are representative.
  sim.advance_to(0.05);
  StepStatistics stats;
  for (auto _ : bs) sim.integrator().step(sim.state(), sim.scene().integrator.dt, stats);
  const double per = 1.0 / std::max(1L, stats.steps);
  bs.counters["cg_iterations"] = stats.cg_iterations * per;
  bs.counters["assembly_ms"] = 1e3 * stats.assembly_seconds * per;
  bs.counters["solve_ms"] = 1e3 * stats.solve_seconds * per;
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  bs.counters["peak_rss_MB"] = ru.ru_maxrss / 1024.0;
  const double blocks = sim.model().pattern.num_blocks();
  bs.counters["matrix_MB"] = 3 * blocks * sizeof(Mat3) / 1e6;  // K, D and the step matrix
  bs.counters["vertices"] = n * n;
  bs.counters["tolerance"] = sim.scene().integrator.cg_tolerance;
  bs.counters["preconditioner"] = preconditioner;
  bs.SetLabel(method + " " + preconditioner_name(sim.integrator().preconditioner()));
}

}  // namespace

BENCHMARK_CAPTURE(Step, ImplicitMidpoint, std::string("implicit-midpoint"))
    ->ArgsProduct({{33, 65, 129}, {6, 4}, {0, 1, 2}})
    ->ArgNames({"n", "tol", "pc"})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(1.0);
BENCHMARK_CAPTURE(Step, BackwardEuler, std::string("backward-euler"))
    ->ArgsProduct({{33, 65, 129}, {6}, {0, 1, 2}})
    ->ArgNames({"n", "tol", "pc"})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(1.0);
