#include "weft/experiments/stability_experiment.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "weft/error.hpp"
#include "sim/simulation_core.hpp"

namespace weft {

namespace {

// A small portable generator (splitmix64), so a seed gives the same perturbation with every
// standard library.
class SplitMix {
 public:
  explicit SplitMix(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  /// Uniform in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * static_cast<double>(next() >> 11) * 0x1.0p-53; }

 private:
  std::uint64_t state_;
};

// A smooth random scalar field on the unit square: a few sinusoids of low wave number.
struct SmoothField {
  static constexpr int kTerms = 4;
  double fu[kTerms], fv[kTerms], phase[kTerms], amplitude[kTerms];
  explicit SmoothField(SplitMix& rng) {
    for (int k = 0; k < kTerms; ++k) {
      fu[k] = rng.uniform(0.5, 2.5);
      fv[k] = rng.uniform(0.5, 2.5);
      phase[k] = rng.uniform(0, 2 * M_PI);
      amplitude[k] = rng.uniform(-1, 1);
    }
  }
  double operator()(double u, double v) const {
    double s = 0;
    for (int k = 0; k < kTerms; ++k) s += amplitude[k] * std::sin(M_PI * (fu[k] * u + fv[k] * v) + phase[k]);
    return s;
  }
};

// Fills `out` (3n) with a smooth random vector field over the pattern, largest component
// magnitude `amplitude` per axis times `axis_scale`.
void smooth_vector_field(SplitMix& rng, const TriMesh& mesh, double size, double amplitude, const Vec3& axis_scale,
                         VecX& out) {
  const int n = mesh.num_vertices();
  out = VecX::Zero(3 * n);
  for (int c = 0; c < 3; ++c) {
    const SmoothField f(rng);
    double peak = 0;
    for (int i = 0; i < n; ++i) {
      out[3 * i + c] = f(mesh.pattern[i].x() / size, mesh.pattern[i].y() / size);
      peak = std::max(peak, std::abs(out[3 * i + c]));
    }
    if (peak > 0)
      for (int i = 0; i < n; ++i) out[3 * i + c] *= amplitude * axis_scale[c] / peak;
  }
}

// Removes the rigid-body part of a velocity field: the centre-of-mass velocity and the
// rotation with the same angular momentum, so a run that comes to rest really stops.
void remove_rigid_motion(const VecX& x, const VecX& mass, VecX& v) {
  const int n = static_cast<int>(mass.size());
  const double M = mass.sum();
  Vec3 c = Vec3::Zero(), vc = Vec3::Zero();
  for (int i = 0; i < n; ++i) {
    c += mass[i] * node(x, i);
    vc += mass[i] * node(v, i);
  }
  c /= M;
  vc /= M;
  Vec3 L = Vec3::Zero();
  Mat3 I = Mat3::Zero();
  for (int i = 0; i < n; ++i) {
    node(v, i) -= vc;
    const Vec3 r = node(x, i) - c;
    L += mass[i] * r.cross(Vec3(node(v, i)));
    I += mass[i] * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
  }
  const Vec3 w = I.ldlt().solve(L);
  for (int i = 0; i < n; ++i) node(v, i) -= w.cross(Vec3(node(x, i) - c));
}

std::string format_number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  return buf;
}

std::string percent(double ratio) { return format_number(100 * ratio) + "%"; }

}  // namespace

std::vector<StabilityMethod> default_stability_methods() {
  return {{"forward Euler", "forward-euler", std::nullopt},
          {"backward Euler", "backward-euler", std::nullopt},
          {"Implicit Midpoint", "implicit-midpoint-plain", std::nullopt},
          {"guarded Implicit Midpoint", "implicit-midpoint", std::nullopt},
          {"alpha 0.6", "alpha", 0.6},
          {"alpha 2/3", "alpha", 2.0 / 3.0},
          {"BDF-2", "bdf2", std::nullopt},
          {"BDF-2 alpha 1/sqrt(3)", "bdf2-alpha", 1.0 / std::sqrt(3.0)}};
}

std::vector<StabilityMethod> parse_stability_methods(const std::string& list, const std::string& option) {
  std::vector<StabilityMethod> out;
  std::stringstream ss(list);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (item.empty()) continue;
    const auto bad = [&](const std::string& why) {
      throw InputError(option + ": '" + item + "' " + why + " (expected NAME or NAME:ALPHA, NAME one of: " +
                       method_names() + ")");
    };
    StabilityMethod m;
    const auto colon = item.find(':');
    m.name = item.substr(0, colon);
    const MethodInfo* info = find_method(m.name);
    if (!info) bad("is not a known method");
    if (info->method == Method::kRk4 || info->method == Method::kRk45) bad("is not a fixed-step semi-implicit method");
    std::string alpha_text;
    if (colon != std::string::npos) {
      alpha_text = item.substr(colon + 1);
      if (info->fixed_alpha) bad("fixes alpha; use 'alpha:A' or 'bdf2-alpha:A'");
      double a = 0;
      try {
        size_t used = 0;
        const auto slash = alpha_text.find('/');
        if (slash == std::string::npos) {
          a = std::stod(alpha_text, &used);
          if (used != alpha_text.size()) bad("has a malformed alpha");
        } else {
          const std::string p = alpha_text.substr(0, slash), q = alpha_text.substr(slash + 1);
          const double num = std::stod(p, &used);
          if (used != p.size()) bad("has a malformed alpha");
          const double den = std::stod(q, &used);
          if (used != q.size() || den == 0) bad("has a malformed alpha");
          a = num / den;
        }
      } catch (const std::logic_error&) {
        bad("has a malformed alpha");
      }
      if (!(a >= 0 && a <= 1)) bad("has alpha outside [0, 1]");
      m.alpha = a;
    } else if (!info->fixed_alpha) {
      m.alpha = info->default_alpha;
    }
    m.label = m.name;
    if (!alpha_text.empty()) m.label.append(" ").append(alpha_text);
    // A method of the default list keeps its label there, so CSVs of runs can be joined.
    for (const auto& d : default_stability_methods())
      if (d.name == m.name && d.alpha.has_value() == m.alpha.has_value() &&
          (!d.alpha || std::abs(*d.alpha - *m.alpha) < 1e-12))
        m.label = d.label;
    out.push_back(m);
  }
  if (out.empty()) throw InputError(option + ": no method given in '" + list + "'");
  return out;
}

