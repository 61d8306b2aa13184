#include "weft/experiments/energy_injection.hpp"
#include "sim/simulation_core.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

#include "elements/membrane.hpp"
#include "io/gnuplot.hpp"
#include "weft/error.hpp"

namespace weft {

namespace {

std::array<Vec3, 3> corners(const VecX& x, const std::array<int, 3>& t) {
  return {Vec3(node(x, t[0])), Vec3(node(x, t[1])), Vec3(node(x, t[2]))};
}

Vec3 unit_normal(const std::array<Vec3, 3>& p) {
  const Vec3 n = (p[1] - p[0]).cross(p[2] - p[0]);
  const double len = n.norm();
  return len > 0 ? Vec3(n / len) : Vec3(Vec3::Zero());
}

}  // namespace

InjectionAnalysis analyse_energy_injection(const Scene& configured, const std::string& label) {
  if (configured.integrator.method != Method::kAlphaFamily || configured.integrator.guard)
    throw InputError("energy injection analysis of '" + label +
                     "': needs an unguarded alpha-family method (the step's forces are known only for those)");
  InjectionAnalysis a;
  a.label = label;
  a.alpha = configured.integrator.alpha;
  a.dt = configured.integrator.dt;
  Simulation sim(configured);
  const ClothModel& model = sim.core().model();
  const TriMesh& mesh = model.mesh;
  const size_t nt = mesh.triangles.size();
  a.triangles.resize(nt);
  a.centroids.resize(nt);
  for (size_t t = 0; t < nt; ++t)
    a.centroids[t] = (mesh.corner(t, 0) + mesh.corner(t, 1) + mesh.corner(t, 2)) / 3.0;

  const double dt = configured.integrator.dt;
  const long steps = std::lround(configured.duration / dt);
  const Vec3 no_viscosity = Vec3::Zero();
  const std::array<Vec3, 3> at_rest = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  MembraneResult r0, r1, ra;
  std::vector<double> term(nt);
  double numerical = sim.energies().numerical_dissipated;
  for (long k = 0; k < steps; ++k) {
    const VecX x0 = sim.core().state().x;
    const long newton_before = sim.core().statistics().newton_iterations;
    sim.advance_to(std::min(configured.duration, (k + 1) * dt));
    const VecX& x1 = sim.core().state().x;
    const EnergyRow e = sim.energies();
    if (!x1.allFinite() || !std::isfinite(e.total()) ||
        e.total() - e.contact_work - sim.initial_total_energy() > sim.energy_scale()) {
      a.status = "unstable";
      break;
    }
    const bool newton = sim.core().statistics().newton_iterations > newton_before;
    const VecX dx = x1 - x0;
    double membranes = 0;
    for (size_t t = 0; t < nt; ++t) {
      const auto& tri = mesh.triangles[t];
      const Material& m = model.material_of(t);
      const auto p0 = corners(x0, tri), p1 = corners(x1, tri);
      Eigen::Matrix<double, 9, 1> d;
      for (int c = 0; c < 3; ++c) d.segment<3>(3 * c) = p1[c] - p0[c];
      evaluate_membrane(model.membranes[t], m, no_viscosity, p0, at_rest, !newton, true, r0);
      evaluate_membrane(model.membranes[t], m, no_viscosity, p1, at_rest, false, true, r1);
      double work;  // f_e,step . dx
      if (newton) {
        std::array<Vec3, 3> pa;
        for (int c = 0; c < 3; ++c) pa[c] = p0[c] + a.alpha * (p1[c] - p0[c]);
        evaluate_membrane(model.membranes[t], m, no_viscosity, pa, at_rest, false, true, ra);
        work = ra.force.dot(d);
      } else {
        work = (r0.force + a.alpha * r0.stiffness * d).dot(d);
      }
      term[t] = r1.energy - r0.energy + work;
      membranes += term[t];
      TriangleInjection& ti = a.triangles[t];
      ti.net_J += term[t];
      if (term[t] > 0) ti.created_J += term[t];
      ti.max_strain = std::max(ti.max_strain, r1.strain.cwiseAbs().maxCoeff());
      if (term[t] > ti.largest_J) {
        ti.largest_J = term[t];
        ti.time_of_largest = sim.core().state().t;
        ti.strain_at_largest = r1.strain;
        ti.strain_change_at_largest = r1.strain - r0.strain;
        const double c = std::clamp(unit_normal(p0).dot(unit_normal(p1)), -1.0, 1.0);
        ti.turn_deg_at_largest = std::acos(c) * 180.0 / M_PI;
      }
    }
    const double created = numerical - e.numerical_dissipated;
    numerical = e.numerical_dissipated;
    a.step_time.push_back(sim.core().state().t);
    a.step_created.push_back(created);
    a.step_membranes.push_back(membranes);
    if (created > 0) {
      a.created_total_J += created;
      a.membranes_in_those_J += membranes;
    }
  }
  a.time_reached = sim.core().state().t;
  return a;
}

namespace {

std::string num(double v) { return format_number(v); }

/// Triangle indices ordered by their net term, largest first.
std::vector<size_t> by_net(const InjectionAnalysis& a) {
  std::vector<size_t> order(a.triangles.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t p, size_t q) { return a.triangles[p].net_J > a.triangles[q].net_J; });
  return order;
}

}  // namespace

