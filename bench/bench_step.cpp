// Time per step of a 1 m x 1 m cloth pinned at two corners, at 33x33, 65x65 and 129x129
// vertices, Implicit Midpoint and backward Euler at dt = 5 ms, one thread (the last argument;
// two for the default configuration too), over the same
// 200 steps (1 s of motion from t = 0.05 s) in every configuration, so that sizes, methods
// and preconditioners are compared on the same motion (the iterations a step needs vary
// through the motion by a third); arguments:
// vertices per side, conjugate-gradient tolerance 10^-t, preconditioner (0 block-Jacobi,
// 1 multigrid, 2 SSOR in single precision, the default; 3 SSOR in double precision,
// Implicit Midpoint at 1e-6 only).
// WarmStart: Implicit Midpoint with SSOR at 1e-6, the solves' warm start combining the
// last h steps' solutions (h = 0: the previous dv alone), over the same steps; run with
// --benchmark_enable_random_interleaving=true to spread the host's drifts over both.
// Counters: CG iterations per step, assembly and solve milliseconds per step, and memory:
// the heap the configuration's simulation holds after its steps (model, matrices, solver
// workspace: the bytes allocated and not freed since just before it was built), the
// process's peak resident set while the configuration ran (freed memory is handed back to
// the system and the peak reset before each configuration, where Linux allows; it includes
// the process's own baseline, a few MB), and the bytes of the step's block matrix.
#include <benchmark/benchmark.h>
#include <malloc.h>
#include <sys/resource.h>

#include <cmath>
#include <fstream>
#include <string>

#include "support/cloth_step_problem.hpp"
#include "sim/simulation_core.hpp"
#include "weft/threads.hpp"

using namespace weft;

namespace {

// Steps timed per configuration (each from a fresh simulation at t = 0.05 s).
constexpr int kSteps = 200;

// A field of /proc/self/status in MB ("VmRSS", "VmHWM"); -1 where unavailable.
double status_MB(const std::string& field) {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(field + ":", 0) == 0) return std::stod(line.substr(field.size() + 1)) / 1024.0;
  return -1;
}

// Bytes allocated from the heap and not yet freed (glibc).
double heap_MB() {
  const struct mallinfo2 mi = mallinfo2();
  return static_cast<double>(mi.uordblks + mi.hblkhd) / 1e6;
}

// Resets the process's peak resident set to the current one (Linux: writing 5 to
// /proc/self/clear_refs); false where that is not possible.
bool reset_peak_rss() {
  std::ofstream out("/proc/self/clear_refs");
  out << "5";
  out.close();
  return static_cast<bool>(out);
}

Scene bench_scene(int n, const std::string& method, int tolerance_exponent, int preconditioner) {
  // The cloth of the solver tests and benchmarks (tests/support/cloth_step_problem.hpp): the
  // default scene's cotton-like linear material.
  Scene s = test::cloth_step_scene(n);
  set_method(s, method, std::nullopt, "benchmark");
  s.integrator.cg_tolerance = std::pow(10.0, -tolerance_exponent);
  s.integrator.preconditioner = preconditioner >= 2   ? Preconditioner::kSsor
                                : preconditioner == 1 ? Preconditioner::kMultigrid
                                                      : Preconditioner::kBlockJacobi;
  s.integrator.ssor_single_precision = preconditioner != 3;  // 3: SSOR in double precision
  return s;
}

