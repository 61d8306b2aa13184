#pragma once
// A validated scene (docs/scene-format.md): what to simulate, for how long, and how.
#include <nlohmann/json.hpp>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "weft/collider.hpp"
#include "weft/material.hpp"
#include "weft/mesh.hpp"
#include "weft/placement_spec.hpp"
#include "weft/settings.hpp"
#include "weft/types.hpp"

namespace weft {

constexpr int kSceneFormatVersion = 1;

// Bounds on scene values (docs/scene-format.md): beyond them a value is a mistake, not a
// cloth, and is refused as bad input rather than left to blow up a run.
constexpr double kMaxLength_m = 1e4;        ///< grid sizes, translations, cloth OBJ coordinates
constexpr double kMaxRotation_deg = 3600;   ///< placement rotation angles (ten turns)
constexpr double kMaxSpeed_m_s = 1e3;       ///< initial velocity components
constexpr double kMaxGravity_m_s2 = 1e3;    ///< gravity components (about 100 g)
constexpr long kMaxGridVertices = 4'000'000;  ///< vertices of a grid, both sides together

// The memory a run needs per vertex of its mesh: the peak resident size of `weft run` on grids
// of 200 x 200 to 700 x 700 vertices is 5.15-5.35 kB per vertex (two triangles per vertex,
// as on any large mesh of a surface), docs/scene-format.md. And the most a run may need: about
// 2.9 million vertices, which take hours per simulated second on a workstation.
constexpr double kRunBytesPerVertex = 5500;
constexpr double kMaxRunBytes = 16e9;

struct GridSpec {
  double size_u = 1, size_v = 1;  ///< metres
  int vertices_u = 2, vertices_v = 2;
  GridPattern pattern = GridPattern::kAlternatingDiagonals;
};

/// Cloth vertices moved as one rigid body by a prescribed motion (a clamp that turns or
/// travels): they follow motion.at(t) applied to their starting positions.
struct ClampSpec {
  std::vector<int> vertices;                    ///< explicit vertex indices
  std::vector<std::pair<int, int>> grid_nodes;  ///< (i, j) on a grid, negative counts from the end
  RigidMotion motion;
};

/// A garment made from a sewing pattern (cloth.mesh.pattern): meshed, placed around the
/// scene's first body in its bind pose and sewn while the scene is set up (docs/garments.md).
struct GarmentSpec {
  std::string pattern_file;                 ///< absolute, resolved against the scene
  double edge_length_m = 0.015;
  double clearance_m = 0.02;
  /// Per panel: the body part, the direction it faces and a shift along the part's axis.
  std::map<std::string, PanelPlacementOverride> panels;
  /// Per panel: its fabric (panels.NAME.material); a panel not named takes the cloth's material.
  std::map<std::string, Material> panel_materials;
  /// Per panel: its grain (panels.NAME.grain_deg), degrees counter-clockwise from the
  /// pattern's y axis to the warp; a panel not named has its warp along y.
  std::map<std::string, double> panel_grain_deg;
  double seam_stiffness_N_m = 1e4;
  double sewing_time_s = 0.5;
  /// The most a vertex moves in one sewing step (SewingOptions::max_step_motion_m): absent, the
  /// sewing's default; 0, no limit.
  std::optional<double> sewing_step_limit_m;
  /// Run the garment even when it does not sew (a stitch left open, an intersection left):
  /// a warning then, in place of the refusal (SewingError).
  bool allow_open_seams = false;
};

struct ClothSpec {
  std::optional<GridSpec> grid;    ///< either a grid ...
  std::string obj_path;            ///< ... or an OBJ file (absolute, resolved against the scene)
  std::optional<GarmentSpec> garment;  ///< ... or a garment sewn from a pattern
  /// ... or a mesh made in code (a garment being sewn); it comes first when set.
  std::shared_ptr<const TriMesh> mesh;
  /// Zero-length springs pulling pairs of vertices together (sewing; set in code).
  std::vector<Seam> seams;
  /// With `mesh`: a material per triangle in place of `material` (a garment being sewn; set in
  /// code). Empty materials: `material` everywhere.
  TriangleMaterials triangle_materials;
  double uv_scale = 1.0;           ///< metres per OBJ texture unit
  Vec3 rotation_deg = Vec3::Zero();  ///< applied X, then Y, then Z
  Vec3 translation = Vec3::Zero();
  Vec3 initial_velocity = Vec3::Zero();
  Material material;
  std::string bending_model = "hinge";  ///< "hinge" or "plate" (docs/scene-format.md)
  std::vector<int> pin_vertices;                  ///< explicit vertex indices
  std::vector<std::pair<int, int>> pin_grid_nodes;///< (i, j) on a grid, negative counts from the end
  double thickness = 0.003;      ///< m: cloth-cloth separation kept by self-collision
  double friction = 0.3;         ///< Coulomb coefficient of cloth-cloth contact
  bool self_collision = true;
  std::vector<ClampSpec> clamps;
};

struct Scene {
  std::string file;                ///< where it was read from ("" when built in code)
  std::string description;
  double duration = 6.0;           ///< s
  double frame_interval = 0.02;    ///< s between output frames
  Vec3 gravity{0, -9.81, 0};
  std::string method_name = "implicit-midpoint";
  IntegratorSettings integrator;
  /// Adaptive damping ratio; unset = the method's default (5% for Implicit Midpoint and
  /// BDF-2 variants, 0 otherwise).
  std::optional<double> damping_ratio;
  ClothSpec cloth;
  ContactSettings contacts;        ///< the contact handling's tunables (`contacts`)
  /// Colliders in file order (docs/scene-format.md); those of type "body" point into `bodies`.
  std::vector<ColliderSpec> colliders;
  /// The body colliders' descriptions: the walking mannequin (docs/body.md).
  std::vector<BodyColliderSpec> bodies;
  /// output.formats: what `weft run` writes (checked_output_formats, weft/exports.hpp); empty
  /// when the scene does not say (then OBJ frames).
  std::vector<std::string> output_formats;

