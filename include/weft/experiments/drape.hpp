#pragma once
// The drape test (Cusick drape meter, BS 5058 / ISO 9073-9; docs/fabric-validation.md): a
// circular specimen clamped concentrically on a smaller support disk hangs under gravity to
// rest. Its drape coefficient is the area of its shadow (the vertical projection) outside the
// disk over the specimen's area outside the disk; its nodes are the folds round its edge.
#include <array>
#include <functional>
#include <string>
#include <vector>

#include "weft/mesh.hpp"
#include "weft/material.hpp"

namespace weft {

struct DrapeOptions {
  double specimen_diameter_m = 0.30;
  double support_diameter_m = 0.18;
  double edge_length_m = 0.01;  ///< target edge length of the specimen's mesh
  /// Angle (degrees, counter-clockwise seen from above) from the world x axis to the fabric's
  /// weft: turning the grain turns the material under the same mesh.
  double grain_deg = 0;
  /// The integrator (a scene's integrator.method name) and its step. The drape test wants the
  /// state at rest, not the motion on the way: backward Euler damps the fast modes that
  /// Implicit Midpoint keeps ringing (docs/fabric-validation.md).
  std::string method = "backward-euler";
  double dt_s = 0.005;
  double max_time_s = 8;        ///< simulated time after which the run stops at rest or not
  double frame_interval_s = 0.05;  ///< how often rest is checked and progress reported
  /// At rest: the largest vertex speed has stayed below rest_speed_m_s for rest_time_s.
  double rest_speed_m_s = 0.002;
  double rest_time_s = 0.3;
  /// The specimen starts flat, or (imperfection_m > 0) with its overhang lifted or lowered by a
  /// smooth random wave: height imperfection_m * s * sum_k a_k cos(k theta + phi_k) / sum_k |a_k|
  /// over k = 1..12, s = 0 at the disk's edge rising linearly to 1 at the specimen's, a_k and
  /// phi_k drawn from imperfection_seed. A real specimen is never flat nor the fabric uniform;
  /// a perfectly flat start keeps the material's fourfold symmetry in the folds.
  double imperfection_m = 0;
  unsigned imperfection_seed = 1;
  std::string bending_model = "hinge";
  /// Cloth-cloth contact. Off by default: a Cusick specimen's folds do not touch, and with the
  /// default contact thickness (3 mm) on meshes finer than about 1 cm the repulsion between
  /// vertices of one fold crumples it (docs/fabric-validation.md).
  bool self_collision = false;
  double pixel_m = 0.0005;      ///< raster pixel of the shadow area
  /// A fold is a maximum of the edge's distance from the axis that stands out by at least
  /// this fraction of the distance's whole range (and by 2 mm).
  double node_prominence = 0.2;
};

struct DrapeResult {
  double drape_coefficient = 0;
  double shadow_area_m2 = 0;    ///< the specimen's vertical projection, support disk included
  double specimen_area_m2 = 0;  ///< pi R^2
  double support_area_m2 = 0;   ///< pi r^2
  int nodes = 0;
  std::vector<double> node_angles_deg;   ///< where the folds stand out, from the x axis
  std::vector<double> edge_angle_deg;    ///< the edge's vertices round the specimen ...
  std::vector<double> edge_radius_m;     ///< ... and their horizontal distance from the axis
  double min_radius_m = 0, max_radius_m = 0;
  double simulated_time_s = 0;
  bool at_rest = false;
  double max_speed_m_s = 0;     ///< at the end
  std::string status = "ok";    ///< "ok" or "unstable" (non-finite positions)
  int vertices = 0, triangles = 0, pinned = 0;
  long steps = 0;
  double wall_seconds = 0;
  TriMesh mesh;                 ///< the specimen at the end (Y up, support disk at y = 0)
};

/// The specimen's mesh: a disk of the specimen's diameter in the y = 0 plane (Y up) whose
/// vertices include a ring on the support disk's edge; `support` receives the vertices on or
/// inside the support disk and `edge` the outer boundary's vertices in counter-clockwise order.
TriMesh drape_specimen_mesh(const DrapeOptions& options, std::vector<int>& support, std::vector<int>& edge);

/// Area (m^2) of the union of the triangles' projections on the horizontal (x, z) plane,
/// counted on a raster of pixel_m pixels (a pixel counts when its centre is covered).
double projected_area(const Points& positions, const std::vector<std::array<int, 3>>& triangles, double pixel_m);

/// The folds of a closed profile (the edge's distance from the axis, in order round it): the
/// maxima whose prominence (height above the higher of the lowest points between it and a
/// higher point on either side, round the circle) is at least min_prominence. Returns their
/// indices.
std::vector<int> profile_nodes(const std::vector<double>& radius, double min_prominence);

using DrapeProgress = std::function<void(double fraction)>;

/// Drapes the specimen: the vertices on the support disk are pinned (the meter clamps the
/// specimen between two disks), the rest falls under gravity from flat until at rest or
/// max_time_s. Throws InputError for bad options, naming them as the command's flags.
DrapeResult run_drape_test(const Material& material, const DrapeOptions& options, const DrapeProgress& progress = {});

}  // namespace weft
