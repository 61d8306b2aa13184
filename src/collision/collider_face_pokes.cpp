// The mesh colliders' vertices that poke into (or come within the thickness of) cloth faces
// (ColliderContacts::face_pokes), for detection's face holds and the fail-safe.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "collision/aabb_tree.hpp"
#include "collision/colliders.hpp"
#include "collision/geometry.hpp"
#include "util/threads.hpp"

namespace weft {

namespace {
// A collider vertex deeper than this behind a cloth face is taken to be on the face's other
// side (under an arm, say), not poking through it.
constexpr double kMaxPokeDepth = 0.02;
// A face is lifted along its own normal only where its vertices' nearest surface normals lean
// to the side it is lifted to: the sum of their cosines with it above kFaceSideAgreement, none
// below kFaceSideLeast (a face across a chin, one vertex under the jaw, is lifted over it).
constexpr double kFaceSideAgreement = 0.2;
constexpr double kFaceSideLeast = -0.5;
}  // namespace

bool ColliderContacts::clear_of(const Collider& c, const VecX& x, const std::array<int, 3>& t, double thickness,
                                double limit) const {
  // A face gives no poke when its vertices' distance bounds show that (1) one of them is
  // farther from the collider than its side normal's reach (the side check then fails) and
  // (2) the whole face is farther than a poke measured along the face's normal can be.
  double lowest = std::numeric_limits<double>::infinity(), highest = 0, longest2 = 0;
  for (int k = 0; k < 3; ++k) {
    const double b = c.distance_bound(node(x, t[k]), t[k], true);
    lowest = std::min(lowest, b);
    highest = std::max(highest, b);
    longest2 = std::max(longest2, (node(x, t[k]) - node(x, t[(k + 1) % 3])).squaredNorm());
  }
  if (!(highest > kMaxPokeDepth + thickness)) return false;
  // Every point of a triangle lies within its longest edge L of each vertex and within
  // L / sqrt(3) of the nearest one.
  const double longest = std::sqrt(longest2);
  const double face = std::max(highest - longest, lowest - longest / std::sqrt(3.0));
  return face >= std::max(limit, kMaxPokeDepth);
}

void ColliderContacts::face_pokes(const Collider& c, const VecX& x, double limit, std::vector<FacePoke>& out) {
  out.clear();
  const double thickness = c.spec().thickness;
  const double margin = std::max(limit, thickness);
  const Points& body = *c.end_vertices();
  const auto& body_triangles = *c.triangle_list();
  const AabbTree& body_tree = *c.end_tree();
  side_normal_known_.assign(scene_held_.size(), 0);
  side_normal_.resize(scene_held_.size());
  // Each (cloth face, collider vertex) pair once: the vertices of the collider's triangles
  // whose boxes overlap the face's (grown by the margin), faces in order and each face's
  // vertices in increasing order. Their geometry on every thread, each chunk of faces keeping
  // the candidates that qualify, joined in order; then, in order, the side check (its
  // nearest-normal queries are kept per node and made only when needed).
  const int faces = static_cast<int>(triangles_.size());
  constexpr int kChunk = 128;
  const size_t chunks = (faces + kChunk - 1) / kChunk;
  if (chunk_tests_.size() < chunks) chunk_tests_.resize(chunks);
  parallel_chunks(chunks, [&](size_t k) {
    std::vector<PokeTest>& found = chunk_tests_[k];
    found.clear();
    std::vector<int> vertices;
    for (int f = static_cast<int>(k) * kChunk, last = std::min(faces, f + kChunk); f < last; ++f) {
      const auto& t = triangles_[f];
      if (!looks_at(t)) continue;
      if (clear_of(c, x, t, thickness, limit)) continue;
      Box box;
      for (int j = 0; j < 3; ++j) box.add(node(x, t[j]));
      box.lo -= Vec3::Constant(margin);
      box.hi += Vec3::Constant(margin);
      vertices.clear();
      body_tree.for_each_overlapping(box, [&](int b) {
        for (int j = 0; j < 3; ++j) vertices.push_back(body_triangles[b][j]);
      });
      std::sort(vertices.begin(), vertices.end());
      vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
      const Vec3 a = node(x, t[0]), b = node(x, t[1]), cc = node(x, t[2]);
      const Vec3 face_normal = (b - a).cross(cc - a);
      const double area2 = face_normal.norm();
      const Vec3 unit_face_normal = area2 > 0 ? Vec3(face_normal / area2) : Vec3::Zero();
      for (const int vertex : vertices) {
        const Vec3 p = body.row(vertex).transpose();
        const PointTriangleClosest q = closest_point_triangle(p, a, b, cc);
        if (q.feature.kind == FeatureKind::kVertex) continue;  // a neighbouring face's
        const Vec3 n = c.end_vertex_normal(vertex);
        const bool on_edge = q.feature.kind == FeatureKind::kEdge;
        // Two ways to measure the face's height over the vertex: along the vertex's normal, and,
        // for a vertex whose normal says little about the face (a nose's tip, a chin, where the
        // collider is finer than the cloth) and which lies right under the face's inside, along
        // the face's own normal, turned to the cloth's side in the check below.
        PokeTest test;
        test.poke = {f, vertex, q.weights, (q.point - p).dot(n), n, on_edge};
        // A vertex under one of the face's edges (the edge across a ridge, the faces on both
        // sides clear of it): the edge itself, found from both its faces, each move measured
        // where the last left it. Only where the edge passes over the vertex, not beside it (the
        // rim of a sleeve around an arm).
        const double height = test.poke.height;
        test.by_vertex_normal = height < limit && height >= -kMaxPokeDepth &&
                                !(on_edge && (q.point - p - height * n).norm() > 0.5 * thickness);
        test.face_normal = unit_face_normal;
        test.face_height = (q.point - p).dot(test.face_normal);
        test.by_face_normal = area2 > 0 && !on_edge && std::abs(test.face_height) < std::max(limit, kMaxPokeDepth);
        if (test.by_vertex_normal || test.by_face_normal) found.push_back(test);
      }
    }
  });
  auto side_normal = [&](int i) -> const Vec3& {
    if (!side_normal_known_[i]) {
      SurfacePoint sp;
      side_normal_known_[i] = 1;
      side_normal_[i] = c.closest(node(x, i), kMaxPokeDepth + thickness, true, i, sp) ? sp.normal : Vec3::Zero();
    }
    return side_normal_[i];
  };
  if (thread_count() > 1) {
    // On several threads, the side normals of every face with a candidate are found first, in
    // chunks of nodes (each node's query reads only its own position: the checks below read the
    // same normals as when each is found on demand, and a query a check would not have made
    // changes no other query's answer).
    side_nodes_.clear();
    for (size_t chunk = 0; chunk < chunks; ++chunk)
      for (const PokeTest& test : chunk_tests_[chunk])
        for (const int i : triangles_[test.poke.face])
          if (!side_normal_known_[i]) {
            side_normal_known_[i] = 2;  // listed
            side_nodes_.push_back(i);
          }
    for (const int i : side_nodes_) side_normal_known_[i] = 0;
    constexpr size_t kNodesPerChunk = 64;
    parallel_chunks((side_nodes_.size() + kNodesPerChunk - 1) / kNodesPerChunk, [&](size_t k) {
      for (size_t j = k * kNodesPerChunk, end = std::min(side_nodes_.size(), j + kNodesPerChunk); j < end; ++j)
        side_normal(side_nodes_[j]);
    });
  }
  auto check = [&](const PokeTest& test) {
    const auto& t = triangles_[test.poke.face];
    // The face must lie on the vertex's side of the collider: its own vertices' nearest
    // surface normals face the same way (not a face on the far side of a thin part). Lifting
    // faces more freely (those wrapped round an arm) moves so many vertices that the cloth's
    // elastic energy blows up: on coarse cloth (triangles as wide as an arm) edges can still
    // cut the body (docs/collisions.md).
    bool same_side = test.by_vertex_normal;
    for (int k = 0; k < 3 && same_side; ++k) same_side = side_normal(t[k]).dot(test.poke.normal) > 0.5;
    if (same_side) {
      out.push_back(test.poke);
      return;
    }
    if (!test.by_face_normal) return;
    // Measured along the face's normal, turned to the side its vertices' nearest surface
    // normals lean to: they must lean that way together, none strongly against it (a face
    // across a chin, one vertex under the jaw, is lifted over the chin), and the collider's
    // vertex must face that side too (not the inner side of an arm beside the face, which
    // lies in front of the face, not through it).
    Vec3 sum = Vec3::Zero();
    for (int k = 0; k < 3; ++k) sum += side_normal(t[k]);
    const bool flip = sum.dot(test.face_normal) < 0;
    const Vec3 normal = flip ? Vec3(-test.face_normal) : test.face_normal;
    const double height = flip ? -test.face_height : test.face_height;
    if (height >= limit || height < -kMaxPokeDepth || test.poke.normal.dot(normal) <= 0) return;
    double agreement = 0, least = 1;
    for (int k = 0; k < 3; ++k) {
      agreement += side_normal(t[k]).dot(normal);
      least = std::min(least, side_normal(t[k]).dot(normal));
    }
    if (agreement <= kFaceSideAgreement || least <= kFaceSideLeast) return;
    FacePoke poke = test.poke;
    poke.normal = normal;
    poke.height = height;
    out.push_back(poke);
  };
  for (size_t chunk = 0; chunk < chunks; ++chunk)
    for (const PokeTest& test : chunk_tests_[chunk]) check(test);
}

}  // namespace weft
