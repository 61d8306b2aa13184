#include "sim/simulation_core.hpp"

#include "collision/colliders.hpp"
#include "collision/clamps.hpp"
#include "collision/self_contact.hpp"
#include "weft/garment/sewing.hpp"
#include "sim/checkpoint.hpp"
#include "weft/error.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <sstream>

namespace weft {

namespace {
// Shares of the set-up time by stage (the integrator and the energy reference take the rest).
constexpr double kSetupShareMesh = 0.2, kSetupShareModel = 0.6, kSetupShareSystem = 0.1;
/// The scene's garment: its pattern meshed, placed around the first body in its bind pose and
/// sewn (weft/garment/sewing.hpp), each panel in its material (the scene's cloth material unless
/// cloth.mesh.pattern.panels.NAME.material gives one); `materials` receives them per triangle.
TriMesh sew_scene_garment(const Scene& scene, const SetupProgress& on_setup, TriangleMaterials& materials) {
  const GarmentSpec& g = *scene.cloth.garment;
  const std::string where = (scene.file.empty() ? std::string("scene") : scene.file) + ": cloth.mesh.pattern";
  if (on_setup) on_setup("garment: meshing " + g.pattern_file, 0.0);
  const Pattern pattern = load_pattern(g.pattern_file);
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
  if (on_setup) on_setup("garment: sewing", 0.0);
  SewnGarment sewn = sew_garment(placed, body, sewing);
  if (sewn.intersections.count() > 0)
    std::fprintf(stderr, "weft: warning: %s: the sewn garment starts with %zu intersecting triangle pairs\n",
                 where.c_str(), sewn.intersections.count());
  materials = {std::move(sewing.panel_materials), std::move(sewn.panel_of_triangle)};
  return std::move(sewn.mesh);
}

}  // namespace

SimulationCore::SimulationCore(const Scene& scene, const SetupProgress& on_setup) : scene_(scene) {
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
  const std::string where = (scene.file.empty() ? std::string("scene") : scene.file) + ": cloth" +
                            (scene.cloth.obj_path.empty() ? std::string(" grid") : " mesh " + scene.cloth.obj_path);
  std::vector<std::vector<int>> clamp_groups;
  try {
    const std::vector<int> pins = resolve_pins(scene.cloth, mesh);
    clamp_groups = resolve_clamps(scene.cloth, mesh, pins);
    stage("model", kSetupShareMesh);
    model_ = std::make_unique<ClothModel>(build_cloth_model(std::move(mesh), materials, scene.gravity, pins,
                                                            parse_bending_model(scene.cloth.bending_model, "cloth.bending_model"),
                                                            scene.cloth.seams));
  } catch (const InputError& e) {
    throw InputError(where + ": " + e.what());
  }
  // RK45 steps adaptively: report its stiffness factors at the scene's (largest) step.
  DampingSettings damping{scene.effective_damping_ratio()};
  if (scene.integrator.method == Method::Rk45) damping.reference_dt = scene.integrator.dt;
  stage("element system", kSetupShareMesh + kSetupShareModel);
  system_ = std::make_unique<ClothSystem>(*model_, damping);
  stage("integrator", kSetupShareMesh + kSetupShareModel + kSetupShareSystem);
  integrator_ = std::make_unique<Integrator>(*system_, scene.integrator);
  for (size_t k = 0; k < scene.bodies.size(); ++k) {
    stage(("body " + std::to_string(k) + " (rig, motion, skinning)").c_str(), kSetupShareMesh + kSetupShareModel + kSetupShareSystem);
    bodies_.push_back(std::make_unique<WalkingBody>(scene.bodies[k]));
  }
  for (const ColliderSpec& c : scene.colliders) {
    if (c.shape == ColliderShape::kBody) {
      const WalkingBody* body = bodies_[c.body].get();
      colliders_.push_back(make_mesh_collider(
          c, body->triangles(), [body](double t, Points& out) { body->positions(t, out); }, true));
    } else if (c.shape == ColliderShape::kMesh) {
      const std::string where = (scene.file.empty() ? std::string("scene") : scene.file) + ": " + c.name;
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
      // The motion as scene_ holds it: move_collider may replace it between steps.
      const RigidMotion* motion = &scene_.colliders[colliders_.size()].motion;
      colliders_.push_back(make_mesh_collider(
          c, obj.triangles,
          [placed = std::move(obj.positions), motion](double t, Points& out) {
            const Eigen::Isometry3d T = motion->at(t);
            out.resize(placed.rows(), 3);
            for (Eigen::Index v = 0; v < placed.rows(); ++v) out.row(v) = (T * Vec3(placed.row(v))).transpose();
          },
          c.closed));
    } else {
      colliders_.push_back(make_analytic_collider(c));
    }
  }
  // Clamped vertices follow their clamps whatever touches them: the colliders' and the
  // cloth's contact handling take them as pinned.
  std::vector<char> held_still = model_->fixed;
  if (!clamp_groups.empty()) {
    std::vector<RigidMotion> motions;
    for (const ClampSpec& c : scene.cloth.clamps) motions.push_back(c.motion);
    clamps_ = std::make_unique<Clamps>(clamp_groups, std::move(motions), model_->initial_positions(), model_->mass);
    for (size_t i = 0; i < held_still.size(); ++i) held_still[i] = held_still[i] || clamps_->clamped()[i];
  }
  if (!colliders_.empty()) {
    std::vector<Collider*> list;
    for (const auto& c : colliders_) list.push_back(c.get());
    contacts_ = std::make_unique<ColliderContacts>(std::move(list), model_->mass, held_still,
                                                   model_->mesh.triangles);
    integrator_->add_contact_handler(contacts_.get());
  }
  // Cloth-cloth contact after the colliders': its fail-safe sees their corrections.
  if (scene.cloth.self_collision) {
    self_contacts_ = std::make_unique<SelfContacts>(model_->mesh.triangles, model_->initial_positions(), model_->mass,
                                                    held_still, scene.cloth.thickness, scene.cloth.friction);
    if (contacts_) self_contacts_->set_held_nodes(&contacts_->touching());
    if (!scene.cloth.seams.empty()) {
      // The two sides of a seam are one point of the cloth to come: they do not push apart.
      std::vector<int> group(model_->num_vertices());
      std::iota(group.begin(), group.end(), 0);
      auto find = [&group](int i) {
        while (group[i] != i) i = group[i] = group[group[i]];
        return i;
      };
      for (const Seam& seam : scene.cloth.seams) group[std::max(find(seam.a), find(seam.b))] = std::min(find(seam.a), find(seam.b));
      for (int i = 0; i < model_->num_vertices(); ++i) group[i] = find(i);
      self_contacts_->set_vertex_groups(std::move(group));
    }
    integrator_->add_contact_handler(self_contacts_.get());
  }
  // The clamps last: their contacts join the others', and they put their vertices on their
  // paths after every other correction.
  if (clamps_) integrator_->add_contact_handler(clamps_.get());
  state_.x = model_->initial_positions();
  state_.v = VecX::Zero(state_.x.size());
  for (int i = 0; i < model_->num_vertices(); ++i)
    if (!model_->fixed[i]) node(state_.v, i) = scene.cloth.initial_velocity;
  for (size_t k = 0; k < clamp_groups.size(); ++k)
    for (int i : clamp_groups[k]) {
      node(state_.x, i) = clamps_->position(k, i, 0);
      node(state_.v, i) = clamps_->velocity(k, i, 0);
    }
  state_.t = 0;
  set_energy_reference();
  stage("done", 1.0);
}

SimulationCore::~SimulationCore() = default;

void SimulationCore::advance_to(double t) {
  // While pins move: a step at a time (each arrival is on the step grid), each moving pin's
  // velocity set again after every step to reach its target at its arrival, so that a pin the
  // self-collision fail-safe held still for a step (an impact zone holding a pin stops) catches
  // up; pins that arrived are put on their targets and stopped.
  const double slack = 1e-9 * scene_.integrator.dt;
  while (!pin_moves_.empty() && state_.t < t - slack) {
    double next = std::min(t, state_.t + scene_.integrator.dt);
    for (const PinMove& m : pin_moves_) next = std::min(next, m.arrival);
    integrator_->advance(state_, next, stats_);
    std::erase_if(pin_moves_, [&](const PinMove& m) {
      if (m.arrival > state_.t + slack) {
        set_pin_velocity(m.node, (m.target - node(state_.x, m.node)) / (m.arrival - state_.t));
        return false;
      }
      node(state_.x, m.node) = m.target;
      set_pin_velocity(m.node, Vec3::Zero());
      return true;
    });
  }
  integrator_->advance(state_, t, stats_);
}

double SimulationCore::arrival_time(double arrival, const std::string& what) const {
  const double now = state_.t, dt = scene_.integrator.dt;
  if (!(arrival > now) || !std::isfinite(arrival))
    throw InputError(what + ": the arrival time " + std::to_string(arrival) + " s must be after the current time " +
                     std::to_string(now) + " s");
  if (scene_.integrator.method == Method::Rk45) return arrival;
  return now + std::max(1L, std::lround((arrival - now) / dt)) * dt;
}

void SimulationCore::set_pin_velocity(int i, const Vec3& v) {
  node(state_.v, i) = v;
  // BDF-2 moves a node by beta dx_prev + dt_b v (with dv = 0 on a pin): a previous change of
  // dt v, beta dt + dt_b = dt, makes that dt v from the next step on.
  if (state_.has_history) {
    node(state_.dx_prev, i) = scene_.integrator.dt * v;
    node(state_.dv_prev, i).setZero();
  }
}

void SimulationCore::move_pins(const std::vector<int>& nodes, const std::vector<Vec3>& targets, double arrival) {
  const std::string what = "move_pins";
  if (nodes.size() != targets.size())
    throw InputError(what + ": " + std::to_string(nodes.size()) + " vertices but " + std::to_string(targets.size()) +
                     " targets (one target per vertex)");
  for (size_t k = 0; k < nodes.size(); ++k) {
    const int i = nodes[k];
    if (i < 0 || i >= model_->num_vertices())
      throw InputError(what + ": vertex " + std::to_string(i) + " does not exist (the cloth has " +
                       std::to_string(model_->num_vertices()) + " vertices)");
    if (!model_->fixed[i]) throw InputError(what + ": vertex " + std::to_string(i) + " is not pinned");
    if (!targets[k].allFinite())
      throw InputError(what + ": the target of vertex " + std::to_string(i) + " is not finite");
  }
  const double when = arrival_time(arrival, what);
  for (size_t k = 0; k < nodes.size(); ++k) {
    const int i = nodes[k];
    std::erase_if(pin_moves_, [i](const PinMove& m) { return m.node == i; });
    pin_moves_.push_back({i, targets[k], when});
    set_pin_velocity(i, (targets[k] - node(state_.x, i)) / (when - state_.t));
  }
}

void SimulationCore::move_collider(size_t k, const Eigen::Isometry3d& target, double arrival) {
  const std::string what = "move_collider";
  if (k >= colliders_.size())
    throw InputError(what + ": collider " + std::to_string(k) + " does not exist (the scene has " +
                     std::to_string(colliders_.size()) + " colliders)");
  ColliderSpec& spec = scene_.colliders[k];
  if (spec.shape == ColliderShape::kBody)
    throw InputError(what + ": " + spec.name + " is a walking body, moved by its motion file, not rigidly");
  if (!target.matrix().allFinite()) throw InputError(what + ": the target pose of " + spec.name + " is not finite");
  const double when = arrival_time(arrival, what);
  const Eigen::Isometry3d now = spec.motion.at(state_.t);
  RigidMotion motion;
  motion.kind = RigidMotion::Kind::kKeyframes;
  motion.keys = {{state_.t, now.translation(), degrees_from_rotation(now.linear())},
                 {when, target.translation(), degrees_from_rotation(target.linear())}};
  spec.motion = motion;
  colliders_[k]->set_motion(motion);
}

void SimulationCore::collider_surface(size_t k, double t, Points& positions, Triangles& triangles) const {
  const Collider& c = *colliders_.at(k);
  if (c.spec().shape == ColliderShape::kBody) {
    const WalkingBody& body = *bodies_[c.spec().body];
    body.positions(t, positions);
    if (triangles.rows() == 0) triangles = body.triangles();
  } else {
    c.surface(t, positions, triangles);
  }
}

Eigen::Isometry3d SimulationCore::collider_pose(size_t k, double t) const {
  if (k >= colliders_.size())
    throw InputError("collider_pose: collider " + std::to_string(k) + " does not exist (the scene has " +
                     std::to_string(colliders_.size()) + " colliders)");
  if (scene_.colliders[k].shape == ColliderShape::kBody)
    throw InputError("collider_pose: " + scene_.colliders[k].name + " is a walking body, without a rigid pose");
  return scene_.colliders[k].motion.at(t);
}

void SimulationCore::reset_state(const VecX& x, const VecX& v) {
  state_ = State{};
  state_.x = x;
  state_.v = v;
  set_energy_reference();
}

void SimulationCore::set_energy_reference() {
  gravity0_ = 0;
  total0_ = 0;
  system_->evaluate(state_.x, state_.v, false, eval_);
  gravity0_ = eval_.gravity_energy;
  const EnergyRow e0 = energies();
  total0_ = e0.total();
  Vec3 lo = node(state_.x, 0), hi = lo;
  for (int i = 1; i < model_->num_vertices(); ++i) {
    lo = lo.cwiseMin(node(state_.x, i));
    hi = hi.cwiseMax(node(state_.x, i));
  }
  energy_scale_ = e0.kinetic + e0.elastic + model_->mass.sum() * scene_.gravity.norm() * (hi - lo).norm() + 1e-12;
  integrator_->set_energy_scale(energy_scale_);
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

// Vectors of the State are empty or 3n long.
VecX get_state_vector(BinaryReader& in, Eigen::Index size, const char* name, bool may_be_empty) {
  VecX v = in.vec();
  if (v.size() != size && !(may_be_empty && v.size() == 0))
    in.fail(std::string("checkpoint's ") + name + " has " + std::to_string(v.size()) + " values, the cloth " +
            std::to_string(size));
  return v;
}
}  // namespace

std::uint64_t SimulationCore::fingerprint() const {
  BinaryWriter w;
  const VecX x0 = model_->initial_positions();
  w.vec(x0);
  w.vec(model_->mass);
  w.raw(model_->fixed.data(), model_->fixed.size());
  w.u64(model_->mesh.triangles.size());
  w.u64(model_->bending.size());
  w.u64(static_cast<std::uint64_t>(model_->pattern.num_blocks()));
  const IntegratorSettings& is = integrator_->settings();
  w.i64(static_cast<int>(is.method));
  for (double d : {is.alpha, is.dt, is.cg_tolerance, is.error_tolerance, is.ssor_relaxation}) w.f64(d);
  w.i64(is.cg_max_iterations);
  w.i64(static_cast<int>(integrator_->preconditioner()));
  w.i64(is.ssor_single_precision);
  w.i64(is.warm_start_history);
  w.i64(is.guard);
  if (is.newton_iterations > 0) {  // (absent when off: fingerprints of older checkpoints hold)
    w.i64(is.newton_iterations);
    w.f64(is.newton_tolerance);
  }
  w.f64(system_->damping_settings().damping_ratio);
  w.f64(system_->damping_settings().reference_dt);
  for (const Material& m : model_->materials)
    for (double d : {m.viscosity_Ns_m, m.surface_density_kg_m2, m.bending_rigidity_weft_Nm, m.bending_rigidity_warp_Nm})
      w.f64(d);
  for (int k : model_->triangle_material) w.i64(k);  // empty with one material
  for (double d : {scene_.duration, scene_.frame_interval}) w.f64(d);
  w.raw(scene_.gravity.data(), 3 * sizeof(double));
  w.i64(scene_.cloth.self_collision);
  for (double d : {scene_.cloth.thickness, scene_.cloth.friction}) w.f64(d);
  if (clamps_) {
    for (size_t i = 0; i < clamps_->clamped().size(); ++i) w.i64(clamps_->clamped()[i]);
    for (const ClampSpec& c : scene_.cloth.clamps)
      for (double t : {0.0, scene_.duration}) w.raw(c.motion.at(t).matrix().data(), 16 * sizeof(double));
  }
  return fnv1a(w.bytes().data(), w.bytes().size());
}

void SimulationCore::save(BinaryWriter& out) const {
  out.u64(fingerprint());
  const State& s = state_;
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
  for (long c : {stats_.steps, stats_.rejected_steps, stats_.cg_iterations, stats_.cg_solves, stats_.cg_failures,
                 stats_.contacts, stats_.max_contacts, stats_.released_contacts, stats_.fail_safe_moves,
                 stats_.contact_passes, stats_.failed_contact_steps, stats_.halved_steps, stats_.guard_redone_steps,
                 stats_.guard_raised_steps, stats_.guard_split_steps, stats_.guard_parts, stats_.newton_iterations,
                 stats_.newton_steps, stats_.newton_halvings, stats_.newton_unconverged})
    out.i64(c);
  out.f64(stats_.guard_max_alpha);
  for (double d : {stats_.assembly_seconds, stats_.solve_seconds, stats_.detection_seconds, stats_.response_seconds,
                   stats_.guard_seconds, stats_.newton_seconds})
    out.f64(d);
  out.f64(gravity0_);
  out.f64(total0_);
  out.f64(energy_scale_);

  const ClothSystem::DynamicState sys = system_->dynamic_state();
  out.doubles(sys.membrane_viscosity.front().data(), 3 * sys.membrane_viscosity.size());
  for (const LogStatistics* l : {&sys.statistics.membrane_kappa, &sys.statistics.membrane_lambda,
                                 &sys.statistics.bending_kappa, &sys.statistics.added_viscosity})
    put(out, *l);
  out.i64(sys.statistics.element_steps);
  out.i64(sys.statistics.raised_element_steps);

  const Integrator::DynamicState in = integrator_->dynamic_state();
  out.i64(in.history.size);
  out.i64(in.history.next);
  out.mat(in.history.b);
  out.mat(in.history.x);
  out.mat(in.history.gram);
  for (double d : {in.history_alpha, in.history_beta, in.history_dt_b, in.history_t, in.ssor_residual_ratio}) out.f64(d);
  out.i64(in.ssor_single_fallbacks);
  out.doubles(in.multigrid_setup_blocks.empty() ? nullptr : in.multigrid_setup_blocks.front().data(),
              9 * in.multigrid_setup_blocks.size());
  for (const std::vector<char>* flags : {&in.contact_pulling, &in.contact_stuck}) {
    out.i64(static_cast<std::int64_t>(flags->size()));
    for (char c : *flags) out.i64(c);
  }
  for (int g : {in.guard_rung, in.guard_calm_steps, in.guard_depth, in.guard_depth_calm_steps}) out.i64(g);
  // The cloth-cloth fail-safe keeps nothing between steps but its counts (for summary.json).
  SelfContactStatistics self;
  if (self_contacts_) self = self_contacts_->statistics();
  for (long c : {self.repulsions, self.collision_impulses, self.impact_zones, self.zone_nodes,
                 self.failed_steps})
    out.i64(c);
  out.f64(self.seconds);
}

void SimulationCore::restore(BinaryReader& in) {
  if (in.u64() != fingerprint())
    in.fail("checkpoint belongs to another cloth or other settings (the mesh, pins, material, integrator or "
            "timing differ from the scene's)");
  const Eigen::Index size = 3 * model_->num_vertices();
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
  StepStatistics st;
  for (long* c : {&st.steps, &st.rejected_steps, &st.cg_iterations, &st.cg_solves, &st.cg_failures, &st.contacts,
                  &st.max_contacts, &st.released_contacts, &st.fail_safe_moves, &st.contact_passes,
                  &st.failed_contact_steps, &st.halved_steps, &st.guard_redone_steps, &st.guard_raised_steps,
                  &st.guard_split_steps, &st.guard_parts, &st.newton_iterations, &st.newton_steps,
                  &st.newton_halvings, &st.newton_unconverged})
    *c = in.i64();
  st.guard_max_alpha = in.f64();
  for (double* d : {&st.assembly_seconds, &st.solve_seconds, &st.detection_seconds, &st.response_seconds,
                    &st.guard_seconds, &st.newton_seconds})
    *d = in.f64();
  const double gravity0 = in.f64(), total0 = in.f64(), energy_scale = in.f64();

  ClothSystem::DynamicState sys;
  const std::vector<double> eta = in.doubles();
  if (eta.size() != 3 * model_->mesh.triangles.size())
    in.fail("checkpoint's viscosities are for " + std::to_string(eta.size() / 3) + " triangles, the cloth has " +
            std::to_string(model_->mesh.triangles.size()));
  for (size_t t = 0; 3 * t < eta.size(); ++t) sys.membrane_viscosity.emplace_back(eta[3 * t], eta[3 * t + 1], eta[3 * t + 2]);
  for (LogStatistics* l : {&sys.statistics.membrane_kappa, &sys.statistics.membrane_lambda,
                           &sys.statistics.bending_kappa, &sys.statistics.added_viscosity})
    *l = get_statistics(in);
  sys.statistics.element_steps = in.i64();
  sys.statistics.raised_element_steps = in.i64();

  Integrator::DynamicState id;
  id.history.size = static_cast<int>(in.i64());
  id.history.next = static_cast<int>(in.i64());
  id.history.b = in.mat();
  id.history.x = in.mat();
  id.history.gram = in.mat();
  for (double* d : {&id.history_alpha, &id.history_beta, &id.history_dt_b, &id.history_t, &id.ssor_residual_ratio})
    *d = in.f64();
  id.ssor_single_fallbacks = in.i64();
  const std::vector<double> blocks = in.doubles();
  if (blocks.size() % 9) in.fail("checkpoint is damaged (multigrid matrix of " + std::to_string(blocks.size()) + " values)");
  for (size_t b = 0; b < blocks.size(); b += 9) id.multigrid_setup_blocks.push_back(Eigen::Map<const Mat3>(&blocks[b]));
  for (std::vector<char>* flags : {&id.contact_pulling, &id.contact_stuck}) {
    const std::int64_t count = in.i64();
    if (count != 0 && count != model_->num_vertices())
      in.fail("checkpoint is damaged (contact flags for " + std::to_string(count) + " nodes)");
    for (std::int64_t k = 0; k < count; ++k) flags->push_back(in.i64() != 0);
  }
  for (int* g : {&id.guard_rung, &id.guard_calm_steps, &id.guard_depth, &id.guard_depth_calm_steps})
    *g = static_cast<int>(in.i64());
  SelfContactStatistics self;
  for (long* c : {&self.repulsions, &self.collision_impulses, &self.impact_zones, &self.zone_nodes,
                  &self.failed_steps})
    *c = in.i64();
  self.seconds = in.f64();
  try {
    system_->restore(sys);
    integrator_->restore(id);
  } catch (const std::invalid_argument& e) {
    in.fail(std::string("checkpoint does not fit the scene: ") + e.what());
  }
  state_ = std::move(s);
  stats_ = st;
  gravity0_ = gravity0;
  total0_ = total0;
  energy_scale_ = energy_scale;
  integrator_->set_energy_scale(energy_scale_);
  if (self_contacts_) self_contacts_->set_statistics(self);
}

EnergyRow SimulationCore::energies() {
  system_->evaluate(state_.x, state_.v, false, eval_);
  EnergyRow r;
  r.time = state_.t;
  const VecX& m = model_->mass;
  for (int i = 0; i < model_->num_vertices(); ++i) r.kinetic += 0.5 * m[i] * node(state_.v, i).squaredNorm();
  r.elastic = eval_.elastic_energy;
  r.gravity = eval_.gravity_energy - gravity0_;
  r.viscous_dissipated = state_.viscous_dissipated;
  r.contact_work = state_.contact_work;
  r.fail_safe_work = state_.fail_safe_work;
  r.numerical_dissipated = total0_ + r.contact_work - r.total() - r.viscous_dissipated;
  if (scene_.integrator.guard) {
    r.guard_parts = static_cast<double>(statistics().guard_parts);
    r.guard_alpha = integrator_->guard_alpha();
  }
  return r;
}

namespace {
/// How far the energy the collision fail-safes put in may pile up, in energy scales, before a
/// run counts as unstable: the corrections of layered cloth put in many scales over a run that
/// the steps take out again (docs/collisions.md), a runaway far more.
constexpr double kFailSafeEnergyFactor = 100;
}  // namespace

RunResult run_simulation(Simulation& sim, const RunCallbacks& cb, const RunResult* resumed) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  RunResult res;
  if (resumed) {
    res.energy = resumed->energy;
    res.wall_seconds = resumed->wall_seconds;
  }
  const double wall_before = res.wall_seconds;
  const Scene& sc = sim.scene();
  res.damping_ratio = sc.effective_damping_ratio();
  res.vertices = sim.core().model().num_vertices();
  res.triangles = static_cast<long>(sim.core().model().mesh.triangles.size());
  const long frames = std::lround(std::floor(sc.duration / sc.frame_interval + 1e-9));
  // The reference state's energy: a resumed run compares with the energy its first part did.
  const double total0 = sim.initial_total_energy();
  for (long f = static_cast<long>(res.energy.size()); f <= frames; ++f) {
    if (f > 0) sim.advance_to(std::min(sc.duration, f * sc.frame_interval));
    const EnergyRow e = sim.energies();
    const State& s = sim.core().state();
    std::string problem;
    if (!s.x.allFinite() || !s.v.allFinite() || !std::isfinite(e.total())) {
      problem = "positions or velocities became non-finite (NaN or infinity)";
    } else if (e.total() - e.contact_work - total0 > sim.energy_scale()) {
      // Moving colliders and clamps may put energy in (contact_work); nothing else may.
      char buf[240];
      std::snprintf(buf, sizeof buf, "mechanical energy%s rose by %.3g J, above the scene's energy scale of %.3g J",
                    e.contact_work != 0 ? " less the contacts' work" : "", e.total() - e.contact_work - total0,
                    sim.energy_scale());
      problem = buf;
    } else if (e.total() - (e.contact_work - e.fail_safe_work) - total0 > kFailSafeEnergyFactor * sim.energy_scale()) {
      // The fail-safes' corrections put energy in that the next steps mostly take out again;
      // where it piles up instead, they are running away.
      char buf[240];
      std::snprintf(buf, sizeof buf,
                    "the collision fail-safes put in %.3g J that stayed, over %.0f times the scene's energy scale of %.3g J",
                    e.total() - (e.contact_work - e.fail_safe_work) - total0, kFailSafeEnergyFactor, sim.energy_scale());
      problem = buf;
    }
    if (!problem.empty()) {
      res.status = "unstable";
      res.unstable_time = s.t;
      res.message = problem;
      break;
    }
    res.energy.push_back(e);
    if (cb.on_frame) cb.on_frame(static_cast<int>(f), sim);
    if (cb.on_progress) cb.on_progress(frames ? static_cast<double>(f) / frames : 1.0);
    res.wall_seconds = wall_before + std::chrono::duration<double>(Clock::now() - start).count();
    if (f < frames && cb.after_frame && cb.after_frame(res)) {
      res.status = "interrupted";
      res.message = "stopped at t = " + std::to_string(s.t) + " s on request";
      break;
    }
  }
  res.steps = sim.core().statistics();
  res.damping = sim.core().system().statistics();
  res.wall_seconds = wall_before + std::chrono::duration<double>(Clock::now() - start).count();
  return res;
}

