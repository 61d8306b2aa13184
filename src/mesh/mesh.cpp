#include "mesh/mesh.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>

#include "weft/error.hpp"

namespace weft {

TriMesh make_grid(double size_u, double size_v, int nu, int nv, GridPattern pattern) {
  TriMesh m;
  m.positions.resize(nu * nv, 3);
  m.pattern.resize(nu * nv);
  const bool shifted = pattern == GridPattern::kShiftedRows;
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const double u = size_u * (i + (shifted && j % 2 ? 0.5 : 0.0)) / (nu - 1), v = size_v * j / (nv - 1);
      m.positions.row(j * nu + i) = Vec3(u, v, 0).transpose();
      m.pattern[j * nu + i] = Vec2(u, v);
    }
  for (int j = 0; j + 1 < nv; ++j)
    for (int i = 0; i + 1 < nu; ++i) {
      const int a = j * nu + i, b = a + 1, c = a + nu, d = c + 1;
      if (shifted) {
        // Split along the diagonal that joins the rows' nearest vertices.
        if (j % 2 == 0) {
          m.triangles.push_back({a, b, c});
          m.triangles.push_back({b, d, c});
        } else {
          m.triangles.push_back({a, d, c});
          m.triangles.push_back({a, b, d});
        }
      } else if ((i + j) % 2 == 0) {
        m.triangles.push_back({a, b, d});
        m.triangles.push_back({a, d, c});
      } else {
        m.triangles.push_back({a, b, c});
        m.triangles.push_back({b, d, c});
      }
    }
  return m;
}

std::vector<int> banded_order(const TriMesh& mesh) {
  const int n = mesh.num_vertices();
  // Connected pieces (union-find over the triangles' edges) and the median edge length.
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  // The band height: the median rise |dv| of the edges that cross rows (rise above a quarter
  // of their length), the row spacing on a grid.
  std::vector<double> rises;
  rises.reserve(3 * mesh.triangles.size());
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      parent[find(a)] = find(b);
      const Vec2 d = mesh.pattern[a] - mesh.pattern[b];
      if (std::abs(d.y()) > 0.25 * d.norm()) rises.push_back(std::abs(d.y()));
    }
  double h = 1.0;
  if (!rises.empty()) {
    std::nth_element(rises.begin(), rises.begin() + rises.size() / 2, rises.end());
    if (rises[rises.size() / 2] > 0) h = rises[rises.size() / 2];
  }
  std::vector<int> piece(n), rank(n, -1);
  std::vector<double> v_min;
  for (int i = 0; i < n; ++i) {
    const int root = find(i);
    if (rank[root] < 0) {
      rank[root] = static_cast<int>(v_min.size());
      v_min.push_back(mesh.pattern[i].y());
    }
    piece[i] = rank[root];
    v_min[piece[i]] = std::min(v_min[piece[i]], mesh.pattern[i].y());
  }
  std::vector<long> band(n);
  for (int i = 0; i < n; ++i) band[i] = std::lround((mesh.pattern[i].y() - v_min[piece[i]]) / h);
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    if (piece[a] != piece[b]) return piece[a] < piece[b];
    if (band[a] != band[b]) return band[a] < band[b];
    if (mesh.pattern[a].x() != mesh.pattern[b].x()) return mesh.pattern[a].x() < mesh.pattern[b].x();
    return a < b;
  });
  return order;
}

std::vector<std::array<int, 4>> interior_edge_stencils(const TriMesh& mesh) {
  std::map<std::pair<int, int>, std::pair<int, int>> edge_tips;  // (min,max) -> (tip, tip)
  std::vector<std::array<int, 4>> out;
  for (const auto& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const int c = t[k], d = t[(k + 1) % 3], tip = t[(k + 2) % 3];
      auto key = std::minmax(c, d);
      auto it = edge_tips.find(key);
      if (it == edge_tips.end()) {
        edge_tips[key] = {tip, -1};
      } else if (it->second.second < 0) {
        it->second.second = tip;
      } else {
        it->second.second = -2;  // non-manifold edge: no bending stencil
      }
    }
  }
  for (const auto& [edge, tips] : edge_tips)
    if (tips.second >= 0) out.push_back({tips.first, tips.second, edge.first, edge.second});
  return out;
}

std::vector<FlatStencil> interior_edge_flat_stencils(const TriMesh& mesh) {
  // Per edge (min, max): the triangles on it (a third marks it non-manifold).
  std::map<std::pair<int, int>, std::array<int, 2>> edge_triangles;
  for (size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const auto key = std::minmax(mesh.triangles[t][k], mesh.triangles[t][(k + 1) % 3]);
      auto [it, inserted] = edge_triangles.try_emplace(key, std::array<int, 2>{static_cast<int>(t), -1});
      if (!inserted) it->second[1] = it->second[1] == -1 ? static_cast<int>(t) : -2;
    }
  auto corner_of = [&](int t, int vertex) {
    for (int k = 0; k < 3; ++k)
      if (mesh.triangles[t][k] == vertex) return k;
    return -1;
  };
  auto tip_of = [&](int t, int c, int d) {
    for (int k = 0; k < 3; ++k)
      if (mesh.triangles[t][k] != c && mesh.triangles[t][k] != d) return k;
    return -1;
  };
  std::vector<FlatStencil> out;
  for (const auto& [edge, tris] : edge_triangles) {
    if (tris[1] < 0) continue;
    const int c = edge.first, d = edge.second, t1 = tris[0], t2 = tris[1];
    const int ka = tip_of(t1, c, d), kb = tip_of(t2, c, d);
    FlatStencil s;
    s.vertices = {mesh.triangles[t1][ka], mesh.triangles[t2][kb], c, d};
    s.triangles = {t1, t2};
    const Vec2 a = mesh.corner(t1, ka), c1 = mesh.corner(t1, corner_of(t1, c)), d1 = mesh.corner(t1, corner_of(t1, d));
    const Vec2 b = mesh.corner(t2, kb), c2 = mesh.corner(t2, corner_of(t2, c)), d2 = mesh.corner(t2, corner_of(t2, d));
    if (c1 == c2 && d1 == d2) {
      s.pattern = {a, b, c1, d1};
    } else {
      // Turn triangle 2 about its edge's midpoint onto triangle 1's edge; the edge takes the
      // mean of its two lengths.
      const Vec2 m1 = 0.5 * (c1 + d1), m2 = 0.5 * (c2 + d2);
      const Vec2 e1 = d1 - c1, e2 = d2 - c2;
      const double l1 = e1.norm(), l2 = e2.norm();
      if (!(l1 > 0) || !(l2 > 0)) continue;
      const Vec2 u1 = e1 / l1, u2 = e2 / l2;
      const double cs = u1.dot(u2), sn = u2.x() * u1.y() - u2.y() * u1.x();  // rotation u2 -> u1
      const Vec2 r = b - m2;
      const Vec2 b_flat = m1 + Vec2(cs * r.x() - sn * r.y(), sn * r.x() + cs * r.y());
      const double half = 0.25 * (l1 + l2);
      s.pattern = {a, b_flat, m1 - half * u1, m1 + half * u1};
    }
    out.push_back(s);
  }
  return out;
}

}  // namespace weft
