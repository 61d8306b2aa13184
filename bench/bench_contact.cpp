// Time per step with contacts, one thread, split into detection, response (constraints,
// friction, fail-safe), assembly and solve:
// - SphereDrop: the scene of scenes/sphere-drop.json (a 1 m square of cotton dropped onto a
//   sphere of radius 0.3 m on the floor, BDF-2 at dt = 5 ms) at n x n vertices, timed over the
//   100 steps from t = 0.3 s, when the cloth is folding over the sphere (about 800 of the 4225
//   vertices of 65x65 in contact);
// - SphereDropFree: the same cloth over the same steps with no colliders (falling freely),
//   the step's cost without contacts for the ratio;
// - BodyDrape: scenes/body-drape.json (a 1.2 m square over the shoulders of the mannequin in
//   its T-pose, which then walks), timed over the 100 steps from t = 0.3 s, while the body
//   still stands in its bind pose;
// - BodyDrapeWalking: the same scene timed over the 100 steps from t = 1.6 s, the body walking.
// - FreeSheet: the cloth of the free-step benchmarks (a 1 m square hanging from two corners,
//   Implicit Midpoint at dt = 5 ms, no collider), timed over the 100 steps from t = 0.3 s;
//   self: 0 self-collision off, 1 on (the default), 2 on with its culling off, 3 on with culling
//   that keeps no regions from one search to the next. It never touches
//   itself: the ratio of 1 to 0 is what looking for self-contact costs a sheet that has none.
// - WalkSegment: scenes/walk.json (the coat on the walking mannequin, Implicit Midpoint at
//   5 ms), the 20 steps from t = from: 0.2 s (the coat settling on the standing body) or 1.6 s
//   (walking), resumed from a checkpoint the first run leaves in the system's temporary folder
//   (weft-bench-walk-<from>-<fingerprint>.ckpt; delete it to take it anew); cull: the
//   self-collision culling off (0) or on (1); bounds: contacts held by the active set's
//   filters (0) or as bounds in one bounded solve (1, ContactSolve::kBounds; its own cached
//   checkpoint, the walk taken there with bounds).
// SphereDrop's bounds: likewise.
// Counters are per step: milliseconds of detection, response, assembly and solve, CG
// iterations, solves, and node contacts held.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>

#include "collision/self_contact.hpp"
#include "sim/model_data.hpp"
#include "sim/simulation_core.hpp"
#include "support/cloth_step_problem.hpp"
#include "weft/error.hpp"
#include "weft/threads.hpp"

using namespace weft;