namespace {
nlohmann::json stats_json(const LogStatistics& s) {
  return {{"min", s.min()}, {"median", s.median()}, {"max", s.max()}, {"count", s.count()}};
}
}  // namespace

nlohmann::json summary_json(const Simulation& sim, const RunResult& r) {
  const Scene& sc = sim.scene();
  nlohmann::json j;
  j["weft_version"] = WEFT_VERSION;
  j["scene"] = sc.file;
  j["method"] = sc.method_name;
  j["alpha"] = sc.integrator.alpha;
  j["dt"] = sc.integrator.dt;
  j["duration"] = sc.duration;
  j["frame_interval"] = sc.frame_interval;
  // Metres per unit of the texture coordinates the frames and animations hold (the pattern
  // divided by it), so that readers (weft render, weft view) measure strain against the pattern.
  j["uv_scale"] = sc.cloth.uv_scale;
  j["vertices"] = r.vertices;
  j["triangles"] = r.triangles;
  j["steps"] = r.steps.steps;
  j["rejected_steps"] = r.steps.rejected_steps;
  j["wall_seconds"] = r.wall_seconds;
  j["assembly_seconds"] = r.steps.assembly_seconds;
  j["solve_seconds"] = r.steps.solve_seconds;
  j["solver_iterations_mean"] = r.steps.cg_solves ? static_cast<double>(r.steps.cg_iterations) / r.steps.cg_solves : 0.0;
  j["solver_iterations_total"] = r.steps.cg_iterations;
  j["solver_failures"] = r.steps.cg_failures;
  j["solver_tolerance"] = sc.integrator.cg_tolerance;
  j["preconditioner"] = preconditioner_name(sim.core().integrator().preconditioner());
  if (sim.core().integrator().preconditioner() == Preconditioner::kSsor) {
    j["ssor_relaxation"] = sim.core().integrator().ssor_relaxation();
    j["ssor_precision"] = sc.integrator.ssor_single_precision ? "single" : "double";
  }
  const bool capped = r.status == "ok" && r.steps.cg_failures > 0;
  j["status"] = capped ? "solver_capped" : r.status;
  if (capped) {
    j["message"] = std::to_string(r.steps.cg_failures) + " of " + std::to_string(r.steps.cg_solves) +
                   " linear solves stopped at the iteration cap (" + std::to_string(sc.integrator.cg_max_iterations) +
                   ") before reaching the tolerance";
  } else if (r.status == "unstable") {
    j["unstable_time"] = r.unstable_time;
    j["message"] = r.message;
  } else if (r.status != "ok") {
    j["message"] = r.message;
  }
  j["frames"] = r.energy.size();
  if (!sim.core().colliders().empty() || sim.core().self_contacts()) {
    const StepStatistics& st = r.steps;
    j["contacts"] = {{"colliders", sim.core().colliders().size()},
                     {"node_contacts_mean", st.steps ? static_cast<double>(st.contacts) / st.steps : 0.0},
                     {"node_contacts_max", st.max_contacts},
                     {"released", st.released_contacts},
                     {"fail_safe_moves", st.fail_safe_moves},
                     {"repeated_solves", st.contact_passes},
                     {"failed_steps", st.failed_contact_steps},
                     {"halved_steps", st.halved_steps},
                     {"detection_seconds", st.detection_seconds},
                     {"response_seconds", st.response_seconds},
                     {"work_J", r.energy.empty() ? 0.0 : r.energy.back().contact_work},
                     {"fail_safe_work_J", r.energy.empty() ? 0.0 : r.energy.back().fail_safe_work}};
    if (const SelfContacts* self = sim.core().self_contacts()) {
      const SelfContactStatistics& ss = self->statistics();
      j["contacts"]["self"] = {{"thickness", self->thickness()},
                               {"friction", self->friction()},
                               {"repulsions", ss.repulsions},
                               {"collision_impulses", ss.collision_impulses},
                               {"impact_zones", ss.impact_zones},
                               {"impact_zone_nodes", ss.zone_nodes},
                               {"failed_steps", ss.failed_steps},
                               {"seconds", ss.seconds}};
    }
  }
  if (sc.integrator.guard) {
    const StepStatistics& st = r.steps;
    j["guard"] = {{"parts_per_step", st.steps ? static_cast<double>(st.guard_parts) / st.steps : 0.0},
                  {"split_steps", st.guard_split_steps},
                  {"seconds", st.guard_seconds},
                  {"redone_steps", st.guard_redone_steps},
                  {"raised_steps", st.guard_raised_steps},
                  {"raised_fraction", st.steps ? static_cast<double>(st.guard_raised_steps) / st.steps : 0.0},
                  {"max_alpha", std::max(sc.integrator.alpha, st.guard_max_alpha)}};
  }
  if (sc.integrator.newton_iterations > 0) {
    const StepStatistics& st = r.steps;
    j["newton"] = {{"max_iterations", sc.integrator.newton_iterations},
                   {"tolerance", sc.integrator.newton_tolerance},
                   {"iterations", st.newton_iterations},
                   {"iterations_per_step", st.steps ? static_cast<double>(st.newton_iterations) / st.steps : 0.0},
                   {"iterated_steps", st.newton_steps},
                   {"line_search_halvings", st.newton_halvings},
                   {"unconverged_steps", st.newton_unconverged},
                   {"seconds", st.newton_seconds}};
  }
  j["damping_ratio"] = r.damping_ratio;
  j["kappa"] = stats_json(r.damping.membrane_kappa);
  j["lambda"] = stats_json(r.damping.membrane_lambda);
  j["bending_kappa"] = stats_json(r.damping.bending_kappa);
  j["added_viscosity_Ns_m"] = {{"mean_over_raised", r.damping.added_viscosity.mean()},
                               {"max", r.damping.added_viscosity.max()},
                               {"material_viscosity", sim.core().model().materials.front().viscosity_Ns_m},
                               {"raised_fraction", r.damping.element_steps
                                                        ? static_cast<double>(r.damping.raised_element_steps) / r.damping.element_steps
                                                        : 0.0}};
  if (!r.energy.empty()) {
    const EnergyRow& last = r.energy.back();
    j["energy_final"] = {{"kinetic", last.kinetic}, {"elastic", last.elastic}, {"gravity", last.gravity},
                         {"viscous_dissipated", last.viscous_dissipated},
                         {"numerical_dissipated", last.numerical_dissipated}};
  }
  return j;
}