nlohmann::json energy_injection_json(const InjectionAnalysis& a, int top) {
  nlohmann::json j;
  j["label"] = a.label;
  j["alpha"] = a.alpha;
  j["dt"] = a.dt;
  j["status"] = a.status;
  j["time_reached"] = a.time_reached;
  j["steps"] = a.step_time.size();
  j["created_total_J"] = a.created_total_J;
  j["membranes_in_those_steps_J"] = a.membranes_in_those_J;
  double net = 0, positive = 0;
  long creating = 0;
  for (const auto& t : a.triangles) {
    net += t.net_J;
    positive += std::max(t.net_J, 0.0);
    creating += t.net_J > 0 ? 1 : 0;
  }
  j["membranes_net_J"] = net;
  j["triangles"] = a.triangles.size();
  j["triangles_with_net_creation"] = creating;
  const std::vector<size_t> order = by_net(a);
  // How concentrated the creation is: the share of the triangles' positive net terms that the
  // top 10% of triangles hold.
  double top_share = 0;
  for (size_t k = 0; k < std::max<size_t>(1, order.size() / 10) && k < order.size(); ++k)
    top_share += std::max(a.triangles[order[k]].net_J, 0.0);
  j["top_tenth_share_of_creation"] = positive > 0 ? top_share / positive : 0.0;
  nlohmann::json list = nlohmann::json::array();
  for (int k = 0; k < top && k < static_cast<int>(order.size()); ++k) {
    const size_t t = order[k];
    const TriangleInjection& ti = a.triangles[t];
    list.push_back({{"triangle", t},
                    {"centroid_uv", {a.centroids[t].x(), a.centroids[t].y()}},
                    {"net_J", ti.net_J},
                    {"created_J", ti.created_J},
                    {"largest_step_J", ti.largest_J},
                    {"time_of_largest", ti.time_of_largest},
                    {"strain_at_largest", {ti.strain_at_largest.x(), ti.strain_at_largest.y(), ti.strain_at_largest.z()}},
                    {"strain_change_at_largest",
                     {ti.strain_change_at_largest.x(), ti.strain_change_at_largest.y(), ti.strain_change_at_largest.z()}},
                    {"turn_deg_at_largest", ti.turn_deg_at_largest},
                    {"max_strain", ti.max_strain}});
  }
  j["top_triangles"] = list;
  return j;
}

std::string write_energy_injection(const InjectionAnalysis& a, const std::filesystem::path& dir) {
  std::ostringstream tri;
  tri << "triangle,u,v,net_J,created_J,largest_step_J,time_of_largest,e_uu,e_vv,e_uv,de_uu,de_vv,de_uv,"
         "turn_deg,max_strain\n";
  for (size_t t = 0; t < a.triangles.size(); ++t) {
    const TriangleInjection& ti = a.triangles[t];
    tri << t << ',' << num(a.centroids[t].x()) << ',' << num(a.centroids[t].y()) << ',' << num(ti.net_J) << ','
        << num(ti.created_J) << ',' << num(ti.largest_J) << ',' << num(ti.time_of_largest);
    for (int c = 0; c < 3; ++c) tri << ',' << num(ti.strain_at_largest[c]);
    for (int c = 0; c < 3; ++c) tri << ',' << num(ti.strain_change_at_largest[c]);
    tri << ',' << num(ti.turn_deg_at_largest) << ',' << num(ti.max_strain) << '\n';
  }
  std::ostringstream st;
  st << "time,created_J,membranes_J\n";
  for (size_t k = 0; k < a.step_time.size(); ++k)
    st << num(a.step_time[k]) << ',' << num(a.step_created[k]) << ',' << num(a.step_membranes[k]) << '\n';
  write_files_atomically({pending_text_file(dir / "injection_triangles.csv", tri.str()),
                          pending_text_file(dir / "injection_steps.csv", st.str())});

  std::ostringstream b;
  b << "set datafile separator ','\n"
    << "set multiplot layout 1,3 title "
    << gnuplot_quote("Where " + a.label + " creates energy (dt = " + num(1e3 * a.dt) + " ms)") << "\n"
    << "set title 'net energy created per triangle over the run (J)' font ',9'\n"
    << "set xlabel 'u, weft (m)'\nset ylabel 'v, warp (m; the attached edge at v = 0)'\nset size ratio -1\n"
    << "set palette defined (-1 'blue', 0 'white', 1 'red')\nset cbrange [-1e-30:1e-30]\n"
    << "stats 'injection_triangles.csv' using 4 nooutput\n"
    << "m = (abs(STATS_min) > abs(STATS_max) ? abs(STATS_min) : abs(STATS_max))\n"
    << "set cbrange [-m-1e-30:m+1e-30]\n"
    << "plot 'injection_triangles.csv' every ::1 using 2:3:4 with points pt 5 ps 0.9 palette notitle\n"
    << "set size noratio\nunset cbrange\n"
    << "set title 'per step: energy created, and the membranes terms (J)' font ',9'\n"
    << "set xlabel 'time (s)'\nset ylabel 'J'\nset key top right font ',8'\nset grid\n"
    << "plot 'injection_steps.csv' every ::1 using 1:2 with lines lw 1.5 title 'created (fall of numerical dissipation)', \\\n"
    << "     'injection_steps.csv' every ::1 using 1:3 with lines dt 2 title 'sum of the membranes terms'\n"
    << "set title 'each triangle at its largest step: term vs strain' font ',9'\n"
    << "set xlabel 'largest |strain| at the end of that step'\nset ylabel 'J (largest step)'\nset logscale y\n"
    << "plot 'injection_triangles.csv' every ::1 using ($8 > $9 ? ($8 > abs($10) ? $8 : abs($10)) : ($9 > abs($10) ? $9 : abs($10))):"
       "($6 > 0 ? $6 : NaN) with points pt 7 ps 0.5 notitle\n"
    << "unset multiplot";
  return render_gnuplot_figure(dir, {"injection", b.str(), 1500, 500});
}

}  // namespace weft