namespace {

constexpr int kSteps = 100;

Scene sphere_drop(int n, bool colliders) {
  Scene s;
  s.duration = 3.0;
  s.frame_interval = 0.02;
  set_method(s, "bdf2", std::nullopt, "benchmark");
  s.integrator.dt = 0.005;
  s.cloth.grid = GridSpec{1.0, 1.0, n, n};
  s.cloth.rotation_deg = Vec3(-90, 0, 0);
  s.cloth.translation = Vec3(-0.5, 0.8, 0.5);
  s.cloth.material = material_preset("cotton");
  s.cloth.self_collision = false;
  if (colliders) {
    ColliderSpec sphere;
    sphere.shape = ColliderShape::kSphere;
    sphere.centre = Vec3(0, 0.3, 0);
    sphere.radius = 0.3;
    sphere.thickness = 0.003;
    sphere.friction = 0.3;
    ColliderSpec floor;
    floor.shape = ColliderShape::kPlane;
    floor.thickness = 0.003;
    floor.friction = 0.5;
    s.colliders = {sphere, floor};
  }
  return s;
}

Scene body_drape(int n) {
  Scene s = sphere_drop(n, false);
  s.cloth.grid = GridSpec{1.2, 1.2, n, n};
  s.cloth.translation = Vec3(-0.6, 0.95, 0.6);
  BodyColliderSpec body;
  body.bind_pose_hold = 1.0;
  body.blend = 0.5;
  s.bodies = {body};
  ColliderSpec c;
  c.shape = ColliderShape::kBody;
  c.body = 0;
  c.thickness = 0.004;
  c.friction = 0.5;
  ColliderSpec floor;
  floor.shape = ColliderShape::kPlane;
  floor.point = Vec3(0, -0.8622, 0);
  floor.friction = 0.5;
  s.colliders = {c, floor};
  return s;
}

// The timed steps of sim (its scene's dt), with their split per step as counters.
StepStatistics time_steps(benchmark::State& bs, Simulation& sim) {
  StepStatistics stats;
  for (auto _ : bs) sim.core().integrator().step(sim.core().state(), sim.scene().integrator.dt, stats);
  const double per = 1.0 / std::max(1L, stats.steps);
  bs.counters["detection_ms"] = 1e3 * stats.detection_seconds * per;
  bs.counters["response_ms"] = 1e3 * stats.response_seconds * per;
  bs.counters["assembly_ms"] = 1e3 * stats.assembly_seconds * per;
  bs.counters["solve_ms"] = 1e3 * stats.solve_seconds * per;
  bs.counters["cg_iterations"] = stats.cg_iterations * per;
  bs.counters["solves"] = stats.cg_solves * per;
  bs.counters["passes"] = stats.contact_passes * per;    // the active set's further solves
  bs.counters["released"] = stats.released_contacts * per;
  return stats;
}

void run(benchmark::State& bs, const Scene& scene, double from = 0.3, bool culling = true, bool keep_regions = true) {
  set_thread_count(1);  // the targets are for one thread
  Simulation sim(scene);
  if (SelfContacts* self = sim.core().simulation_data().self_contacts.get()) self->set_culling(culling, keep_regions);
  sim.advance_to(from);
  const StepStatistics stats = time_steps(bs, sim);
  const double per = 1.0 / std::max(1L, stats.steps);
  bs.counters["contacts"] = stats.contacts * per;
  bs.counters["vertices"] = sim.core().model().num_vertices();
  if (const SelfContacts* self = sim.core().self_contacts(); self && culling) {
    // The share of the triangles the searches passed over (over the whole run, the settling
    // included), and contours checked per search.
    const SelfCullingStatistics& c = self->culling_statistics();
    const double offered = static_cast<double>(c.calls) * static_cast<double>(sim.core().model().mesh.triangles.size());
    bs.counters["culled_share"] = offered > 0 ? c.triangles_culled / offered : 0.0;
    bs.counters["contours_per_search"] = c.calls ? static_cast<double>(c.contour_checks) / c.calls : 0.0;
    bs.counters["kept_share"] = c.calls ? static_cast<double>(c.reused) / c.calls : 0.0;
  }
}

void SphereDrop(benchmark::State& bs) {
  Scene s = sphere_drop(static_cast<int>(bs.range(0)), true);
  s.integrator.preconditioner = Preconditioner::kSsor;  // pc 1
  if (bs.range(1) == 2) s.integrator.preconditioner = Preconditioner::kMultigrid;  // pc 2
  if (bs.range(2) == 1) s.integrator.contact_solve = ContactSolve::kBounds;
  run(bs, s);
}
void SphereDropFree(benchmark::State& bs) { run(bs, sphere_drop(static_cast<int>(bs.range(0)), false)); }
void BodyDrape(benchmark::State& bs) { run(bs, body_drape(static_cast<int>(bs.range(0)))); }
void BodyDrapeWalking(benchmark::State& bs) { run(bs, body_drape(static_cast<int>(bs.range(0))), 1.6); }
// The walk scene at `from` seconds: restored from the cached checkpoint, or run there (and
// cached). A cached checkpoint that no longer reads (an older format) is taken anew, from a
// simulation built again since the failed restore may have changed part of it.
std::unique_ptr<Simulation> walk_to(const Scene& scene, double from) {
  auto sim = std::make_unique<Simulation>(scene);
  char name[96];
  std::snprintf(name, sizeof name, "weft-bench-walk-%.3f-%016llx.ckpt", from,
                static_cast<unsigned long long>(sim->fingerprint()));
  const std::filesystem::path path = std::filesystem::temp_directory_path() / name;
  if (std::ifstream in{path, std::ios::binary}) {
    std::stringstream bytes;
    bytes << in.rdbuf();
    try {
      restore_checkpoint(bytes.str(), path.string(), *sim);
      return sim;
    } catch (const InputError&) {
      sim = std::make_unique<Simulation>(scene);
    }
  }
  sim->advance_to(from);
  const std::string bytes = checkpoint_bytes(nlohmann::json::object(), *sim, RunResult{});
  const std::filesystem::path partial = path.string() + ".part";
  std::ofstream(partial, std::ios::binary) << bytes;
  std::filesystem::rename(partial, path);
  return sim;
}

void WalkSegment(benchmark::State& bs) {
  set_thread_count(1);
  Scene scene = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/walk.json");
  if (bs.range(2) == 1) scene.integrator.contact_solve = ContactSolve::kBounds;
  const std::unique_ptr<Simulation> owned = walk_to(scene, bs.range(0) / 10.0);
  Simulation& sim = *owned;
  sim.core().simulation_data().self_contacts->set_culling(bs.range(1) != 0);
  const double self_before = sim.core().self_contacts()->statistics().seconds;
  const StepStatistics stats = time_steps(bs, sim);
  const double per = 1.0 / std::max(1L, stats.steps);
  bs.counters["guard_ms"] = 1e3 * stats.guard_seconds * per;
  bs.counters["parts"] = stats.guard_parts * per;
  // the fail-safe's share of the response (SelfContactStatistics::seconds)
  bs.counters["self_fail_safe_ms"] = 1e3 * (sim.core().self_contacts()->statistics().seconds - self_before) * per;
}

void FreeSheet(benchmark::State& bs) {
  Scene s = test::cloth_step_scene(static_cast<int>(bs.range(0)));
  s.cloth.self_collision = bs.range(1) != 0;
  run(bs, s, 0.3, bs.range(1) != 2, bs.range(1) != 3);
}

}  // namespace

BENCHMARK(SphereDrop)
    ->Args({65, 1, 0})->Args({65, 2, 0})->Args({65, 1, 1})->Args({129, 1, 0})->Args({129, 2, 0})->Args({129, 1, 1})
    ->ArgNames({"n", "pc", "bounds"})->Unit(benchmark::kMillisecond)->Iterations(kSteps);
BENCHMARK(SphereDropFree)->Arg(65)->Arg(129)->ArgName("n")->Unit(benchmark::kMillisecond)->Iterations(kSteps);
BENCHMARK(BodyDrape)->Arg(65)->ArgName("n")->Unit(benchmark::kMillisecond)->Iterations(kSteps);
BENCHMARK(BodyDrapeWalking)->Arg(65)->ArgName("n")->Unit(benchmark::kMillisecond)->Iterations(kSteps);
BENCHMARK(WalkSegment)
    ->Args({2, 0, 0})->Args({2, 1, 0})->Args({2, 1, 1})->Args({16, 0, 0})->Args({16, 1, 0})->Args({16, 1, 1})
    ->ArgNames({"from_ds", "cull", "bounds"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(20);
BENCHMARK(FreeSheet)
    ->ArgsProduct({{33, 65, 129}, {0, 1, 2, 3}})
    ->ArgNames({"n", "self"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(kSteps);