namespace {
constexpr char kCheckpointMagic[8] = {'W', 'E', 'F', 'T', 'C', 'K', 'P', 'T'};
constexpr size_t kCheckpointPrefix = sizeof kCheckpointMagic + sizeof(std::uint32_t) + sizeof(std::uint64_t);
}  // namespace

std::string checkpoint_bytes(const nlohmann::json& header, const Simulation& sim, const RunResult& so_far) {
  BinaryWriter w;
  w.raw(kCheckpointMagic, sizeof kCheckpointMagic);
  const std::uint32_t version = kCheckpointFormatVersion;
  w.raw(&version, sizeof version);
  w.text(header.dump());
  sim.core().save(w);
  w.u64(so_far.energy.size());
  for (const EnergyRow& e : so_far.energy)
    for (double d : {e.time, e.kinetic, e.elastic, e.gravity, e.viscous_dissipated, e.numerical_dissipated, e.contact_work,
                     e.fail_safe_work, e.guard_parts, e.guard_alpha})
      w.f64(d);
  w.f64(so_far.wall_seconds);
  w.u64(fnv1a(w.bytes().data(), w.bytes().size()));
  return w.bytes();
}

nlohmann::json checkpoint_header(const std::string& bytes, const std::string& file) {
  BinaryReader in(bytes, file);
  char magic[sizeof kCheckpointMagic] = {};
  if (bytes.size() < kCheckpointPrefix || (in.raw(magic, sizeof magic), std::memcmp(magic, kCheckpointMagic, sizeof magic)))
    in.fail("not a weft checkpoint");
  std::uint32_t version = 0;
  in.raw(&version, sizeof version);
  if (version != kCheckpointFormatVersion)
    in.fail("checkpoint format version " + std::to_string(version) + ", this weft reads version " +
            std::to_string(kCheckpointFormatVersion));
  std::uint64_t stored = 0;
  std::memcpy(&stored, bytes.data() + bytes.size() - sizeof stored, sizeof stored);
  if (bytes.size() < kCheckpointPrefix + sizeof stored || fnv1a(bytes.data(), bytes.size() - sizeof stored) != stored)
    in.fail("checkpoint is damaged (its checksum does not match its contents)");
  try {
    return nlohmann::json::parse(in.text());
  } catch (const nlohmann::json::exception& e) {
    in.fail(std::string("checkpoint header is damaged: ") + e.what());
  }
}