void validate(const StabilityExperimentSettings& s) {
  const auto positive = [](const std::string& option, double v) {
    if (!(v > 0) || !std::isfinite(v))
      throw InputError(option + ": must be a positive finite number, got " + format_number(v));
  };
  positive("--size", s.size_m);
  positive("--duration", s.duration_s);
  positive("--stretch-modulus", s.stretch_modulus_N_m);
  positive("--shear-modulus", s.shear_modulus_N_m);
  positive("--density", s.surface_density_kg_m2);
  if (!(s.bending_rigidity_Nm >= 0) || !std::isfinite(s.bending_rigidity_Nm))
    throw InputError("--bending-rigidity: must be a non-negative finite number, got " + format_number(s.bending_rigidity_Nm));
  if (s.resolution < 2 || s.resolution > 201)
    throw InputError("--resolution: must be in [2, 201] vertices per side, got " + std::to_string(s.resolution));
  for (double v : {s.fold_fraction, s.jitter_fraction, s.velocity_m_s})
    if (!(v >= 0) || !std::isfinite(v))
      throw InputError("--fold/--jitter/--velocity: must be non-negative finite numbers, got " + format_number(v));
  if (!(s.rest_fraction > 0 && s.rest_fraction < 1))
    throw InputError("--rest-fraction: must be in (0, 1), got " + format_number(s.rest_fraction));
  if (s.dts.empty()) throw InputError("--dts: no time step given");
  for (double dt : s.dts) {
    positive("--dts", dt);
    if (dt > s.duration_s)
      throw InputError("--dts: time step " + format_number(dt) + " s is longer than --duration " +
                       format_number(s.duration_s) + " s");
  }
  if (s.ratios.empty()) throw InputError("--ratios: no damping ratio given");
  for (double r : s.ratios)
    if (!(r >= 0 && r <= 10))
      throw InputError("--ratios: damping ratio must be in [0, 10] (a fraction of critical), got " + format_number(r));
  if (s.methods.empty()) throw InputError("--methods: no method given");
}