void Step(benchmark::State& bs, const std::string& method) {
  const int n = static_cast<int>(bs.range(0));
  const int tolerance_exponent = static_cast<int>(bs.range(1));
  const int preconditioner = static_cast<int>(bs.range(2));
  set_thread_count(bs.range(3));
  malloc_trim(0);  // hand back what earlier configurations freed, so the peak is this one's
  const bool peak_reset = reset_peak_rss();
  const double heap_before = heap_MB();
  Simulation sim(bench_scene(n, method, tolerance_exponent, preconditioner));
  // Let the cloth start moving so the measured steps are representative.
  sim.advance_to(0.05);
  StepStatistics stats;
  for (auto _ : bs) sim.core().integrator().step(sim.core().state(), sim.scene().integrator.dt, stats);
  const double per = 1.0 / std::max(1L, stats.steps);
  bs.counters["cg_iterations"] = stats.cg_iterations * per;
  bs.counters["assembly_ms"] = 1e3 * stats.assembly_seconds * per;
  bs.counters["solve_ms"] = 1e3 * stats.solve_seconds * per;
  double peak = status_MB("VmHWM");
  if (!peak_reset || peak < 0) {  // no per-configuration peak here: the process's (cumulative)
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    peak = ru.ru_maxrss / 1024.0;
  }
  bs.counters["peak_rss_MB"] = peak;
  bs.counters["heap_MB"] = heap_MB() - heap_before;
  const double blocks = sim.core().model().pattern.num_blocks();
  bs.counters["matrix_MB"] = blocks * sizeof(Mat3) / 1e6;  // the step matrix (K and D are fused into it)
  bs.counters["vertices"] = n * n;
  bs.counters["tolerance"] = sim.scene().integrator.cg_tolerance;
  bs.counters["preconditioner"] = preconditioner;
  bs.counters["threads"] = static_cast<double>(bs.range(3));
  bs.SetLabel(method + " " + preconditioner_name(sim.core().integrator().preconditioner()));
  set_thread_count(0);
}

void WarmStart(benchmark::State& bs) {
  const int n = static_cast<int>(bs.range(0));
  set_thread_count(1);
  Scene scene = bench_scene(n, "implicit-midpoint", 6, 2);
  scene.integrator.warm_start_history = static_cast<int>(bs.range(1));
  Simulation sim(scene);
  sim.advance_to(0.05);
  StepStatistics stats;
  for (auto _ : bs) sim.core().integrator().step(sim.core().state(), scene.integrator.dt, stats);
  const double per = 1.0 / std::max(1L, stats.steps);
  bs.counters["cg_iterations"] = stats.cg_iterations * per;
  bs.counters["assembly_ms"] = 1e3 * stats.assembly_seconds * per;
  bs.counters["solve_ms"] = 1e3 * stats.solve_seconds * per;
  set_thread_count(0);
}

}  // namespace

BENCHMARK(WarmStart)
    ->ArgsProduct({{33, 65, 129}, {0, 3}})
    ->ArgNames({"n", "history"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(kSteps);
BENCHMARK_CAPTURE(Step, ImplicitMidpoint, std::string("implicit-midpoint"))
    ->ArgsProduct({{33, 65, 129}, {6, 4}, {0, 1, 2}, {1}})
    ->ArgNames({"n", "tol", "pc", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(kSteps);
BENCHMARK_CAPTURE(Step, ImplicitMidpoint, std::string("implicit-midpoint"))
    ->ArgsProduct({{33, 65, 129}, {6}, {3}, {1}})
    ->ArgNames({"n", "tol", "pc", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(kSteps);
BENCHMARK_CAPTURE(Step, BackwardEuler, std::string("backward-euler"))
    ->ArgsProduct({{33, 65, 129}, {6}, {0, 1, 2}, {1}})
    ->ArgNames({"n", "tol", "pc", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(kSteps);
// The default configuration (SSOR in single precision at 1e-6) on one thread and on two: the
// assembly runs on every thread allowed (docs/performance.md, "Threads").
BENCHMARK_CAPTURE(Step, ImplicitMidpoint, std::string("implicit-midpoint"))
    ->ArgsProduct({{33, 65, 129}, {6}, {2}, {2}})
    ->ArgNames({"n", "tol", "pc", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(kSteps);
BENCHMARK_CAPTURE(Step, BackwardEuler, std::string("backward-euler"))
    ->ArgsProduct({{33, 65, 129}, {6}, {2}, {2}})
    ->ArgNames({"n", "tol", "pc", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(kSteps);
