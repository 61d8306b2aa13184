#pragma once
// Clamps (docs/scene-format.md, cloth "clamps"): groups of cloth vertices moved as rigid bodies
// by prescribed motions. The solve holds each clamped vertex to its prescribed displacement
// (a kinematic contact, integrate/contact.hpp); after the solve the vertex is put exactly on
// its path. The clamps' work on the cloth is booked as contact work.
#include <vector>

#include "integrate/contact.hpp"
#include "weft/collider.hpp"

namespace weft {

class Clamps : public ContactHandler {
 public:
  /// `groups`: per clamp, its vertices; `motions`: per clamp, its motion; `rest_positions`
  /// (3n, m): the vertices' positions at t = 0, which the motions carry. Throws
  /// std::invalid_argument for sizes that do not fit.
  Clamps(std::vector<std::vector<int>> groups, std::vector<RigidMotion> motions, const VecX& rest_positions,
         const VecX& mass);

  void detect(const VecX& x, const VecX& v, double t, double dt, std::vector<NodeContact>& out) override;
  void detect_end(const VecX&, const VecX&, double, double, const std::vector<char>&,
                  std::vector<NodeContact>&) override {}
  /// Puts every clamped vertex on its path at t + dt, moving at the clamp's velocity there.
  void finish_step(const VecX& x0, VecX& x1, VecX& v1, double t, double dt, ContactReport& report) override;
  bool prescribes_motion() const override { return true; }

  /// Per node: in a clamp (n entries).
  const std::vector<char>& clamped() const { return clamped_; }
  /// The position of clamped vertex `node` of clamp `k` at time t, and its velocity.
  Vec3 position(size_t k, int node, double t) const;
  Vec3 velocity(size_t k, int node, double t) const;

 private:
  std::vector<std::vector<int>> groups_;
  std::vector<RigidMotion> motions_;
  VecX rest_, mass_;
  std::vector<char> clamped_;
};

}  // namespace weft
