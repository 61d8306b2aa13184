#include "elements/plate_bending.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "weft/error.hpp"

namespace weft {

std::vector<LinearBendingStencil> plate_bending_stencils(const TriMesh& mesh, double rigidity_weft_Nm,
                                                         double rigidity_warp_Nm) {
  const int n = mesh.num_vertices();
  // Opposite vertex across each edge, and each vertex's neighbours.
  std::map<std::pair<int, int>, std::vector<int>> edge_tips;
  std::vector<std::set<int>> neighbours(n);
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3], c = t[(k + 2) % 3];
      edge_tips[std::minmax(a, b)].push_back(c);
      neighbours[a].insert(b);
      neighbours[a].insert(c);
    }
  const double twist = std::sqrt(rigidity_weft_Nm * rigidity_warp_Nm);
  std::vector<double> triangle_area(mesh.triangles.size());
  for (size_t ti = 0; ti < mesh.triangles.size(); ++ti) {
    const auto& t = mesh.triangles[ti];
    const Vec2 e1 = mesh.pattern[t[1]] - mesh.pattern[t[0]], e2 = mesh.pattern[t[2]] - mesh.pattern[t[0]];
    triangle_area[ti] = 0.5 * std::abs(e1.x() * e2.y() - e1.y() * e2.x());
  }
  // Triangles on each edge.
  std::map<std::pair<int, int>, std::vector<int>> edge_triangles;
  for (size_t ti = 0; ti < mesh.triangles.size(); ++ti)
    for (int k = 0; k < 3; ++k) edge_triangles[std::minmax(mesh.triangles[ti][k], mesh.triangles[ti][(k + 1) % 3])].push_back(static_cast<int>(ti));

  std::vector<LinearBendingStencil> out;
  out.reserve(edge_triangles.size());
  // One stencil per edge, centred on it: the vertices of its triangles, the tips across their
  // other edges, then more of the neighbourhood by distance until six points determine a
  // quadratic. Centring the fit on edges lets every kink along a mesh line be seen. Each
  // stencil carries a third of its triangles' area, so the weights sum to the sheet's area.
  for (const auto& [edge, tris] : edge_triangles) {
    std::vector<int> pts{edge.first, edge.second};
    double area = 0;
    Vec2 centroid = 0.5 * (mesh.pattern[edge.first] + mesh.pattern[edge.second]);
    auto add = [&](std::vector<int>& list, int v) {
      if (std::find(pts.begin(), pts.end(), v) == pts.end() && std::find(list.begin(), list.end(), v) == list.end())
        list.push_back(v);
    };
    for (int ti : tris) {
      area += triangle_area[ti] / 3.0;
      for (int v : mesh.triangles[ti]) add(pts, v);
    }
    for (int ti : tris) {
      const auto& t = mesh.triangles[ti];
      for (int k = 0; k < 3; ++k)
        for (int tip : edge_tips[std::minmax(t[k], t[(k + 1) % 3])]) add(pts, tip);
    }
    const double scale = std::sqrt(3.0 * area / tris.size());
    std::vector<int> extra;
    for (int v : std::vector<int>(pts))
      for (int j : neighbours[v]) add(extra, j);
    std::sort(extra.begin(), extra.end(), [&](int a, int b) {
      return (mesh.pattern[a] - centroid).squaredNorm() < (mesh.pattern[b] - centroid).squaredNorm();
    });
    auto design = [&](const std::vector<int>& p) {
      MatX A(p.size(), 6);
      for (size_t r = 0; r < p.size(); ++r) {
        const Vec2 q = (mesh.pattern[p[r]] - centroid) / scale;
        A.row(r) << 1, q.x(), q.y(), 0.5 * q.x() * q.x(), q.x() * q.y(), 0.5 * q.y() * q.y();
      }
      return A;
    };
    auto well_posed = [&](const MatX& A) {
      if (A.rows() < 6) return false;
      Eigen::JacobiSVD<MatX> svd(A);
      const auto& sv = svd.singularValues();
      return sv[5] > 1e-6 * sv[0];
    };
    size_t next = 0;
    MatX A = design(pts);
    while (!well_posed(A) && next < extra.size()) {
      pts.push_back(extra[next++]);
      A = design(pts);
    }
    if (!well_posed(A))
      throw InputError("edge (" + std::to_string(edge.first) + ", " + std::to_string(edge.second) +
                       ") has too few neighbours for the plate bending element "
                       "(use \"bending_model\": \"hinge\" for such meshes)");
    // Least-squares fit: coefficients = (A^T A)^-1 A^T z; rows 3..5 give x_uu, x_uv, x_vv in
    // the scaled coordinates, divided by scale^2 for the pattern's.
    const MatX P = (A.transpose() * A).ldlt().solve(A.transpose());
    LinearBendingStencil s;
    s.vertices = pts;
    s.measures.resize(3, pts.size());
    s.measures.row(0) = P.row(3) / (scale * scale);  // x_uu: bends the weft yarns
    s.measures.row(1) = P.row(5) / (scale * scale);  // x_vv: bends the warp yarns
    s.measures.row(2) = P.row(4) / (scale * scale);  // x_uv: twist
    s.weights = area * Vec3(rigidity_weft_Nm, rigidity_warp_Nm, 2.0 * twist);
    s.finish();
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace weft
