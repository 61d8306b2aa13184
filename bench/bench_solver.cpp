// Linear solve of one Implicit Midpoint step of the benchmark cloth (bench_step.cpp: 1 m,
// pinned at two corners, dt = 5 ms) at 33x33, 65x65, 129x129 and (multigrid and SSOR)
// 257x257 vertices, with PCG and the block-Jacobi, aggregation-multigrid or SSOR
// preconditioner (the second argument: SSOR's relaxation times 10, 0 for the automatic
// choice), relative tolerance 1e-6, warm started from the previous step's dv as the
// integrator does. The time per iteration
// is one whole solve_pcg call (including the per-matrix multigrid update or SSOR copy).
// Counters: CG iterations; for multigrid the setup, update and one V-cycle in milliseconds,
// the number of levels and the nodes and blocks of each coarse level.
// SsorLowerSolve<T>: one triangular solve of the SSOR operator alone, per node, in double
// precision (four lanes) and in single precision (eight lanes, the default).
// StepPart/<n>/<part>: the default solve's parts alone, each repeated on data that stays in
// the caches as far as it fits: 0 the single-precision SSOR copy of the step matrix
// (SsorOperatorT<float>::assign, the values only), 1 the double-precision product of the true
// residual (BlockMatrix::multiply), 2 one single-precision CG iteration (the upper solve with
// the new direction, the lower solve with the curvature, the residual update). With
// `Assemble` (bench_assembly.cpp) they give a floor for a step: what it would take if every
// part ran as fast as it does alone.
//   build-native/weft_bench --benchmark_filter='Solve/' --benchmark_repetitions=3
//   build-native/weft_bench --benchmark_filter='StepPart|Assemble' --benchmark_repetitions=5
#include <benchmark/benchmark.h>

#include <chrono>
#include <map>
#include <memory>

#include "linalg/pcg.hpp"
#include "support/cloth_step_problem.hpp"
#include "sim/simulation_core.hpp"

using namespace weft;

namespace {

// The step system the integrator solves (tests/support/cloth_step_problem.hpp), after the
// cloth has moved for 0.05 s; built once per size.
const test::ClothStepProblem& problem(int n) {
  static std::map<int, std::unique_ptr<test::ClothStepProblem>> cache;
  auto& slot = cache[n];
  if (!slot) {
    slot = std::make_unique<test::ClothStepProblem>();
    test::make_cloth_step_problem(n, 0.05, *slot);
  }
  return *slot;
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void Solve(benchmark::State& bs, Preconditioner pc) {
  const int n = static_cast<int>(bs.range(0));
  const test::ClothStepProblem& p = problem(n);
  const auto& fixed = p.sim->core().system().pinned();
  PcgSettings settings;
  settings.relative_tolerance = 1e-6;
  settings.preconditioner = pc;
  if (pc == Preconditioner::kSsor) settings.ssor_omega = bs.range(1) / 10.0;  // 0: automatic
  PcgWorkspace ws;
  VecX x = p.guess;
  PcgResult r = solve_pcg(p.step.matrix, p.rhs, fixed, settings, x, ws);  // warm-up, setup
  for (auto _ : bs) {
    x = p.guess;
    r = solve_pcg(p.step.matrix, p.rhs, fixed, settings, x, ws);
    benchmark::DoNotOptimize(x.data());
  }
  bs.counters["cg_iterations"] = r.iterations;
  bs.counters["converged"] = r.converged;
  if (pc == Preconditioner::kMultigrid) {
    AggregationMultigrid mg;
    const int reps = 5;
    auto t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < reps; ++k) mg.setup(p.step.matrix, fixed, settings.multigrid);
    bs.counters["setup_ms"] = ms_since(t0) / reps;
    t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < reps; ++k) mg.update(p.step.matrix);
    bs.counters["update_ms"] = ms_since(t0) / reps;
    VecX z;
    t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < reps; ++k) mg.apply(p.rhs, z);
    bs.counters["vcycle_ms"] = ms_since(t0) / reps;
    bs.counters["levels"] = mg.num_levels();
    for (int l = 1; l < mg.num_levels(); ++l)
      bs.counters["blocks_L" + std::to_string(l)] = mg.coarse_matrix(l).block.size();
    for (int l = 1; l < mg.num_levels(); ++l)
      bs.counters["nodes_L" + std::to_string(l)] = mg.level_nodes(l);
  }
  bs.SetLabel(pc == Preconditioner::kMultigrid ? "multigrid" : pc == Preconditioner::kSsor ? "ssor" : "block-jacobi");
}

}  // namespace