Scene stability_scene(const StabilityExperimentSettings& s, const StabilityMethod& method, double dt,
                      double damping_ratio) {
  Scene sc;
  sc.description = "stability experiment cell";
  sc.duration = s.duration_s;
  sc.frame_interval = dt;
  sc.gravity = Vec3::Zero();
  set_method(sc, method.name, method.alpha, "--methods");
  sc.integrator.dt = dt;
  sc.integrator.cg_tolerance = s.cg_tolerance;
  sc.damping_ratio = damping_ratio;
  sc.cloth.grid = GridSpec{s.size_m, s.size_m, s.resolution, s.resolution};
  Material& m = sc.cloth.material;
  m.name = "stability-linear";
  m.surface_density_kg_m2 = s.surface_density_kg_m2;
  m.weft = StressCurve::linear(s.stretch_modulus_N_m);
  m.warp = StressCurve::linear(s.stretch_modulus_N_m);
  m.shear = StressCurve::linear(s.shear_modulus_N_m);
  m.poisson_ratio = 0.0;
  m.bending_rigidity_weft_Nm = m.bending_rigidity_warp_Nm = s.bending_rigidity_Nm;
  m.viscosity_Ns_m = 0.0;
  return sc;
}

void stability_perturbation(const StabilityExperimentSettings& s, const TriMesh& mesh, const VecX& mass, VecX& x,
                            VecX& v) {
  const int n = mesh.num_vertices();
  SplitMix rng(s.seed);
  const double edge = s.size_m / (s.resolution - 1);
  VecX fold;
  // Folds mostly out of the plane (z) and half as much in it: large rotations and stretch.
  smooth_vector_field(rng, mesh, s.size_m, s.fold_fraction * s.size_m, Vec3(0.5, 0.5, 1.0), fold);
  x.resize(3 * n);
  for (int i = 0; i < n; ++i) {
    node(x, i) = mesh.positions.row(i).transpose() + node(fold, i);
    for (int c = 0; c < 3; ++c) x[3 * i + c] += s.jitter_fraction * edge * rng.uniform(-1, 1);
  }
  smooth_vector_field(rng, mesh, s.size_m, s.velocity_m_s, Vec3(1, 1, 1), v);
  remove_rigid_motion(x, mass, v);
}