RunResult restore_checkpoint(const std::string& bytes, const std::string& file, Simulation& sim) {
  checkpoint_header(bytes, file);  // checks the format and checksum
  BinaryReader in(bytes, file, sizeof kCheckpointMagic + sizeof(std::uint32_t), bytes.size() - sizeof(std::uint64_t));
  in.text();
  sim.core().restore(in);
  RunResult r;
  const std::uint64_t rows = in.u64();
  if (rows > bytes.size() / (10 * sizeof(double))) in.fail("checkpoint is damaged (" + std::to_string(rows) + " energy rows)");
  for (std::uint64_t k = 0; k < rows; ++k) {
    EnergyRow e;
    for (double* d : {&e.time, &e.kinetic, &e.elastic, &e.gravity, &e.viscous_dissipated, &e.numerical_dissipated,
                      &e.contact_work, &e.fail_safe_work, &e.guard_parts, &e.guard_alpha})
      *d = in.f64();
    r.energy.push_back(e);
  }
  r.wall_seconds = in.f64();
  if (!in.at_end()) in.fail("checkpoint is damaged (" + std::to_string(bytes.size()) + " bytes, more than it describes)");
  return r;
}

std::string energy_csv(const std::vector<EnergyRow>& rows) {
  std::ostringstream out;
  // A guarded run's rows carry the guard's alpha (never 0); other runs' have no guard columns.
  const bool guard = std::any_of(rows.begin(), rows.end(), [](const EnergyRow& e) { return e.guard_alpha > 0; });
  out << "time,kinetic,elastic,gravity,viscous_dissipated,numerical_dissipated,contact_work,total"
      << (guard ? ",guard_parts,guard_alpha\n" : "\n");
  char buf[360];
  for (const auto& e : rows) {
    int k = std::snprintf(buf, sizeof buf, "%.6f,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g", e.time, e.kinetic,
                          e.elastic, e.gravity, e.viscous_dissipated, e.numerical_dissipated, e.contact_work, e.total());
    if (guard) k += std::snprintf(buf + k, sizeof buf - k, ",%.0f,%.6g", e.guard_parts, e.guard_alpha);
    std::snprintf(buf + k, sizeof buf - k, "\n");
    out << buf;
  }
  return out.str();
}