BENCHMARK_CAPTURE(Solve, BlockJacobi, Preconditioner::kBlockJacobi)
    ->Arg(33)->Arg(65)->Arg(129)->Unit(benchmark::kMillisecond)->MinTime(0.5);
BENCHMARK_CAPTURE(Solve, Multigrid, Preconditioner::kMultigrid)
    ->Arg(33)->Arg(65)->Arg(129)->Arg(257)->Unit(benchmark::kMillisecond)->MinTime(0.5);
BENCHMARK_CAPTURE(Solve, Ssor, Preconditioner::kSsor)
    ->ArgsProduct({{33, 65, 129, 257}, {0, 12, 14, 16}})->Unit(benchmark::kMillisecond)->MinTime(0.5);

namespace {
template <class T>
void SsorLowerSolve(benchmark::State& bs) {
  const test::ClothStepProblem& p = problem(static_cast<int>(bs.range(0)));
  SsorOperatorT<T> S;
  S.assign(p.step.matrix, p.sim->core().system().pinned(), 1.4);
  typename SsorOperatorT<T>::Vector v4, y4(S.vector_size());
  S.pad(p.rhs, v4);
  for (auto _ : bs) {
    S.solve_lower(v4.data(), y4.data());
    benchmark::DoNotOptimize(y4.data());
  }
  bs.counters["ns_per_node"] = benchmark::Counter(
      S.num_nodes(), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

void StepPart(benchmark::State& bs) {
  const int n = static_cast<int>(bs.range(0)), part = static_cast<int>(bs.range(1));
  const test::ClothStepProblem& p = problem(n);
  const auto& fixed = p.sim->core().system().pinned();
  const std::vector<int>* order = p.sim->core().system().solver_order();
  int free_nodes = 0;
  for (char f : fixed) free_nodes += !f;
  const double omega = ssor_relaxation_for(free_nodes), cp = omega - 1.0, cu = 2.0 - omega;
  SsorOperatorT<float> S;
  S.assign(p.step.matrix, fixed, omega, order);
  Eigen::VectorXf r, z, d, q, t, w, dx;
  S.pad(p.rhs, r);
  z = d = q = t = w = r;
  dx.setZero(r.size());
  VecX y(p.rhs.size());
  double rz = 0, sink = 0;
  for (auto _ : bs) {
    if (part == 0) {
      S.assign(p.step.matrix, fixed, omega, order);
    } else if (part == 1) {
      p.step.matrix.multiply(p.guess, y);
      benchmark::DoNotOptimize(y.data());
    } else {
      // Tiny steps along the directions keep the vectors' values (and their timing) steady.
      S.step_and_solve_upper(z.data(), 0.5, d.data(), t.data(), w.data(), cp, cu, dx.data(), 0.0);
      sink += S.solve_lower_dot(w.data(), q.data(), d.data(), t.data());
      sink += S.update(1e-12, t.data(), q.data(), r.data(), 1.0 / omega, z.data(), rz);
    }
  }
  benchmark::DoNotOptimize(sink);
  bs.SetLabel(part == 0 ? "ssor copy" : part == 1 ? "product" : "cg iteration");
}
}  // namespace
BENCHMARK(StepPart)
    ->ArgsProduct({{33, 65, 129}, {0, 1, 2}})->ArgNames({"n", "part"})->Unit(benchmark::kMicrosecond);
BENCHMARK(SsorLowerSolve<double>)->Arg(33)->Arg(65)->Arg(129)->Unit(benchmark::kMicrosecond);
BENCHMARK(SsorLowerSolve<float>)->Arg(33)->Arg(65)->Arg(129)->Unit(benchmark::kMicrosecond);
