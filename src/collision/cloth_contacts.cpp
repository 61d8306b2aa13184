#include "collision/cloth_contacts.hpp"

#include <algorithm>
#include <numeric>

namespace weft {

std::vector<int> seam_groups(int vertices, const std::vector<Seam>& seams) {
  if (seams.empty()) return {};
  std::vector<int> group(vertices);
  std::iota(group.begin(), group.end(), 0);
  auto find = [&group](int i) {
    while (group[i] != i) i = group[i] = group[group[i]];
    return i;
  };
  for (const Seam& seam : seams) group[std::max(find(seam.a), find(seam.b))] = std::min(find(seam.a), find(seam.b));
  for (int i = 0; i < vertices; ++i) group[i] = find(i);
  return group;
}

ClothContacts add_cloth_contacts(Integrator& integrator, const std::vector<std::unique_ptr<Collider>>& colliders,
                                 const VecX& mass, const std::vector<char>& held,
                                 const std::vector<std::array<int, 3>>& triangles, const VecX& rest_positions,
                                 const SelfCollisionSettings& self, const std::vector<int>& groups) {
  ClothContacts out;
  if (!colliders.empty()) {
    std::vector<Collider*> list;
    for (const auto& c : colliders) list.push_back(c.get());
    out.colliders = std::make_unique<ColliderContacts>(std::move(list), mass, held, triangles);
    integrator.add_contact_handler(out.colliders.get());
  }
  // Cloth-cloth contact after the colliders': its fail-safe sees their corrections.
  if (self.on) {
    out.self = std::make_unique<SelfContacts>(triangles, rest_positions, mass, held, self.thickness_m, self.friction);
    if (out.colliders) out.self->set_held_nodes(&out.colliders->touching(), &out.colliders->touching_normals());
    if (!groups.empty()) out.self->set_vertex_groups(groups);
    integrator.add_contact_handler(out.self.get());
  }
  return out;
}

}  // namespace weft