// The public Simulation: its core does the work.
Simulation::Simulation(const Scene& scene, const SetupProgress& on_setup)
    : core_(std::make_unique<SimulationCore>(scene, on_setup)) {}
Simulation::~Simulation() = default;
const Scene& Simulation::scene() const { return core_->scene(); }
double Simulation::time() const { return core_->state().t; }
const TriMesh& Simulation::mesh() const { return core_->model().mesh; }
int Simulation::vertex_count() const { return core_->model().num_vertices(); }
const VecX& Simulation::positions() const { return core_->state().x; }
const VecX& Simulation::velocities() const { return core_->state().v; }
VecX& Simulation::positions() { return core_->state().x; }
VecX& Simulation::velocities() { return core_->state().v; }
const VecX& Simulation::masses() const { return core_->model().mass; }
const std::vector<char>& Simulation::pinned() const { return core_->model().fixed; }
VecX Simulation::added_viscosity_per_vertex() const { return core_->system().added_viscosity_per_vertex(); }
const StepStatistics& Simulation::step_statistics() const { return core_->statistics(); }
const DampingStatistics& Simulation::damping_statistics() const { return core_->system().statistics(); }
size_t Simulation::collider_count() const { return core_->colliders().size(); }
const ColliderSpec& Simulation::collider(size_t k) const {
  if (k >= core_->colliders().size())
    throw InputError("collider " + std::to_string(k) + " does not exist: the scene has " +
                     std::to_string(core_->colliders().size()) + " colliders");
  return core_->colliders()[k]->spec();
}
void Simulation::collider_surface(size_t k, double t, Points& positions, Triangles& triangles) const {
  core_->collider_surface(k, t, positions, triangles);
}
void Simulation::reset_state(const VecX& x, const VecX& v) { core_->reset_state(x, v); }
void Simulation::advance_to(double t) { core_->advance_to(t); }
void Simulation::move_pins(const std::vector<int>& nodes, const std::vector<Vec3>& targets, double arrival) {
  core_->move_pins(nodes, targets, arrival);
}
size_t Simulation::moving_pins() const { return core_->moving_pins(); }
void Simulation::move_collider(size_t k, const Eigen::Isometry3d& target, double arrival) {
  core_->move_collider(k, target, arrival);
}
Eigen::Isometry3d Simulation::collider_pose(size_t k, double t) const { return core_->collider_pose(k, t); }
EnergyRow Simulation::energies() { return core_->energies(); }
double Simulation::energy_scale() const { return core_->energy_scale(); }
double Simulation::initial_total_energy() const { return core_->initial_total_energy(); }
std::uint64_t Simulation::fingerprint() const { return core_->fingerprint(); }

}  // namespace weft
