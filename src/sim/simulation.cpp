#include "sim/simulation_core.hpp"

#include "collision/colliders.hpp"
#include "collision/clamps.hpp"
#include "collision/self_contact.hpp"
#include "integrate/integrator.hpp"
#include "weft/garment/sewing.hpp"
#include "sim/checkpoint.hpp"
#include "util/timer.hpp"
#include "weft/error.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <sstream>

namespace weft {


SimulationCore::SimulationCore(const Scene& scene, const SetupProgress& on_setup)
    : SimulationCore(std::make_shared<const Model>(scene, on_setup)) {}

SimulationCore::SimulationCore(std::shared_ptr<const Model> model)
    : model_(model ? std::move(model) : throw InputError("Simulation: no model (a null pointer)")),
      m_(&model_->core()),
      data_(make_data(*m_)) {
  system_ = std::make_unique<ClothSystem>(*m_->cloth, m_->system, data_->system);
  integrator_ = std::make_unique<Integrator>(*system_, m_->integrator, data_->integrator);
}

SimulationCore::~SimulationCore() = default;

void SimulationCore::advance_to(double t, bool stop_on_runaway) { advance(*m_, *data_, t, stop_on_runaway); }

double SimulationCore::arrival_time(double arrival, const std::string& what) const {
  const double now = data_->state.t, dt = m_->scene.integrator.dt;
  if (!(arrival > now) || !std::isfinite(arrival))
    throw InputError(what + ": the arrival time " + std::to_string(arrival) + " s must be after the current time " +
                     std::to_string(now) + " s");
  if (m_->scene.integrator.method == Method::kRk45) return arrival;
  return now + std::max(1L, std::lround((arrival - now) / dt)) * dt;
}

void SimulationCore::move_pins(const std::vector<int>& nodes, const std::vector<Vec3>& targets, double arrival) {
  const std::string what = "move_pins";
  const ClothModel& cloth = model();
  if (nodes.size() != targets.size())
    throw InputError(what + ": " + std::to_string(nodes.size()) + " vertices but " + std::to_string(targets.size()) +
                     " targets (one target per vertex)");
  for (size_t k = 0; k < nodes.size(); ++k) {
    const int i = nodes[k];
    if (i < 0 || i >= cloth.num_vertices())
      throw InputError(what + ": vertex " + std::to_string(i) + " does not exist (the cloth has " +
                       std::to_string(cloth.num_vertices()) + " vertices)");
    if (!cloth.pinned[i]) throw InputError(what + ": vertex " + std::to_string(i) + " is not pinned");
    if (!targets[k].allFinite())
      throw InputError(what + ": the target of vertex " + std::to_string(i) + " is not finite");
  }
  const double when = arrival_time(arrival, what);
  State& s = data_->state;
  for (size_t k = 0; k < nodes.size(); ++k) {
    const int i = nodes[k];
    std::erase_if(data_->pin_moves, [i](const PinMove& m) { return m.node == i; });
    data_->pin_moves.push_back({i, targets[k], when});
    set_pin_velocity(*m_, *data_, i, (targets[k] - node(s.x, i)) / (when - s.t));
  }
}

void SimulationCore::move_collider(size_t k, const Eigen::Isometry3d& target, double arrival) {
  const std::string what = "move_collider";
  const size_t count = data_->colliders.size();
  if (k >= count)
    throw InputError(what + ": collider " + std::to_string(k) + " does not exist (the scene has " +
                     std::to_string(count) + " colliders)");
  const ColliderSpec& spec = m_->scene.colliders[k];
  if (spec.shape == ColliderShape::kBody)
    throw InputError(what + ": " + spec.name + " is a walking body, moved by its motion file, not rigidly");
  if (!target.matrix().allFinite()) throw InputError(what + ": the target pose of " + spec.name + " is not finite");
  const double when = arrival_time(arrival, what);
  const double now_t = data_->state.t;
  const Eigen::Isometry3d now = data_->collider_motions[k].at(now_t);
  RigidMotion motion;
  motion.kind = RigidMotion::Kind::kKeyframes;
  motion.keys = {{now_t, now.translation(), degrees_from_rotation(now.linear())},
                 {when, target.translation(), degrees_from_rotation(target.linear())}};
  data_->collider_motions[k] = motion;
  data_->colliders[k]->set_motion(motion);
}

void SimulationCore::collider_surface(size_t k, double t, Points& positions, Triangles& triangles) const {
  if (k >= data_->colliders.size())
    throw InputError("collider_surface: collider " + std::to_string(k) + " does not exist (the scene has " +
                     std::to_string(data_->colliders.size()) + " colliders)");
  const Collider& c = *data_->colliders[k];
  if (c.spec().shape == ColliderShape::kBody) {
    const WalkingBody& body = *m_->bodies[c.spec().body];
    body.positions(t, positions);
    if (triangles.rows() == 0) triangles = body.triangles();
  } else {
    c.surface(t, positions, triangles);
  }
}

Eigen::Isometry3d SimulationCore::collider_pose(size_t k, double t) const {
  const std::vector<ColliderSpec>& specs = m_->scene.colliders;
  if (k >= specs.size())
    throw InputError("collider_pose: collider " + std::to_string(k) + " does not exist (the scene has " +
                     std::to_string(specs.size()) + " colliders)");
  if (specs[k].shape == ColliderShape::kBody)
    throw InputError("collider_pose: " + specs[k].name + " is a walking body, without a rigid pose");
  return data_->collider_motions[k].at(t);
}

void SimulationCore::reset_state(const VecX& x, const VecX& v) {
  // x and v may be the state's own vectors; the state keeps its storage (the Python module's
  // arrays view it).
  const VecX new_x = x, new_v = v;
  State& s = data_->state;
  VecX storage_x = std::move(s.x), storage_v = std::move(s.v);
  s = State{};
  s.x = std::move(storage_x);
  s.v = std::move(storage_v);
  s.x = new_x;
  s.v = new_v;
  set_energy_reference(*m_, *data_);
}

EnergyRow SimulationCore::energies() { return weft::energies(*m_, *data_); }
std::uint64_t SimulationCore::fingerprint() const { return weft::fingerprint(*m_); }
void SimulationCore::save(BinaryWriter& out) const { save_data(*m_, *data_, out); }
void SimulationCore::restore(BinaryReader& in) { restore_data(*m_, *data_, in); }

RunResult run_simulation(Simulation& sim, const RunCallbacks& cb, const RunResult* resumed) {
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
  // The corrections of layered cloth put in many energy scales over a run that the steps take
  // out again (docs/collisions.md), a runaway far more.
  const double fail_safe_factor = sc.contacts.fail_safe_energy_factor;
  for (long f = static_cast<long>(res.energy.size()); f <= frames; ++f) {
    // A step whose energy ran away ends the frame early, and the check below stops the run
    // there: a cloth blowing up can make each later step's collision handling take minutes.
    if (f > 0) sim.core().advance_to(std::min(sc.duration, f * sc.frame_interval), true);
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
    } else if (e.total() - (e.contact_work - e.fail_safe_work) - total0 > fail_safe_factor * sim.energy_scale()) {
      // The fail-safes' corrections put energy in that the next steps mostly take out again;
      // where it piles up instead, they are running away.
      char buf[240];
      std::snprintf(buf, sizeof buf,
                    "the collision fail-safes put in %.3g J that stayed, over %.3g times the scene's energy scale of %.3g J",
                    e.total() - (e.contact_work - e.fail_safe_work) - total0, fail_safe_factor, sim.energy_scale());
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
    res.wall_seconds = wall_before + seconds_since(start);
    if (f < frames && cb.after_frame && cb.after_frame(res)) {
      res.status = "interrupted";
      res.message = "stopped at t = " + std::to_string(s.t) + " s on request";
      break;
    }
  }
  res.steps = sim.core().statistics();
  res.damping = sim.core().system().statistics();
  res.wall_seconds = wall_before + seconds_since(start);
  return res;
}

namespace {
nlohmann::json stats_json(const LogStatistics& s) {
  return {{"min", s.min()}, {"median", s.median()}, {"max", s.max()}, {"count", s.count()}};
}

// The statistics that summary.json reports as they are in its object `group` ("": the top
// level), under their keys (WEFT_STEP_STATISTICS).
void add_step_statistics(nlohmann::json& j, const StepStatistics& st, const std::string& group) {
  for (const StepStatistic& s : kStepStatistics) {
    if (group != s.group || !*s.key) continue;
    if (s.count) {
      j[s.key] = st.*s.count;
    } else {
      j[s.key] = st.*s.value;
    }
  }
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
  add_step_statistics(j, r.steps, "");
  j["wall_seconds"] = r.wall_seconds;
  j["solver_iterations_mean"] = r.steps.cg_solves ? static_cast<double>(r.steps.cg_iterations) / r.steps.cg_solves : 0.0;
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
                     {"node_contacts_mean", st.contact_solves ? static_cast<double>(st.contacts) / st.contact_solves : 0.0},
                     {"work_J", r.energy.empty() ? 0.0 : r.energy.back().contact_work},
                     {"fail_safe_work_J", r.energy.empty() ? 0.0 : r.energy.back().fail_safe_work}};
    add_step_statistics(j["contacts"], st, "contacts");
    if (const SelfContacts* self = sim.core().self_contacts()) {
      const SelfContactStatistics& ss = self->statistics();
      nlohmann::json& js = j["contacts"]["self"];
      js = {{"thickness", self->thickness()}, {"friction", self->friction()}};
      for (const SelfContactStatistic& c : kSelfContactStatistics) {
        if (c.count) {
          js[c.key] = ss.*c.count;
        } else {
          js[c.key] = ss.*c.value;
        }
      }
    }
  }
  if (sc.integrator.guard) {
    const StepStatistics& st = r.steps;
    j["guard"] = {{"parts_per_step", st.steps ? static_cast<double>(st.guard_parts) / st.steps : 0.0},
                  {"raised_fraction", st.steps ? static_cast<double>(st.guard_raised_steps) / st.steps : 0.0},
                  {"max_alpha", std::max(sc.integrator.alpha, st.guard_max_alpha)}};
    add_step_statistics(j["guard"], st, "guard");
  }
  // Unguarded backward Euler takes a step that put energy in again with Newton iterations
  // (IntegratorSettings::backward_euler_newton).
  const bool automatic = sc.integrator.method == Method::kAlphaFamily && sc.integrator.alpha == 1.0 &&
                         !sc.integrator.guard && sc.integrator.backward_euler_newton &&
                         sc.integrator.newton_iterations < kBackwardEulerNewton;
  if (sc.integrator.newton_iterations > 0 || automatic) {
    const StepStatistics& st = r.steps;
    j["newton"] = {{"max_iterations", sc.integrator.newton_iterations},
                   {"tolerance", sc.integrator.newton_tolerance},
                   {"iterations_per_step", st.steps ? static_cast<double>(st.newton_iterations) / st.steps : 0.0}};
    add_step_statistics(j["newton"], st, "newton");
    if (automatic) j["newton"]["automatic_max_iterations"] = kBackwardEulerNewton;
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
Simulation::Simulation(std::shared_ptr<const Model> model) : core_(std::make_unique<SimulationCore>(std::move(model))) {}
const Scene& Simulation::scene() const { return core_->scene(); }
const std::shared_ptr<const Model>& Simulation::model() const { return core_->shared_model(); }

Model::Model(const Scene& scene, const SetupProgress& on_setup) : impl_(build_model(scene, on_setup)) {}
Model::~Model() = default;
const Scene& Model::scene() const { return impl_->scene; }
const TriMesh& Model::mesh() const { return impl_->cloth->mesh; }
int Model::vertex_count() const { return impl_->num_vertices(); }
std::uint64_t Model::fingerprint() const { return weft::fingerprint(*impl_); }
double Simulation::time() const { return core_->state().t; }
const TriMesh& Simulation::mesh() const { return core_->model().mesh; }
int Simulation::vertex_count() const { return core_->model().num_vertices(); }
const VecX& Simulation::positions() const { return core_->state().x; }
const VecX& Simulation::velocities() const { return core_->state().v; }
VecX& Simulation::positions() { return core_->state().x; }
VecX& Simulation::velocities() { return core_->state().v; }
const VecX& Simulation::masses() const { return core_->model().mass; }
const std::vector<char>& Simulation::pinned() const { return core_->model().pinned; }
VecX Simulation::added_viscosity_per_vertex() const { return core_->system().added_viscosity_per_vertex(); }
const StepStatistics& Simulation::step_statistics() const { return core_->statistics(); }
const DampingStatistics& Simulation::damping_statistics() const { return core_->system().statistics(); }
size_t Simulation::collider_count() const { return core_->colliders().size(); }
const ColliderSpec& Simulation::collider(size_t k) const {
  if (k >= core_->colliders().size())
    throw InputError("collider " + std::to_string(k) + " does not exist (the scene has " +
                     std::to_string(core_->colliders().size()) + " colliders)");
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
