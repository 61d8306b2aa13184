#include "weft/recording.hpp"

namespace weft {

std::string collider_output_name(const ColliderSpec& spec, size_t k) {
  return spec.shape == ColliderShape::kBody ? "body" + std::to_string(spec.body) : "collider" + std::to_string(k);
}

FrameRecording::FrameRecording(const Simulation& sim, bool colliders, bool viscosity) : viscosity_(viscosity) {
  const TriMesh& mesh = sim.mesh();
  cloth_.name = "cloth";
  cloth_.triangles = mesh.triangles;
  // Texture coordinates in the units of the cloth's OBJ texture coordinates (metres on a grid).
  cloth_.texcoords = pattern_texcoords(mesh.pattern, sim.scene().cloth.uv_scale);
  cloth_.vertex_count = mesh.num_vertices();
  if (!colliders) return;
  colliders_.resize(sim.collider_count());
  for (size_t k = 0; k < colliders_.size(); ++k) {
    Points positions;
    Triangles triangles;
    sim.collider_surface(k, sim.time(), positions, triangles);
    colliders_[k].name = collider_output_name(sim.collider(k), k);
    colliders_[k].triangles = triangle_list(triangles);
  }
}

void FrameRecording::add_frame(const Simulation& sim, const std::vector<Points>* surfaces) {
  const VecX eta = viscosity_ ? sim.added_viscosity_per_vertex() : VecX();
  cloth_.add_frame(sim.positions().data(), sim.vertex_count(), viscosity_ ? eta.data() : nullptr);
  for (size_t k = 0; k < colliders_.size(); ++k) {
    Points drawn;
    if (!surfaces) {
      Triangles triangles;
      sim.collider_surface(k, sim.time(), drawn, triangles);
    }
    const Points& positions = surfaces ? (*surfaces)[k] : drawn;
    colliders_[k].add_frame(positions.data(), static_cast<int>(positions.rows()));
  }
  times_.push_back(sim.time());
}

std::vector<const AnimatedMesh*> FrameRecording::meshes() const {
  std::vector<const AnimatedMesh*> out{&cloth_};
  for (const AnimatedMesh& c : colliders_) out.push_back(&c);
  return out;
}

void FrameRecording::read_frames(const std::string& bytes, const std::string& file, size_t frames) {
  std::vector<AnimatedMesh*> out{&cloth_};
  for (AnimatedMesh& c : colliders_) out.push_back(&c);
  read_recorded_frames(bytes, file, out, times_, frames);
}

}  // namespace weft
