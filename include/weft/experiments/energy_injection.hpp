#pragma once
// Where an alpha-family step creates energy: the step's energy balance split among the
// membrane triangles (docs/results.md, "Energy created").
//
// For a step without contacts, with the forces the step applied f_step = f(x0) + alpha K(x0) dx
// (+ viscous and gravity; K the assembled, projected Jacobian) and dx = dt (v0 + alpha dv), the
// kinetic energy changes by f_step . dx + (1/2 - alpha) dv^T M dv, gravity's energy by exactly
// -f_gravity . dx and the viscous work booked is -f_viscous,step . dx (docs/method.md 6). So the
// energy the step created, minus the fall of the numerical dissipation, is
//   sum over elements e of [E_e(x1) - E_e(x0) + f_e,step . dx]  -  (alpha - 1/2) dv^T M dv.
// The membranes' terms are computed here per triangle; what they do not explain (bending,
// which is linear and only takes energy out for alpha >= 1/2, the kinetic term, contacts and
// the linear solve's tolerance) is reported as the rest. A step that Newton iterations solved
// (IntegratorSettings::newton_iterations) applied f(x_a) at x_a = x0 + alpha dx instead.
#include <filesystem>
#include <string>
#include <vector>

#include "weft/experiments/trajectory.hpp"

namespace weft {

/// One triangle's terms over a run.
struct TriangleInjection {
  double net_J = 0;                ///< sum over the steps (positive: energy created)
  double created_J = 0;            ///< sum over the steps where the term is positive
  double largest_J = 0;            ///< the largest single step's term
  double time_of_largest = 0;      ///< the end of that step (s)
  Vec3 strain_at_largest = Vec3::Zero();  ///< (e_uu, e_vv, e_uv) at the end of that step
  Vec3 strain_change_at_largest = Vec3::Zero();  ///< their change over that step
  double turn_deg_at_largest = 0;  ///< the angle the triangle's normal turned in that step
  double max_strain = 0;           ///< the largest |e_uu|, |e_vv|, |e_uv| over the run
};

struct InjectionAnalysis {
  std::string label;     ///< the configuration analysed
  double alpha = 0.5;
  double dt = 0;
  std::string status = "ok";  ///< "unstable" when it stopped early
  double time_reached = 0;
  std::vector<TriangleInjection> triangles;  ///< per mesh triangle
  std::vector<Vec2> centroids;               ///< pattern coordinates of each triangle's centroid (m)
  std::vector<double> step_time;             ///< end of each step (s)
  std::vector<double> step_created;          ///< fall of the numerical dissipation over each step (J)
  std::vector<double> step_membranes;        ///< the sum of the triangles' terms over each step (J)
  double created_total_J = 0;     ///< sum of the positive step_created
  double membranes_in_those_J = 0;  ///< sum of step_membranes over those steps
};

/// Steps `configured` (an alpha-family method, e.g. from configure_scene) to its duration, or
/// until it becomes unstable, recording every triangle's term at every step. Throws
/// InputError for a method outside the alpha family.
InjectionAnalysis analyse_energy_injection(const Scene& configured, const std::string& label);

/// Writes DIR/injection_triangles.csv, DIR/injection_steps.csv and the figure
/// DIR/injection.{gp,png,svg}; returns a warning when gnuplot is missing ("" otherwise).
std::string write_energy_injection(const InjectionAnalysis& a, const std::filesystem::path& dir);

/// The summary of the analysis for results.json: totals, the share of the membranes, and the
/// triangles that created the most (their strains and turns at their largest step).
nlohmann::json energy_injection_json(const InjectionAnalysis& a, int top = 10);

}  // namespace weft