StabilityCell run_stability_cell(const StabilityExperimentSettings& s, const StabilityMethod& method, double dt,
                                 double damping_ratio) {
  const auto start = std::chrono::steady_clock::now();
  StabilityCell c;
  c.method = method.label;
  c.dt = dt;
  c.damping_ratio = damping_ratio;
  Simulation sim(stability_scene(s, method, dt, damping_ratio));
  c.alpha = sim.scene().integrator.alpha;
  VecX x, v;
  stability_perturbation(s, sim.core().model().mesh, sim.core().model().mass, x, v);
  sim.reset_state(x, v);
  const std::vector<double> kappa = sim.core().system().membrane_kappa_max(x, dt);
  c.kappa_max = kappa.empty() ? 0.0 : *std::max_element(kappa.begin(), kappa.end());

  const EnergyRow e0 = sim.energies();
  const double energy0 = e0.kinetic + e0.elastic;
  const long steps = std::lround(s.duration_s / dt);
  const long window = std::max(1L, std::lround(s.rest_window_s / dt));
  long quiet_steps = 0;
  c.max_energy_ratio = c.final_energy_ratio = 1.0;
  for (long k = 1; k <= steps; ++k) {
    sim.advance_to(k * dt);
    c.steps = k;
    const State& st = sim.core().state();
    const EnergyRow e = sim.energies();
    const double energy = e.kinetic + e.elastic;
    std::string reason;
    // The same criteria as run_simulation: non-finite values, or energy rising by more than
    // the scene's energy scale (nothing external adds energy here).
    if (!st.x.allFinite() || !st.v.allFinite() || !std::isfinite(energy)) reason = "nan";
    else if (e.total() - e0.total() > sim.energy_scale()) reason = "energy";
    else if (sim.core().statistics().cg_failures > 0) reason = "cg";
    if (!reason.empty()) {
      c.stable = false;
      c.reason = reason;
      c.unstable_time = st.t;
      break;
    }
    c.max_energy_ratio = std::max(c.max_energy_ratio, energy / energy0);
    c.final_energy_ratio = energy / energy0;
    c.final_kinetic_ratio = e.kinetic / energy0;
    quiet_steps = e.kinetic < s.rest_fraction * energy0 ? quiet_steps + 1 : 0;
    if (quiet_steps >= window) {
      c.rest_time = (k - window) * dt;
      break;
    }
  }
  const StepStatistics& ss = sim.core().statistics();
  c.cg_iterations_mean = ss.cg_solves ? static_cast<double>(ss.cg_iterations) / ss.cg_solves : 0.0;
  c.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return c;
}

