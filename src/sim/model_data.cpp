#include "sim/model_data.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <vector>

#include "collision/clamps.hpp"
#include "collision/cloth_contacts.hpp"
#include "collision/colliders.hpp"
#include "collision/self_contact.hpp"
#include "sim/checkpoint.hpp"
#include "weft/error.hpp"
#include "weft/garment/sewing.hpp"

namespace weft {

namespace {
/// How messages name the scene: its file, or "scene" for one made in code.
std::string scene_name(const Scene& scene) { return scene.file.empty() ? std::string("scene") : scene.file; }
// Shares of the set-up time by stage (the integrator and the energy reference take the rest).
constexpr double kSetupShareMesh = 0.2, kSetupShareModel = 0.6, kSetupShareSystem = 0.1;
/// The scene's garment: its pattern meshed, placed around the first body in its bind pose and
/// sewn (weft/garment/sewing.hpp), each panel in its material (the scene's cloth material unless
/// cloth.mesh.pattern.panels.NAME.material gives one); `materials` receives them per triangle.
TriMesh sew_scene_garment(const Scene& scene, const SetupProgress& on_setup, TriangleMaterials& materials) {
  const GarmentSpec& g = *scene.cloth.garment;
  const std::string where = scene_name(scene) + ": cloth.mesh.pattern";
  if (on_setup) on_setup("garment: meshing " + g.pattern_file, 0.0);
  const Pattern pattern = load_pattern(g.pattern_file);
  // The panels the scene names are the pattern's: checked here, where the pattern is read
  // (reading the scene reads none), before any meshing.
  check_scene_panels(scene, pattern);
  GarmentMeshOptions mesh_options;
  mesh_options.target_edge_m = g.edge_length_m;
  for (const auto& [name, degrees] : g.panel_grain_deg) mesh_options.grain_angle_rad[name] = degrees * M_PI / 180;
  const GarmentMesh garment = mesh_garment(pattern, mesh_options);
  const BindBody body = load_bind_body(scene.bodies.front(), 1.0);
  PlacementOptions placement;
  placement.clearance_m = g.clearance_m;
  placement.overrides = g.panels;
  const PlacedGarment placed = place_garment(pattern, garment, body, placement);
  SewingOptions sewing;
  sewing.material = scene.cloth.material;
  for (const Panel& panel : pattern.panels) {
    const auto own = g.panel_materials.find(panel.name);
    sewing.panel_materials.push_back(own == g.panel_materials.end() ? scene.cloth.material : own->second);
  }
  sewing.seam_stiffness_N_m = g.seam_stiffness_N_m;
  sewing.max_time_s = g.sewing_time_s;
  if (g.sewing_step_limit_m)
    sewing.max_step_motion_m = *g.sewing_step_limit_m > 0 ? *g.sewing_step_limit_m : std::numeric_limits<double>::infinity();
  if (on_setup) on_setup("garment: sewing " + std::to_string(pattern.stitches.size()) + " stitches", 0.0);
  // Progress every 0.1 s of simulated sewing (five intervals of 20 ms).
  int intervals = 0;
  SewnGarment sewn = sew_garment(placed, body, sewing, [&](double t, double gap) {
    if (!on_setup || ++intervals % 5 != 0) return;
    char note[128];
    std::snprintf(note, sizeof note, "garment: sewing: %.2f s simulated, largest seam gap %.2f mm", t, 1e3 * gap);
    on_setup(note, 0.0);
  });
  if (!sewn.sewn()) {
    const std::string message = where + ": " + unsewn_headline(pattern, sewn) + "\n" + unsewn_report(pattern, sewn);
    if (!g.allow_open_seams)
      throw SewingError(message + "The scene was not run. `weft garment " + g.pattern_file +
                        " --out DIR` writes the garment as far as it sews (DIR/garment_unsewn.obj) to look at; "
                        "cloth.mesh.pattern.allow_open_seams runs it as it is.");
    std::fprintf(stderr, "weft: warning: %s(cloth.mesh.pattern.allow_open_seams: the scene runs the garment as it is)\n",
                 message.c_str());
  }
  materials = {std::move(sewing.panel_materials), std::move(sewn.panel_of_triangle)};
  return std::move(sewn.mesh);
}

// The fastest a collider's surface or a clamped vertex moves over the scene's duration, as a
// sustained speed: the largest displacement of a surface vertex (or a clamped vertex) over
// kDrivingWindow seconds, sampled every 20 ms (at most kDrivingSamples samples; the whole
// duration where it is shorter than the window). A motion that jitters back and forth within
// the window (recorded motion's noise: the shipped walk's foot turns 38 degrees in one of its
// frames around 2 s, its toes moving at 10 m/s for a few milliseconds) does not set the scale;
// a collider or clamp moving steadily at v gives v. Sampled once per model, from the scene's
// motions (what every simulation of it starts with).
constexpr int kDrivingSamples = 400;
constexpr double kDrivingWindow = 0.1;
double driving_speed(const SimulationModel& M) {
  const Scene& scene = M.scene;
  const int samples = std::clamp(static_cast<int>(std::ceil(scene.duration / 0.02)), 1, kDrivingSamples);
  const double interval = scene.duration / samples;
  if (!(interval > 0)) return 0;
  const int window = std::clamp(static_cast<int>(std::lround(kDrivingWindow / interval)), 1, samples);
  const double span = window * interval;
  double fastest = 0;
  std::vector<Points> ring(window + 1);  // the surface at the last window + 1 samples
  for (size_t k = 0; k < scene.colliders.size(); ++k) {
    const ColliderSpec& c = scene.colliders[k];
    if (c.shape != ColliderShape::kBody && c.motion.kind == RigidMotion::Kind::kStatic) continue;
    std::unique_ptr<Collider> analytic;
    if (c.shape != ColliderShape::kBody && c.shape != ColliderShape::kMesh) analytic = make_analytic_collider(c);
    auto surface = [&](double t, Points& out) {  // as the collider's own surface(t)
      if (c.shape == ColliderShape::kBody) {
        M.bodies[c.body]->positions(t, out);
      } else if (c.shape == ColliderShape::kMesh) {
        const Eigen::Isometry3d T = c.motion.at(t);
        const Points& placed = M.collider_vertices[k];
        out.resize(placed.rows(), 3);
        for (Eigen::Index v = 0; v < placed.rows(); ++v) out.row(v) = (T * Vec3(placed.row(v))).transpose();
      } else {
        Triangles triangles;
        analytic->surface(t, out, triangles);
      }
    };
    for (int j = 0; j <= samples; ++j) {
      Points& now = ring[j % (window + 1)];
      surface(j * interval, now);
      if (j < window) continue;
      const Points& before = ring[(j - window) % (window + 1)];
      if (now.rows() > 0 && now.rows() == before.rows())
        fastest = std::max(fastest, (now - before).rowwise().norm().maxCoeff() / span);
    }
  }
  const VecX rest = M.cloth->initial_positions();
  for (size_t g = 0; g < M.clamp_groups.size(); ++g) {
    const RigidMotion& motion = scene.cloth.clamps[g].motion;
    for (int j = window; j <= samples; ++j) {
      const Eigen::Isometry3d now = motion.at(j * interval), before = motion.at((j - window) * interval);
      for (int i : M.clamp_groups[g]) {
        const Vec3 p = node(rest, i);
        fastest = std::max(fastest, (now * p - before * p).norm() / span);
      }
    }
  }
  return fastest;
}

}  // namespace

std::unique_ptr<SimulationModel> build_model(const Scene& scene, const SetupProgress& on_setup) {
  auto model = std::make_unique<SimulationModel>();
  SimulationModel& M = *model;
  M.scene = scene;
  // The fractions are roughly the stages' shares of a large grid's set-up (a 601x601 grid).
  auto stage = [&](const char* name, double fraction) {
    if (on_setup) on_setup(name, fraction);
  };
  stage("cloth mesh", 0.0);
  // One material for the whole cloth, unless a garment's panels or a mesh made in code give
  // one per triangle.
  TriangleMaterials materials{{scene.cloth.material}, {}};
  if (!scene.cloth.garment && !scene.cloth.triangle_materials.materials.empty())
    materials = scene.cloth.triangle_materials;
  TriMesh mesh =
      scene.cloth.garment ? sew_scene_garment(scene, on_setup, materials) : build_cloth_mesh(scene.cloth);
  // Problems found while building the model (a degenerate triangle, a bad pin) name the
  // scene and the mesh they come from.
  const std::string where = scene_name(scene) + ": cloth" +
                            (scene.cloth.obj_path.empty() ? std::string(" grid") : " mesh " + scene.cloth.obj_path);
  try {
    const std::vector<int> pins = resolve_pins(scene.cloth, mesh);
    M.clamp_groups = resolve_clamps(scene.cloth, mesh, pins);
    stage("model", kSetupShareMesh);
    M.cloth = std::make_unique<ClothModel>(build_cloth_model(std::move(mesh), materials, scene.gravity, pins,
                                                            parse_bending_model(scene.cloth.bending_model, "cloth.bending_model"),
                                                            scene.cloth.seams));
  } catch (const InputError& e) {
    throw InputError(where + ": " + e.what());
  }
  // RK45 steps adaptively: report its stiffness factors at the scene's (largest) step.
  DampingSettings damping{scene.effective_damping_ratio()};
  if (scene.integrator.method == Method::kRk45) damping.reference_dt = scene.integrator.dt;
  stage("element system", kSetupShareMesh + kSetupShareModel);
  M.system = ClothSystem::make_constants(*M.cloth, damping);
  stage("integrator", kSetupShareMesh + kSetupShareModel + kSetupShareSystem);
  {
    ClothSystem::Data scratch = ClothSystem::make_data(*M.cloth);
    const ClothSystem system(*M.cloth, M.system, scratch);
    M.integrator = Integrator::make_constants(system, scene.integrator);
  }
  for (size_t k = 0; k < scene.bodies.size(); ++k) {
    stage(("body " + std::to_string(k) + " (rig, motion, skinning)").c_str(), kSetupShareMesh + kSetupShareModel + kSetupShareSystem);
    M.bodies.push_back(std::make_unique<WalkingBody>(scene.bodies[k]));
  }
  // Mesh colliders' geometry as the scene places it (their motions move it).
  M.collider_triangles.resize(scene.colliders.size());
  M.collider_vertices.resize(scene.colliders.size());
  for (size_t k = 0; k < scene.colliders.size(); ++k) {
    const ColliderSpec& c = scene.colliders[k];
    if (c.shape != ColliderShape::kMesh) continue;
    const std::string where = scene_name(scene) + ": " + c.name;
    ObjMesh obj;
    try {
      obj = read_obj(c.obj_path);
    } catch (const InputError& e) {
      throw InputError(where + ": " + e.what());
    }
    if (obj.triangles.rows() == 0) throw InputError(where + ": " + c.obj_path + ": no faces (a mesh collider needs triangles)");
    const Mat3 R = rotation_from_degrees(c.rotation_deg);
    for (Eigen::Index v = 0; v < obj.positions.rows(); ++v)
      obj.positions.row(v) = (R * (c.scale * obj.positions.row(v).transpose()) + c.translation).transpose();
    M.collider_triangles[k] = std::move(obj.triangles);
    M.collider_vertices[k] = std::move(obj.positions);
  }
  // Clamped vertices follow their clamps whatever touches them: the colliders' and the
  // cloth's contact handling take them as pinned.
  M.held = M.cloth->pinned;
  for (const std::vector<int>& group : M.clamp_groups)
    for (int i : group) M.held[i] = 1;
  M.seam_groups = seam_groups(M.num_vertices(), scene.cloth.seams);
  M.driving_speed = driving_speed(M);
  stage("done", 1.0);
  return model;
}

SimulationData::~SimulationData() = default;

std::unique_ptr<SimulationData> make_data(const SimulationModel& M) {
  const Scene& scene = M.scene;
  const ClothModel& cloth = *M.cloth;
  auto data = std::make_unique<SimulationData>();
  SimulationData& D = *data;
  D.system = ClothSystem::make_data(cloth);
  ClothSystem system(cloth, M.system, D.system);
  D.integrator = Integrator::make_data(system, M.integrator);
  Integrator integrator(system, M.integrator, D.integrator);
  for (const ColliderSpec& c : scene.colliders) D.collider_motions.push_back(c.motion);
  for (size_t k = 0; k < scene.colliders.size(); ++k) {
    const ColliderSpec& c = scene.colliders[k];
    if (c.shape == ColliderShape::kBody) {
      const WalkingBody* body = M.bodies[c.body].get();
      D.colliders.push_back(make_mesh_collider(
          c, body->triangles(), [body](double t, Points& out) { body->positions(t, out); }, true));
    } else if (c.shape == ColliderShape::kMesh) {
      // The motion as the data holds it: move_collider may replace it between steps.
      const RigidMotion* motion = &D.collider_motions[k];
      const Points* placed = &M.collider_vertices[k];
      D.colliders.push_back(make_mesh_collider(
          c, M.collider_triangles[k],
          [placed, motion](double t, Points& out) {
            const Eigen::Isometry3d T = motion->at(t);
            out.resize(placed->rows(), 3);
            for (Eigen::Index v = 0; v < placed->rows(); ++v) out.row(v) = (T * Vec3(placed->row(v))).transpose();
          },
          c.closed));
    } else {
      D.colliders.push_back(make_analytic_collider(c));
    }
  }
  if (!M.clamp_groups.empty()) {
    std::vector<RigidMotion> motions;
    for (const ClampSpec& c : scene.cloth.clamps) motions.push_back(c.motion);
    D.clamps = std::make_unique<Clamps>(M.clamp_groups, std::move(motions), cloth.initial_positions(), cloth.mass);
  }
  ClothContacts contacts = add_cloth_contacts(
      integrator, D.colliders, cloth.mass, M.held, cloth.mesh.triangles, cloth.initial_positions(),
      {scene.cloth.self_collision, scene.cloth.thickness, scene.cloth.friction}, M.seam_groups);
  D.contacts = std::move(contacts.colliders);
  D.self_contacts = std::move(contacts.self);
  // The clamps last: their contacts join the others', and they put their vertices on their
  // paths after every other correction.
  if (D.clamps) integrator.add_contact_handler(D.clamps.get());
  State& s = D.state;
  s.x = cloth.initial_positions();
  s.v = VecX::Zero(s.x.size());
  for (int i = 0; i < cloth.num_vertices(); ++i)
    if (!cloth.pinned[i]) node(s.v, i) = scene.cloth.initial_velocity;
  for (size_t k = 0; k < M.clamp_groups.size(); ++k)
    for (int i : M.clamp_groups[k]) {
      node(s.x, i) = D.clamps->position(k, i, 0);
      node(s.v, i) = D.clamps->velocity(k, i, 0);
    }
  s.t = 0;
  set_energy_reference(M, D);
  // The scene's contact tunables (`contacts`), before the first step.
  if (D.contacts) D.contacts->set_tunables(scene.contacts);
  if (D.self_contacts) D.self_contacts->set_tunables(scene.contacts);
  return data;
}

namespace {
/// Sets the velocity of pinned vertex i (and its BDF-2 history, as if it had moved so before).
void set_pin_velocity(const SimulationModel& M, State& s, int i, const Vec3& v) {
  node(s.v, i) = v;
  // BDF-2 moves a node by beta dx_prev + dt_b v (with dv = 0 on a pin): a previous change of
  // dt v, beta dt + dt_b = dt, makes that dt v from the next step on.
  if (s.has_history) {
    node(s.dx_prev, i) = M.scene.integrator.dt * v;
    node(s.dv_prev, i).setZero();
  }
}
}  // namespace

void set_pin_velocity(const SimulationModel& M, SimulationData& D, int i, const Vec3& v) {
  set_pin_velocity(M, D.state, i, v);
}

namespace {
double kinetic_energy(const SimulationModel& M, const State& s) {
  const VecX& m = M.cloth->mass;
  double kinetic = 0;
  for (int i = 0; i < M.cloth->num_vertices(); ++i) kinetic += 0.5 * m[i] * node(s.v, i).squaredNorm();
  return kinetic;
}
}  // namespace

void advance(const SimulationModel& M, SimulationData& D, double t, bool stop_on_runaway) {
  ClothSystem system(*M.cloth, M.system, D.system);
  Integrator integrator(system, M.integrator, D.integrator);
  State& s = D.state;
  // While pins move: a step at a time (each arrival is on the step grid), each moving pin's
  // velocity set again after every step to reach its target at its arrival, so that a pin the
  // self-collision fail-safe held still for a step (an impact zone holding a pin stops) catches
  // up; pins that arrived are put on their targets and stopped.
  const double dt = M.scene.integrator.dt;
  const double slack = 1e-9 * dt;
  while (!D.pin_moves.empty() && s.t < t - slack) {
    double next = std::min(t, s.t + dt);
    for (const PinMove& m : D.pin_moves) next = std::min(next, m.arrival);
    integrator.advance(s, next, D.statistics);
    std::erase_if(D.pin_moves, [&](const PinMove& m) {
      if (m.arrival > s.t + slack) {
        set_pin_velocity(M, s, m.node, (m.target - node(s.x, m.node)) / (m.arrival - s.t));
        return false;
      }
      node(s.x, m.node) = m.target;
      set_pin_velocity(M, s, m.node, Vec3::Zero());
      return true;
    });
  }
  if (!stop_on_runaway || M.scene.integrator.method == Method::kRk45) {
    integrator.advance(s, t, D.statistics);
    return;
  }
  // A step at a time, looking at the energy after each: first the kinetic energy alone (one
  // pass over the velocities), and the whole balance only when that alone is past the limit
  // (a long free fall gains kinetic energy that its lost height balances).
  const double limit = M.scene.integrator.runaway_energy_factor * D.energy_scale;
  while (s.t < t - slack) {
    // The last step ends at t itself, as a single call to t would (the steps keep their own
    // clock either way).
    integrator.advance(s, std::lround((t - s.t) / dt) <= 1 ? t : s.t + dt, D.statistics);
    const double kinetic = kinetic_energy(M, s);
    if (!std::isfinite(kinetic)) return;
    if (kinetic - s.contact_work - D.total0 > limit) {
      const EnergyRow e = energies(M, D);
      if (!std::isfinite(e.total()) || e.total() - e.contact_work - D.total0 > limit) return;
    }
  }
}

void set_energy_reference(const SimulationModel& M, SimulationData& D) {
  const ClothModel& cloth = *M.cloth;
  const State& s = D.state;
  D.gravity0 = 0;
  D.total0 = 0;
  ClothSystem system(cloth, M.system, D.system);
  system.evaluate(s.x, s.v, false, D.eval);
  D.gravity0 = D.eval.gravity_energy;
  const EnergyRow e0 = energies(M, D);
  D.total0 = e0.total();
  Vec3 lo = node(s.x, 0), hi = lo;
  for (int i = 1; i < cloth.num_vertices(); ++i) {
    lo = lo.cwiseMin(node(s.x, i));
    hi = hi.cwiseMax(node(s.x, i));
  }
  // What the cloth has and may gain by falling across its size, or the kinetic energy it
  // would have moving with the fastest collider or clamp, whichever is larger (a scene without
  // gravity that a moving collider drives has no other scale).
  const double own = e0.kinetic + e0.elastic + cloth.mass.sum() * M.scene.gravity.norm() * (hi - lo).norm();
  const double driven = 0.5 * cloth.mass.sum() * M.driving_speed * M.driving_speed;
  D.energy_scale = std::max(own, driven) + 1e-12;
  D.integrator.energy_scale = D.energy_scale;
}

EnergyRow energies(const SimulationModel& M, SimulationData& D) {
  ClothSystem system(*M.cloth, M.system, D.system);
  const Integrator integrator(system, M.integrator, D.integrator);
  const State& state = D.state;
  system.evaluate(state.x, state.v, false, D.eval);
  EnergyRow r;
  r.time = state.t;
  r.kinetic = kinetic_energy(M, state);
  r.elastic = D.eval.elastic_energy;
  r.gravity = D.eval.gravity_energy - D.gravity0;
  r.viscous_dissipated = state.viscous_dissipated;
  r.contact_work = state.contact_work;
  r.fail_safe_work = state.fail_safe_work;
  r.numerical_dissipated = D.total0 + r.contact_work - r.total() - r.viscous_dissipated;
  if (M.scene.integrator.guard) {
    r.guard_parts = static_cast<double>(D.statistics.guard_parts);
    r.guard_alpha = integrator.guard_alpha();
  }
  return r;
}


namespace {
void put(BinaryWriter& out, const LogStatistics& s) {
  const LogStatistics::Snapshot snap = s.snapshot();
  out.u64(snap.bins.size());
  for (const auto& [bin, n] : snap.bins) {
    out.i64(bin);
    out.i64(n);
  }
  out.i64(snap.count);
  out.f64(snap.min);
  out.f64(snap.max);
  out.f64(snap.sum);
}

LogStatistics get_statistics(BinaryReader& in) {
  LogStatistics::Snapshot snap;
  const std::uint64_t bins = in.u64();
  for (std::uint64_t k = 0; k < bins; ++k) {
    const std::int64_t bin = in.i64();
    snap.bins.emplace_back(static_cast<int>(std::clamp<std::int64_t>(bin, -1, 1 << 30)), in.i64());
  }
  snap.count = in.i64();
  snap.min = in.f64();
  snap.max = in.f64();
  snap.sum = in.f64();
  try {
    return LogStatistics::from_snapshot(snap);
  } catch (const std::invalid_argument& e) {
    in.fail(std::string("checkpoint is damaged: ") + e.what());
  }
}

// The step statistics as WEFT_STEP_STATISTICS lists them: the counts, then the largest values,
// then the seconds, each kind in the list's order.
constexpr StatisticKind kStatisticKindsInCheckpoints[] = {StatisticKind::kCount, StatisticKind::kLargest,
                                                          StatisticKind::kSeconds};

void put(BinaryWriter& out, const StepStatistics& st) {
  for (const StatisticKind kind : kStatisticKindsInCheckpoints)
    for (const StepStatistic& s : kStepStatistics) {
      if (s.kind != kind) continue;
      if (s.count) {
        out.i64(st.*s.count);
      } else {
        out.f64(st.*s.value);
      }
    }
}

StepStatistics get_step_statistics(BinaryReader& in) {
  StepStatistics st;
  for (const StatisticKind kind : kStatisticKindsInCheckpoints)
    for (const StepStatistic& s : kStepStatistics) {
      if (s.kind != kind) continue;
      if (s.count) {
        st.*s.count = in.i64();
      } else {
        st.*s.value = in.f64();
      }
    }
  return st;
}

void put_vec3(BinaryWriter& out, const Vec3& v) { out.raw(v.data(), 3 * sizeof(double)); }

void put(BinaryWriter& out, const Points& p) { out.doubles(p.data(), static_cast<size_t>(p.size())); }

void put(BinaryWriter& out, const RigidMotion& m) {
  out.i64(static_cast<int>(m.kind));
  for (const Vec3* v : {&m.linear_velocity, &m.angular_velocity, &m.centre}) put_vec3(out, *v);
  out.u64(m.keys.size());
  for (const RigidMotion::Key& k : m.keys) {
    out.f64(k.time);
    put_vec3(out, k.translation);
    put_vec3(out, k.rotation_deg);
  }
}

void put(BinaryWriter& out, const StressCurve& c) {
  out.f64(c.modulus());
  out.doubles(c.strain_points().data(), c.strain_points().size());
  out.doubles(c.stress_points().data(), c.stress_points().size());
}

// The rest of what the motion depends on (checkpoint format 11): the elements' rest shapes and
// stencils (the pattern, uv_scale, the bending model, the seams), the materials' curves and
// coupling, the integrator's switches, every collider's settings and surface, and the bodies.
void put_motion_settings(BinaryWriter& w, const SimulationModel& M) {
  const ClothModel& cloth = *M.cloth;
  for (const auto& t : cloth.mesh.triangles) w.raw(t.data(), sizeof t);
  for (const MembraneGeometry& g : cloth.membranes) {
    put_vec3(w, g.ru);
    put_vec3(w, g.rv);
    w.f64(g.area);
  }
  for (const LinearBendingStencil& b : cloth.bending) {
    w.raw(b.vertices.data(), b.vertices.size() * sizeof(int));
    w.mat(b.measures);
    w.vec(b.weights);
  }
  for (const Material& m : cloth.materials) {
    w.f64(m.poisson_ratio);
    for (const StressCurve* c : {&m.weft, &m.warp, &m.shear}) put(w, *c);
  }
  const IntegratorSettings& is = M.integrator.settings;
  w.i64(is.halve_overshooting_solves);
  w.i64(is.guard_last_resort_newton);
  w.f64(is.newton_tolerance);  // the guard's and backward Euler's own iterations stop there too
  for (size_t k = 0; k < M.scene.colliders.size(); ++k) {
    const ColliderSpec& c = M.scene.colliders[k];
    w.i64(static_cast<int>(c.shape));
    for (double d : {c.thickness, c.friction, c.radius, c.edge_radius, c.scale}) w.f64(d);
    for (const Vec3* v : {&c.point, &c.normal, &c.centre, &c.end_a, &c.end_b, &c.half_extents, &c.rotation_deg,
                          &c.translation})
      put_vec3(w, *v);
    w.i64(c.closed);
    w.i64(c.body);
    put(w, c.motion);
    if (k < M.collider_vertices.size()) put(w, M.collider_vertices[k]);
    if (k < M.collider_triangles.size())
      w.raw(M.collider_triangles[k].data(), static_cast<size_t>(M.collider_triangles[k].size()) * sizeof(int));
  }
  for (size_t k = 0; k < M.scene.bodies.size(); ++k) {
    const BodyColliderSpec& b = M.scene.bodies[k];
    w.text(b.motion_file);
    w.text(b.skinning);
    for (double d : {b.speed, b.start_time, b.bind_pose_hold, b.blend, b.arm_spread_deg}) w.f64(d);
    // The motion file's content, as the body's surface at the start and the end.
    Points p;
    for (double t : {0.0, M.scene.duration}) {
      M.bodies[k]->positions(t, p);
      put(w, p);
    }
  }
}

// Vectors of the State are empty or 3n long.
VecX get_state_vector(BinaryReader& in, Eigen::Index size, const char* name, bool may_be_empty) {
  VecX v = in.vec();
  if (v.size() != size && !(may_be_empty && v.size() == 0))
    in.fail(std::string("checkpoint's ") + name + " has " + std::to_string(v.size()) + " values, the cloth " +
            std::to_string(size));
  return v;
}
}  // namespace

std::uint64_t fingerprint(const SimulationModel& M) {
  BinaryWriter w;
  const VecX x0 = M.cloth->initial_positions();
  w.vec(x0);
  w.vec(M.cloth->mass);
  w.raw(M.cloth->pinned.data(), M.cloth->pinned.size());
  w.u64(M.cloth->mesh.triangles.size());
  w.u64(M.cloth->bending.size());
  w.u64(static_cast<std::uint64_t>(M.cloth->pattern.num_blocks()));
  const IntegratorSettings& is = M.integrator.settings;
  w.i64(static_cast<int>(is.method));
  for (double d : {is.alpha, is.dt, is.cg_tolerance, is.error_tolerance, is.ssor_relaxation}) w.f64(d);
  w.i64(is.cg_max_iterations);
  w.i64(static_cast<int>(M.integrator.preconditioner));
  w.i64(is.ssor_single_precision);
  w.i64(is.warm_start_history);
  w.i64(is.guard);
  if (is.newton_iterations > 0) {  // (absent when off: fingerprints of older checkpoints hold)
    w.i64(is.newton_iterations);
    w.f64(is.newton_tolerance);
  }
  if (!is.backward_euler_newton) w.i64(-1);  // (likewise absent in the default)
  if (is.contact_solve != ContactSolve::kActiveSet) w.i64(-2 - static_cast<int>(is.contact_solve));  // (likewise)
  if (is.max_step_halvings != IntegratorSettings{}.max_step_halvings) {  // (likewise)
    w.i64(-5);
    w.i64(is.max_step_halvings);
  }
  // The contact tunables that change the motion (not fail_safe_energy_factor), likewise
  // absent at their defaults.
  const ContactSettings& cs = M.scene.contacts;
  const ContactSettings defaults;
  const std::vector<double> contact_tunables = {cs.hold_margin, cs.held_rest_speed, double(cs.self_passes),
                                                double(cs.self_zone_rounds), cs.self_repulsion_time,
                                                cs.self_hold_reach, cs.self_hold_reach_speed};
  const std::vector<double> contact_defaults = {
      defaults.hold_margin,         defaults.held_rest_speed, double(defaults.self_passes), double(defaults.self_zone_rounds),
      defaults.self_repulsion_time, defaults.self_hold_reach, defaults.self_hold_reach_speed};
  if (contact_tunables != contact_defaults) {
    w.i64(-6);
    for (double d : contact_tunables) w.f64(d);
  }
  w.f64(M.system.damping.damping_ratio);
  w.f64(M.system.damping.reference_dt);
  for (const Material& m : M.cloth->materials)
    for (double d : {m.viscosity_Ns_m, m.surface_density_kg_m2, m.bending_rigidity_weft_Nm, m.bending_rigidity_warp_Nm})
      w.f64(d);
  for (int k : M.cloth->triangle_material) w.i64(k);  // empty with one material
  for (double d : {M.scene.duration, M.scene.frame_interval}) w.f64(d);
  w.raw(M.scene.gravity.data(), 3 * sizeof(double));
  w.i64(M.scene.cloth.self_collision);
  for (double d : {M.scene.cloth.thickness, M.scene.cloth.friction}) w.f64(d);
  if (!M.clamp_groups.empty()) {
    std::vector<char> clamped(M.num_vertices(), 0);
    for (const std::vector<int>& group : M.clamp_groups)
      for (int i : group) clamped[i] = 1;
    for (char c : clamped) w.i64(c);
    for (const ClampSpec& c : M.scene.cloth.clamps)
      for (double t : {0.0, M.scene.duration}) w.raw(c.motion.at(t).matrix().data(), 16 * sizeof(double));
  }
  put_motion_settings(w, M);
  return fnv1a(w.bytes().data(), w.bytes().size());
}


void save_data(const SimulationModel& M, const SimulationData& D, BinaryWriter& out) {
  out.u64(fingerprint(M));
  const State& s = D.state;
  out.vec(s.x);
  out.vec(s.v);
  out.f64(s.t);
  out.vec(s.dx_prev);
  out.vec(s.dv_prev);
  out.i64(s.has_history);
  out.f64(s.viscous_dissipated);
  out.f64(s.contact_work);
  out.f64(s.fail_safe_work);
  out.f64(s.rk45_step);
  out.f64(s.step_clock);
  put(out, D.statistics);
  out.f64(D.gravity0);
  out.f64(D.total0);
  out.f64(D.energy_scale);

  const ClothSystem::Data& sys = D.system;
  out.doubles(sys.membrane_viscosity.front().data(), 3 * sys.membrane_viscosity.size());
  for (const LogStatistics* l : {&sys.statistics.membrane_kappa, &sys.statistics.membrane_lambda,
                                 &sys.statistics.bending_kappa, &sys.statistics.added_viscosity})
    put(out, *l);
  out.i64(sys.statistics.element_steps);
  out.i64(sys.statistics.raised_element_steps);

  const Integrator::Data& in = D.integrator;
  const SolutionHistory::Snapshot history = in.history.snapshot();
  out.i64(history.size);
  out.i64(history.next);
  out.mat(history.b);
  out.mat(history.x);
  out.mat(history.gram);
  for (double d : {in.history_alpha, in.history_beta, in.history_dt_b, in.history_t, in.pcg.ssor_residual_ratio}) out.f64(d);
  out.i64(in.pcg.ssor_single_fallbacks);
  out.doubles(in.multigrid_setup_blocks.empty() ? nullptr : in.multigrid_setup_blocks.front().data(),
              9 * in.multigrid_setup_blocks.size());
  for (const std::vector<char>* flags : {&in.pulling, &in.stuck}) {
    out.i64(static_cast<std::int64_t>(flags->size()));
    for (char c : *flags) out.i64(c);
  }
  for (int g : {in.guard_rung, in.guard_calm_steps, in.guard_depth, in.guard_depth_calm_steps}) out.i64(g);
  // The cloth-cloth fail-safe keeps nothing between steps but its counts (for summary.json).
  SelfContactStatistics self;
  if (D.self_contacts) self = D.self_contacts->statistics();
  for (const SelfContactStatistic& c : kSelfContactStatistics)
    if (c.count) out.i64(self.*c.count);
  for (const SelfContactStatistic& c : kSelfContactStatistics)
    if (c.value) out.f64(self.*c.value);
}


void restore_data(const SimulationModel& M, SimulationData& D, BinaryReader& in) {
  if (in.u64() != fingerprint(M))
    in.fail("checkpoint belongs to another cloth or other settings (the mesh, pins, materials, integrator, "
            "colliders or timing differ from the scene's)");
  const Eigen::Index size = 3 * M.cloth->num_vertices();
  State s;
  s.x = get_state_vector(in, size, "positions", false);
  s.v = get_state_vector(in, size, "velocities", false);
  s.t = in.f64();
  s.dx_prev = get_state_vector(in, size, "previous change of positions", true);
  s.dv_prev = get_state_vector(in, size, "previous change of velocities", true);
  s.has_history = in.i64() != 0;
  s.viscous_dissipated = in.f64();
  s.contact_work = in.f64();
  s.fail_safe_work = in.f64();
  s.rk45_step = in.f64();
  s.step_clock = in.f64();
  const StepStatistics st = get_step_statistics(in);
  const double gravity0 = in.f64(), total0 = in.f64(), energy_scale = in.f64();

  ClothSystem::Data sys;  // caches at their start; the viscosities and statistics read below
  const std::vector<double> eta = in.doubles();
  if (eta.size() != 3 * M.cloth->mesh.triangles.size())
    in.fail("checkpoint's viscosities are for " + std::to_string(eta.size() / 3) + " triangles, the cloth has " +
            std::to_string(M.cloth->mesh.triangles.size()));
  for (size_t t = 0; 3 * t < eta.size(); ++t) sys.membrane_viscosity.emplace_back(eta[3 * t], eta[3 * t + 1], eta[3 * t + 2]);
  for (LogStatistics* l : {&sys.statistics.membrane_kappa, &sys.statistics.membrane_lambda,
                           &sys.statistics.bending_kappa, &sys.statistics.added_viscosity})
    *l = get_statistics(in);
  sys.statistics.element_steps = in.i64();
  sys.statistics.raised_element_steps = in.i64();

  // The integrator's checkpointed part, checked against the model before D changes.
  Integrator::Data id = Integrator::make_data(ClothSystem(*M.cloth, M.system, sys), M.integrator);
  SolutionHistory::Snapshot history;
  history.size = static_cast<int>(in.i64());
  history.next = static_cast<int>(in.i64());
  history.b = in.mat();
  history.x = in.mat();
  history.gram = in.mat();
  for (double* d : {&id.history_alpha, &id.history_beta, &id.history_dt_b, &id.history_t, &id.pcg.ssor_residual_ratio})
    *d = in.f64();
  id.pcg.ssor_single_fallbacks = in.i64();
  const std::vector<double> blocks = in.doubles();
  if (blocks.size() % 9) in.fail("checkpoint is damaged (multigrid matrix of " + std::to_string(blocks.size()) + " values)");
  for (size_t b = 0; b < blocks.size(); b += 9) id.multigrid_setup_blocks.push_back(Eigen::Map<const Mat3>(&blocks[b]));
  for (std::vector<char>* flags : {&id.pulling, &id.stuck}) {
    const std::int64_t count = in.i64();
    if (count != 0 && count != M.cloth->num_vertices())
      in.fail("checkpoint is damaged (contact flags for " + std::to_string(count) + " nodes)");
    for (std::int64_t k = 0; k < count; ++k) flags->push_back(in.i64() != 0);
  }
  for (int* g : {&id.guard_rung, &id.guard_calm_steps, &id.guard_depth, &id.guard_depth_calm_steps})
    *g = static_cast<int>(in.i64());
  SelfContactStatistics self;
  for (const SelfContactStatistic& c : kSelfContactStatistics)
    if (c.count) self.*c.count = in.i64();
  for (const SelfContactStatistic& c : kSelfContactStatistics)
    if (c.value) self.*c.value = in.f64();
  id.energy_scale = energy_scale;
  try {
    id.history.restore(history);
    ClothSystem system(*M.cloth, M.system, sys);
    Integrator(system, M.integrator, id).restored();
  } catch (const std::invalid_argument& e) {
    in.fail(std::string("checkpoint does not fit the scene: ") + e.what());
  }
  // Into D: the handlers stay D's own.
  id.handlers = std::move(D.integrator.handlers);
  D.system = std::move(sys);
  D.integrator = std::move(id);
  D.state = std::move(s);
  D.statistics = st;
  D.gravity0 = gravity0;
  D.total0 = total0;
  D.energy_scale = energy_scale;
  if (D.self_contacts) D.self_contacts->set_statistics(self);
}

}  // namespace weft
