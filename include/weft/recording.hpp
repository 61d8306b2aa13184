#pragma once
// The frames of a run kept for its animations (docs/exports.md): what `weft run` and the Python
// module record at each output frame and write at the end as glb, usda and pc2.
#include <cstddef>
#include <ostream>
#include <string>
#include <vector>

#include "weft/collider.hpp"
#include "weft/exports.hpp"
#include "weft/simulation.hpp"
#include "weft/types.hpp"

namespace weft {

/// The name a run's outputs give collider k: "body<b>" for walking body b, "collider<k>" for
/// another collider (the frames' body<b>_NNNNN.obj and collider<k>_NNNNN.obj files, the
/// animations' nodes).
std::string collider_output_name(const ColliderSpec& spec, size_t k);

class FrameRecording {
 public:
  /// Set up for `sim`'s cloth and colliders. `colliders`: keep the colliders' surfaces (glb,
  /// usda); `viscosity`: keep the cloth's added viscosity per vertex (glb's colours).
  FrameRecording(const Simulation& sim, bool colliders, bool viscosity);
  /// Records `sim`'s state now. `surfaces`: the colliders' surfaces at this time where the
  /// caller has drawn them already (Simulation::collider_surface, one per collider); null:
  /// they are drawn here.
  void add_frame(const Simulation& sim, const std::vector<Points>* surfaces = nullptr);
  size_t frame_count() const { return times_.size(); }
  const std::vector<double>& times() const { return times_; }
  const AnimatedMesh& cloth() const { return cloth_; }
  /// The cloth, then the colliders kept.
  std::vector<const AnimatedMesh*> meshes() const;

  void write_glb(std::ostream& out) const { weft::write_glb(out, meshes(), times_); }
  void write_usda(std::ostream& out) const { weft::write_usda(out, meshes(), times_); }
  void write_pc2(std::ostream& out) const { weft::write_pc2(out, cloth_); }
  void write_rest_obj(std::ostream& out) const { weft::write_rest_obj(out, cloth_); }
  /// The frames so far, for a checkpoint (write_recorded_frames), and back (read_recorded_frames:
  /// the first `frames` of them; throws InputError naming `file` when they do not fit).
  void write_frames(std::ostream& out) const { write_recorded_frames(out, meshes(), times_); }
  void read_frames(const std::string& bytes, const std::string& file, size_t frames);

 private:
  AnimatedMesh cloth_;
  std::vector<AnimatedMesh> colliders_;
  std::vector<double> times_;
  bool viscosity_ = false;
};

}  // namespace weft
