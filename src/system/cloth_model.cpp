// The cloth's model from its mesh and materials: masses, pins, elements and the block pattern
// (build_cloth_model).
#include "system/cloth.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "weft/error.hpp"

namespace weft {

VecX ClothModel::initial_positions() const {
  VecX x(3 * num_vertices());
  for (int i = 0; i < num_vertices(); ++i) node(x, i) = mesh.positions.row(i).transpose();
  return x;
}

BendingModel parse_bending_model(const std::string& name, const std::string& where) {
  if (name == "plate") return BendingModel::kPlate;
  if (name == "hinge") return BendingModel::kHinge;
  throw InputError(where + ": unknown bending model '" + name + "' (expected plate or hinge)");
}

ClothModel build_cloth_model(TriMesh mesh, const Material& material, const Vec3& gravity,
                             const std::vector<int>& pins, BendingModel bending,
                             const std::vector<Seam>& seams) {
  return build_cloth_model(std::move(mesh), TriangleMaterials{{material}, {}}, gravity, pins, bending, seams);
}

ClothModel build_cloth_model(TriMesh mesh, const TriangleMaterials& materials, const Vec3& gravity,
                             const std::vector<int>& pins, BendingModel bending,
                             const std::vector<Seam>& seams) {
  ClothModel m;
  m.gravity = gravity;
  const int n = mesh.num_vertices();
  if (materials.materials.empty()) throw InputError("the cloth has no material");
  if (!materials.index.empty() && materials.index.size() != mesh.triangles.size())
    throw InputError("the cloth has materials for " + std::to_string(materials.index.size()) + " triangles, the mesh has " +
                     std::to_string(mesh.triangles.size()));
  for (const Material& material : materials.materials)
    if (!(material.surface_density_kg_m2 > 0))
      throw InputError("material surface density must be positive, got " +
                       std::to_string(material.surface_density_kg_m2));
  // The distinct materials the triangles use, in order of first use, and each triangle's
  // index into them; one material leaves the index empty.
  std::vector<int> distinct_of(materials.materials.size(), -1);
  std::vector<int> triangle_material(mesh.triangles.size(), 0);
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const int k = materials.index.empty() ? 0 : materials.index[t];
    if (k < 0 || static_cast<size_t>(k) >= materials.materials.size())
      throw InputError("triangle " + std::to_string(t) + " has material " + std::to_string(k) + ", the cloth has " +
                       std::to_string(materials.materials.size()));
    int& d = distinct_of[static_cast<size_t>(k)];
    for (size_t e = 0; e < m.materials.size() && d < 0; ++e)
      if (same_parameters(materials.materials[static_cast<size_t>(k)], m.materials[e])) d = static_cast<int>(e);
    if (d < 0) {
      d = static_cast<int>(m.materials.size());
      m.materials.push_back(materials.materials[static_cast<size_t>(k)]);
    }
    triangle_material[t] = d;
  }
  if (m.materials.empty()) m.materials.push_back(materials.materials.front());  // a mesh without triangles
  if (m.materials.size() > 1) m.triangle_material = std::move(triangle_material);
  m.mass = VecX::Zero(n);
  m.membranes.resize(mesh.triangles.size());
  std::vector<std::pair<int, int>> pairs;
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k)
      if (tri[k] < 0 || tri[k] >= n)
        throw InputError("triangle " + std::to_string(t) + " refers to vertex " + std::to_string(tri[k]) +
                         ", the mesh has " + std::to_string(n));
    if (!make_membrane_geometry(mesh.corner(t, 0), mesh.corner(t, 1), mesh.corner(t, 2), m.membranes[t]))
      throw InputError("triangle " + std::to_string(t) + " (vertices " + std::to_string(tri[0]) + ", " +
                       std::to_string(tri[1]) + ", " + std::to_string(tri[2]) +
                       ") is degenerate in the pattern (zero area)");
    const double density = m.material_of(t).surface_density_kg_m2;
    for (int k = 0; k < 3; ++k) m.mass[tri[k]] += density * m.membranes[t].area / 3.0;
    for (int a = 0; a < 3; ++a)
      for (int b = a + 1; b < 3; ++b) pairs.emplace_back(tri[a], tri[b]);
  }
  for (int i = 0; i < n; ++i)
    if (!(m.mass[i] > 0)) throw InputError("vertex " + std::to_string(i) + " belongs to no triangle");
  m.pinned.assign(n, 0);
  for (int p : pins) {
    if (p < 0 || p >= n)
      throw InputError("pin refers to vertex " + std::to_string(p) + ", the mesh has " + std::to_string(n) + " vertices");
    m.pinned[p] = 1;
  }
  m.inverse_mass = m.mass.cwiseInverse();
  for (int i = 0; i < n; ++i)
    if (m.pinned[i]) m.inverse_mass[i] = 0.0;

  if (bending == BendingModel::kHinge) {
    for (const auto& s : interior_edge_flat_stencils(mesh)) {
      // A hinge across a seam between two materials takes the mean of their rigidities (the
      // same value when both sides are of one material).
      const Material &m1 = m.material_of(static_cast<size_t>(s.triangles[0])),
                     &m2 = m.material_of(static_cast<size_t>(s.triangles[1]));
      const double weft = 0.5 * (m1.bending_rigidity_weft_Nm + m2.bending_rigidity_weft_Nm);
      const double warp = 0.5 * (m1.bending_rigidity_warp_Nm + m2.bending_rigidity_warp_Nm);
      BendingGeometry g;
      if (!make_bending_geometry(s.pattern[0], s.pattern[1], s.pattern[2], s.pattern[3], weft, warp, g))
        continue;  // a degenerate hinge carries no bending stiffness
      m.bending.push_back(hinge_stencil(s.vertices, g));
    }
  } else {
    if (!mesh.corner_pattern.empty())
      throw InputError("the plate bending element needs one pattern place per vertex; a mesh sewn from several "
                       "pieces (a vertex with two texture coordinates) takes the hinge element");
    if (m.materials.size() > 1)
      throw InputError("the plate bending element takes one material; a cloth of several materials takes the hinge "
                       "element");
    const Material& material = m.materials.front();
    m.bending = plate_bending_stencils(mesh, material.bending_rigidity_weft_Nm, material.bending_rigidity_warp_Nm);
  }
  // Seams: zero-length springs, E = k/2 |x_i - x_j|^2, one linear stencil each.
  for (const Seam& seam : seams) {
    if (seam.a < 0 || seam.a >= n || seam.b < 0 || seam.b >= n || seam.a == seam.b)
      throw InputError("seam joins vertices " + std::to_string(seam.a) + " and " + std::to_string(seam.b) +
                       ", the mesh has " + std::to_string(n));
    LinearBendingStencil st;
    st.vertices = {seam.a, seam.b};
    st.measures = MatX(1, 2);
    st.measures << 1.0, -1.0;
    st.weights = VecX::Constant(1, seam.stiffness_N_m);
    st.finish();
    m.bending.push_back(std::move(st));
  }
  for (const auto& b : m.bending)
    for (size_t a = 0; a < b.vertices.size(); ++a)
      for (size_t c = a + 1; c < b.vertices.size(); ++c) pairs.emplace_back(b.vertices[a], b.vertices[c]);
  m.mesh = std::move(mesh);
  m.pattern = BlockPattern(n, pairs);
  for (size_t t = 0; t < m.membranes.size(); ++t) {
    const auto& tri = m.mesh.triangles[t];
    std::array<int, 9> slots;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) slots[3 * a + b] = m.pattern.slot(tri[a], tri[b]);
    m.membrane_slots.push_back(slots);
    const Vec3 inv(m.inverse_mass[tri[0]], m.inverse_mass[tri[1]], m.inverse_mass[tri[2]]);
    m.membrane_mass_sums.push_back(membrane_mass_sums(m.membranes[t].ru, m.membranes[t].rv, inv));
  }
  for (const auto& b : m.bending) {
    const size_t k = b.vertices.size();
    std::vector<int> slots(k * k);
    for (size_t a = 0; a < k; ++a)
      for (size_t c = 0; c < k; ++c) slots[k * a + c] = m.pattern.slot(b.vertices[a], b.vertices[c]);
    m.bending_slots.push_back(std::move(slots));
    m.bending_mass_sums.push_back(b.stiffness_mass_sum(m.inverse_mass));
  }
  m.bending_slot_q.assign(m.pattern.num_blocks(), 0.0);
  for (size_t e = 0; e < m.bending.size(); ++e) {
    const auto& b = m.bending[e];
    const Eigen::Index k = b.Q.rows();
    for (Eigen::Index a = 0; a < k; ++a)
      for (Eigen::Index c = 0; c < k; ++c) m.bending_slot_q[m.bending_slots[e][k * a + c]] += b.Q(a, c);
  }
  m.solver_order = banded_order(m.mesh);
  return m;
}

}  // namespace weft
