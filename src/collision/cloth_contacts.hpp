#pragma once
// A cloth's contact handling as its steps take it (docs/collisions.md): the colliders'
// contacts, then the cloth's own, added to an integrator in that order. A simulation
// (sim/model_data.cpp) and the sewing of a garment (garment/sewing.cpp) set it up through here.
#include <array>
#include <memory>
#include <vector>

#include "collision/colliders.hpp"
#include "collision/self_contact.hpp"
#include "integrate/integrator.hpp"
#include "weft/mesh.hpp"

namespace weft {

/// Per vertex (of `vertices`), the smallest vertex it is sewn to through `seams`, directly or
/// along a chain (itself when none): the two sides of a seam stand for one point of the cloth
/// to come, so they do not push each other apart. Empty when there are no seams.
std::vector<int> seam_groups(int vertices, const std::vector<Seam>& seams);

/// Cloth-cloth contact as a cloth's keys set it (ClothSpec: self_collision, thickness, friction).
struct SelfCollisionSettings {
  bool on = true;
  double thickness_m = 0.003;  ///< the separation the repulsions keep
  double friction = 0.3;       ///< Coulomb coefficient between layers
};

/// A cloth's contact handlers (the integrator they were added to points at them).
struct ClothContacts {
  std::unique_ptr<ColliderContacts> colliders;  ///< null without colliders
  std::unique_ptr<SelfContacts> self;           ///< null when self-collision is off
};

/// Makes the contact handlers of a cloth (its node masses, the nodes `held` by their own motion
/// that no contact moves, its triangles and rest positions) and adds them to `integrator`: the
/// contacts with `colliders` first, then the cloth-cloth contacts, whose fail-safe sees the
/// colliders' corrections and the nodes they hold, and whose vertices of one seam group
/// (`groups`, from seam_groups; empty: every vertex its own) count as one point.
ClothContacts add_cloth_contacts(Integrator& integrator, const std::vector<std::unique_ptr<Collider>>& colliders,
                                 const VecX& mass, const std::vector<char>& held,
                                 const std::vector<std::array<int, 3>>& triangles, const VecX& rest_positions,
                                 const SelfCollisionSettings& self, const std::vector<int>& groups);

}  // namespace weft