StabilityExperimentResult run_stability_experiment(const StabilityExperimentSettings& s,
                                                   const std::function<void(double)>& progress) {
  validate(s);
  const auto start = std::chrono::steady_clock::now();
  StabilityExperimentResult r;
  r.settings = s;
  {
    Simulation sim(stability_scene(s, s.methods.front(), s.dts.front(), 0.0));
    VecX x, v;
    stability_perturbation(s, sim.core().model().mesh, sim.core().model().mass, x, v);
    sim.reset_state(x, v);
    const EnergyRow e = sim.energies();
    r.initial_energy = e.kinetic + e.elastic;
  }
  // Work per cell is about proportional to the number of steps: weight progress by it.
  double total = 0, done = 0;
  for (double dt : s.dts) total += s.methods.size() * s.ratios.size() / dt;
  for (const auto& m : s.methods)
    for (double dt : s.dts)
      for (double ratio : s.ratios) {
        r.cells.push_back(run_stability_cell(s, m, dt, ratio));
        done += 1 / dt;
        if (progress) progress(done / total);
      }
  r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

std::string stability_csv(const StabilityExperimentResult& r) {
  std::ostringstream out;
  out << "method,alpha,dt,damping_ratio,stable,reason,unstable_time,rest_time,kappa_max,max_energy_ratio,"
         "final_energy_ratio,final_kinetic_ratio,steps,cg_iterations_mean,wall_seconds\n";
  char buf[512];
  for (const auto& c : r.cells) {
    std::snprintf(buf, sizeof buf, "%s,%.10g,%g,%g,%d,%s,%g,%g,%.6g,%.6g,%.6g,%.6g,%ld,%.3f,%.4f\n", c.method.c_str(),
                  c.alpha, c.dt, c.damping_ratio, c.stable ? 1 : 0, c.reason.c_str(), c.unstable_time, c.rest_time,
                  c.kappa_max, c.max_energy_ratio, c.final_energy_ratio, c.final_kinetic_ratio, c.steps, c.cg_iterations_mean,
                  c.wall_seconds);
    out << buf;
  }
  return out.str();
}

namespace {
std::string cell_text(const StabilityCell& c) {
  char buf[96];
  if (!c.stable) {
    std::snprintf(buf, sizeof buf, "**unstable** (%s, %.2f s)", c.reason.c_str(), c.unstable_time);
  } else if (c.rest_time >= 0) {
    std::snprintf(buf, sizeof buf, "rest %.2f s", c.rest_time);
  } else {
    std::snprintf(buf, sizeof buf, "moving (K %.2g)", c.final_kinetic_ratio);
  }
  std::string text = buf;
  // A stable run whose energy rose noticeably on the way is flagged: it is close to the edge.
  if (c.stable && c.max_energy_ratio > 1.05) {
    std::snprintf(buf, sizeof buf, ", peak E x%.2f", c.max_energy_ratio);
    text += buf;
  }
  return text;
}

std::string list_dts(const std::vector<double>& dts) {
  if (dts.empty()) return "none";
  std::string s;
  for (double dt : dts) {
    if (!s.empty()) s.append(", ");
    s.append(format_number(1e3 * dt)).append(" ms");
  }
  return s;
}
}  // namespace

std::string stability_markdown(const StabilityExperimentResult& r) {
  const auto& s = r.settings;
  std::ostringstream out;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "Square %g m, %dx%d vertices, no gravity, no pins; linear material: stretch %g N/m, shear %g N/m, "
                "density %g kg/m^2, bending %g N m, no material viscosity. Seed %llu; fold %g x size, jitter %g x "
                "edge, velocity %g m/s (rigid motion removed); initial energy %.4g J. Duration %g s; at rest = "
                "kinetic energy below %g x initial energy for %g s. Wall time %.1f s.\n\n",
                s.size_m, s.resolution, s.resolution, s.stretch_modulus_N_m, s.shear_modulus_N_m,
                s.surface_density_kg_m2, s.bending_rigidity_Nm, static_cast<unsigned long long>(s.seed),
                s.fold_fraction, s.jitter_fraction, s.velocity_m_s, r.initial_energy, s.duration_s, s.rest_fraction,
                s.rest_window_s, r.wall_seconds);
  out << buf;
  out << "Cells: `rest T` = came to rest at time T; `moving (K x)` = stable but still moving at the end, "
         "x = final kinetic energy / initial energy; `peak E xN` = "
         "the energy rose to N times its initial value on the way (shown above 1.05); `unstable (reason, T)` = stopped at time T: `nan` "
         "non-finite state, `energy` energy rose above the initial energy scale, `cg` linear solve hit its "
         "iteration cap. kappa max = largest membrane stiffness factor at the start.\n\n";
  for (const auto& m : s.methods) {
    out << "### " << m.label << "\n\n| dt | kappa max |";
    for (double ratio : s.ratios) out << " " << percent(ratio) << " |";
    out << "\n| --- | --- |";
    for (size_t i = 0; i < s.ratios.size(); ++i) out << " --- |";
    out << "\n";
    std::vector<double> zero_fails, five_fails;
    for (double dt : s.dts) {
      std::string row;
      double kappa = 0;
      for (double ratio : s.ratios)
        for (const auto& c : r.cells)
          if (c.method == m.label && c.dt == dt && c.damping_ratio == ratio) {
            row.append(" ").append(cell_text(c)).append(" |");
            kappa = c.kappa_max;
            if (!c.stable && ratio == 0.0) zero_fails.push_back(dt);
            if (!c.stable && std::abs(ratio - 0.05) < 1e-12) five_fails.push_back(dt);
          }
      std::snprintf(buf, sizeof buf, "| %g ms | %.3g |", 1e3 * dt, kappa);
      out << buf << row << "\n";
    }
    out << "\nUnstable with 0%: " << list_dts(zero_fails);
    if (std::find(s.ratios.begin(), s.ratios.end(), 0.05) != s.ratios.end())
      out << ". Unstable with 5%: " << list_dts(five_fails);
    out << ".\n\n";
  }
  return out.str();
}

}  // namespace weft