  /// The damping ratio that applies (explicit value or the method's default).
  double effective_damping_ratio() const;
  int steps_per_frame() const;  ///< frame_interval / dt (fixed-step methods)
};

/// The default adaptive damping ratio of a method.
double default_damping_ratio(Method method, double alpha);

/// Reads and validates a scene file. Throws InputError naming the file, key and value.
Scene load_scene(const std::string& path);
/// Reads a scene from its JSON text; `file` names it in messages, relative paths in it are
/// relative to `base_dir`.
Scene parse_scene_text(std::string_view text, const std::string& file, const std::string& base_dir);
Scene parse_scene(const nlohmann::json& j, const std::string& file, const std::string& base_dir);

/// Sets method and alpha by name (alpha only where the method takes one); validates.
/// `where` prefixes error messages.
void set_method(Scene& scene, const std::string& name, std::optional<double> alpha, const std::string& where);
/// Re-checks the timing fields after overrides (dt > 0, frame interval a multiple of dt...).
void validate_timing(const Scene& scene, const std::string& where);

/// Settings that replace a scene's (`weft run`'s options); unset ones leave the scene's.
struct SceneOverrides {
  std::string method;                    ///< a name of method_table(); "" keeps the scene's
  std::optional<double> alpha;           ///< where the method takes one
  std::optional<double> dt, duration;    ///< s
  /// The linear solves' relative residual, or RK45's local error tolerance for rk45.
  std::optional<double> tolerance;
  std::optional<double> damping_ratio;   ///< adaptive damping target, [0, 10]
  std::optional<double> newton;          ///< Newton iterations per step, an integer in [0, 100]
  std::string preconditioner;            ///< auto, block-jacobi, ssor or multigrid; "" keeps the scene's
};
/// Applies `overrides` to `scene` and validates the result (set_method, validate_timing); throws
/// InputError naming `where`, the override (as weft run's option) and the value for an unknown
/// method or preconditioner, a Newton count that is not an integer from 0 to 100, and whatever
/// validate_timing refuses.
void apply_overrides(Scene& scene, const SceneOverrides& overrides, const std::string& where);

/// Bytes a run of a mesh with this many vertices needs (estimate).
double estimated_run_bytes(long vertices);
/// Throws InputError "WHAT (N vertices) needs about X GB to simulate, more than ..." when the
/// estimate exceeds kMaxRunBytes or the machine's physical memory.
void check_memory_estimate(long vertices, const std::string& what);

/// The cloth mesh placed in the world (grid generated or OBJ read) and the pinned vertices.
TriMesh build_cloth_mesh(const ClothSpec& spec);
std::vector<int> resolve_pins(const ClothSpec& spec, const TriMesh& mesh);
/// The vertices of each clamp (in spec.clamps' order). Throws InputError for a vertex that
/// does not exist, or one pinned or in two clamps, naming the key.
std::vector<std::vector<int>> resolve_clamps(const ClothSpec& spec, const TriMesh& mesh, const std::vector<int>& pins);

}  // namespace weft
