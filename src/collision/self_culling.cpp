#include "collision/self_culling.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include <Eigen/SVD>

#include "util/threads.hpp"

namespace weft {

namespace {

/// The conditions are met with this much to spare (rounding of the cones and distances).
constexpr double kSafety = 1.001;
constexpr double kCosineSlack = 1e-9;
constexpr size_t kLeafChunk = 256;
/// Kept regions are taken only with this much to spare (the fit's rounding, far below it).
constexpr double kKeptRounding = 1 + 1e-6;
/// The contours of the regions passed over are measured out to this many times the widest
/// reach asked so far, so that regions kept may serve reaches up to that (and positions that
/// far from a rigid motion of theirs).
constexpr double kKeptProbe = 4;

Vec3 at(const VecX& x, int i) { return Vec3(x[3 * i], x[3 * i + 1], x[3 * i + 2]); }

// The directed edges of `in` left after each edge met in both directions is taken out.
void cancel_opposites(std::vector<std::array<int, 2>>& edges) {
  std::sort(edges.begin(), edges.end(), [](const std::array<int, 2>& p, const std::array<int, 2>& q) {
    const auto kp = std::minmax(p[0], p[1]), kq = std::minmax(q[0], q[1]);
    return kp < kq || (kp == kq && p < q);
  });
  size_t kept = 0;
  for (size_t k = 0; k < edges.size();) {
    // Edges of the same key are adjacent; with only good edges (at most one each way) a key
    // has one or two entries.
    if (k + 1 < edges.size() && edges[k + 1][0] == edges[k][1] && edges[k + 1][1] == edges[k][0]) {
      k += 2;
      continue;
    }
    edges[kept++] = edges[k++];
  }
  edges.resize(kept);
}

double point_segment_distance(const std::array<double, 2>& p, const std::array<double, 2>& a,
                              const std::array<double, 2>& b) {
  const double dx = b[0] - a[0], dy = b[1] - a[1];
  const double len2 = dx * dx + dy * dy;
  double s = len2 > 0 ? ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2 : 0.0;
  s = std::clamp(s, 0.0, 1.0);
  const double ex = a[0] + s * dx - p[0], ey = a[1] + s * dy - p[1];
  return std::sqrt(ex * ex + ey * ey);
}

}  // namespace

SelfCulling::SelfCulling(const std::vector<std::array<int, 3>>& triangles, const AabbTree& tree) {
  const int nodes = tree.node_count();
  never_.assign(nodes, 0);
  contour_begin_.assign(nodes + 1, 0);
  if (nodes == 0) return;
  // Edges no region may hold in its contour: met twice in one direction or by over two triangles.
  std::map<std::pair<int, int>, std::array<int, 2>> uses;  // key -> uses each way
  for (const auto& t : triangles)
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      ++uses[std::minmax(a, b)][a < b ? 0 : 1];
    }
  std::vector<char> bad_triangle(triangles.size(), 0);
  for (size_t f = 0; f < triangles.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const auto& u = uses[std::minmax(triangles[f][k], triangles[f][(k + 1) % 3])];
      if (u[0] > 1 || u[1] > 1) bad_triangle[f] = 1;
    }
  // Contours bottom up (children follow their parent in depth-first order), each kept apart,
  // then laid out in node order.
  std::vector<std::vector<std::array<int, 2>>> contour(nodes);
  const std::vector<int>& slot = tree.slot_triangles();
  for (int i = nodes - 1; i >= 0; --i) {
    std::vector<std::array<int, 2>>& c = contour[i];
    if (tree.node_leaf(i)) {
      for (int k = tree.node_begin(i); k < tree.node_end(i); ++k) {
        const auto& t = triangles[slot[k]];
        if (bad_triangle[slot[k]]) never_[i] = 1;
        for (int e = 0; e < 3; ++e) c.push_back({t[e], t[(e + 1) % 3]});
      }
    } else {
      const int l = i + 1, r = tree.node_right(i);
      never_[i] = never_[l] || never_[r];
      c = contour[l];
      c.insert(c.end(), contour[r].begin(), contour[r].end());
    }
    cancel_opposites(c);
  }
  for (int i = 0; i < nodes; ++i) {
    if (tree.node_leaf(i)) leaves_.push_back(i);
    contour_begin_[i] = static_cast<int>(contour_.size());
    contour_.insert(contour_.end(), contour[i].begin(), contour[i].end());
  }
  contour_begin_[nodes] = static_cast<int>(contour_.size());
}

void SelfCulling::find(const std::vector<std::array<int, 3>>& triangles, const AabbTree& tree, const VecX& xa,
                       const VecX& xb, double r, std::vector<char>& skip) {
  const int nodes = tree.node_count();
  ++stats_.calls;
  if (nodes == 0 || !(r > 0) || static_cast<int>(never_.size()) != nodes) {
    skip.assign(nodes, 0);
    return;
  }
  const bool moving = &xa != &xb && xa != xb;
  widest_r_ = std::max(widest_r_, r);
  auto count = [&](const std::vector<char>& flags) {
    for (int i = 0; i < nodes; ++i)
      if (flags[i]) {
        ++stats_.regions_culled;
        stats_.triangles_culled += tree.node_end(i) - tree.node_begin(i);
      }
  };
  // The kept regions, where the positions are near enough a rigid motion of the kept ones (the
  // bound is taken with room for the rounding of the fit).
  if (keeping_ && kept_.valid && kept_.positions.size() == xa.size() &&
      near_kept(xa, xb, moving, 0.5 * (kept_.reach / kKeptRounding - r))) {
    skip = kept_.skip;
    ++stats_.reused;
    count(skip);
    return;
  }
  find_cones(triangles, tree, xa, xb, moving);
  const double reach = select(tree, xa, xb, moving, r, skip);
  count(skip);
  kept_.valid = keeping_ && reach > 0;
  if (!kept_.valid) return;
  kept_.reach = reach;
  kept_.skip = skip;
  kept_.positions = xb;
  kept_.centroid = Vec3::Zero();
  const int n = static_cast<int>(xb.size() / 3);
  for (int i = 0; i < n; ++i) kept_.centroid += at(xb, i);
  kept_.centroid /= std::max(n, 1);
}

bool SelfCulling::near_kept(const VecX& xa, const VecX& xb, bool moving, double d) const {
  if (!(d >= 0)) return false;
  const int n = static_cast<int>(xa.size() / 3);
  const double d2 = d * d;
  // Every vertex within d of where it was kept, and of a rigid motion of it. The first is the
  // common case (the positions a search ended at, looked at again at the next step's start).
  auto within = [&](const auto& moved) {
    for (int i = 0; i < n; ++i) {
      const Vec3 p = moved(i);
      if ((at(xa, i) - p).squaredNorm() > d2 || (moving && (at(xb, i) - p).squaredNorm() > d2)) return false;
    }
    return true;
  };
  if (within([&](int i) { return at(kept_.positions, i); })) return true;
  // Kabsch: the rotation taking the kept positions about their centroid nearest to xa about its
  // own, from the SVD of their covariance. Any rotation and shift give a valid bound; the best
  // fit gives the smallest.
  Vec3 centroid = Vec3::Zero();
  for (int i = 0; i < n; ++i) centroid += at(xa, i);
  centroid /= std::max(n, 1);
  Mat3 h = Mat3::Zero();
  for (int i = 0; i < n; ++i) h += (at(kept_.positions, i) - kept_.centroid) * (at(xa, i) - centroid).transpose();
  const Eigen::JacobiSVD<Mat3> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 flip = Mat3::Identity();
  if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0) flip(2, 2) = -1;
  const Mat3 rotation = svd.matrixV() * flip * svd.matrixU().transpose();
  return within([&](int i) { return Vec3(centroid + rotation * (at(kept_.positions, i) - kept_.centroid)); });
}

void SelfCulling::find_cones(const std::vector<std::array<int, 3>>& triangles, const AabbTree& tree, const VecX& xa,
                             const VecX& xb, bool moving) {
  // Cones bottom up. A leaf's from its triangles (on the threads allowed, each leaf apart):
  // each triangle's unit control vectors of its normal over the step (n(t) = e1(t) x e2(t), a
  // quadratic in t whose Bernstein coefficients are n(0), n(0) + (e1 x d2 + d1 x e2) / 2 and
  // n(1); at rest n alone), the cone about their mean, and the smallest altitude bound. A
  // node's the best of three about its children's axes and their bisector that holds both
  // children's cones (cosines and sines only: cos(a + b) = cos a cos b - sin a sin b).
  const int nodes = tree.node_count();
  cone_.resize(nodes);
  const std::vector<int>& slot = tree.slot_triangles();
  const int controls = moving ? 3 : 1;
  const size_t leaves = leaves_.size();
  parallel_chunks((leaves + kLeafChunk - 1) / kLeafChunk, [&](size_t chunk) {
    std::array<Vec3, 3 * AabbTree::kMaxLeafTriangles> unit;
    for (size_t l = chunk * kLeafChunk, end = std::min(leaves, l + kLeafChunk); l < end; ++l) {
      const int i = leaves_[l];
      Cone& c = cone_[i];
      c.cosine = 0;
      c.altitude = std::numeric_limits<double>::infinity();
      Vec3 sum = Vec3::Zero();
      bool degenerate = false;
      int count = 0;
      for (int k = tree.node_begin(i); k < tree.node_end(i); ++k) {
        const auto& t = triangles[slot[k]];
        const Vec3 a0 = at(xa, t[0]), b0 = at(xa, t[1]), c0 = at(xa, t[2]);
        const Vec3 e1 = b0 - a0, e2 = c0 - a0;
        Vec3* control = &unit[count];
        control[0] = e1.cross(e2);
        double longest2 = std::max({e1.squaredNorm(), e2.squaredNorm(), (c0 - b0).squaredNorm()});
        if (moving) {
          const Vec3 a1 = at(xb, t[0]), b1 = at(xb, t[1]), c1 = at(xb, t[2]);
          const Vec3 f1 = b1 - a1, f2 = c1 - a1;
          control[2] = f1.cross(f2);
          control[1] = control[0] + 0.5 * (e1.cross(f2 - e2) + (f1 - e1).cross(e2));
          longest2 = std::max({longest2, f1.squaredNorm(), f2.squaredNorm(), (c1 - b1).squaredNorm()});
        }
        double shortest2 = std::numeric_limits<double>::infinity();
        for (int j = 0; j < controls; ++j) shortest2 = std::min(shortest2, control[j].squaredNorm());
        if (!(shortest2 > 0) || !(longest2 > 0)) {
          degenerate = true;
          break;
        }
        c.altitude = std::min(c.altitude, std::sqrt(shortest2 / longest2));
        for (int j = 0; j < controls; ++j) {
          control[j].normalize();
          sum += control[j];
        }
        count += controls;
      }
      const double len = sum.norm();
      if (degenerate || !(len > 0)) continue;
      c.axis = sum / len;
      double lowest = 1;
      for (int j = 0; j < count; ++j) lowest = std::min(lowest, c.axis.dot(unit[j]));
      c.cosine = lowest - kCosineSlack;  // rounding
      c.sine = c.cosine > 0 ? std::sqrt(1 - c.cosine * c.cosine) : 1.0;
    }
  });
  auto holding = [](const Vec3& axis, const Cone& p, const Cone& q, Cone& c) {
    double lowest = 1;
    for (const Cone* k : {&p, &q}) {
      const double ca = std::clamp(axis.dot(k->axis), -1.0, 1.0), sa = std::sqrt(1 - ca * ca);
      lowest = std::min(lowest, ca * k->cosine - sa * k->sine);
    }
    if (lowest > c.cosine) {
      c.axis = axis;
      c.cosine = lowest;
    }
  };
  for (int i = nodes - 1; i >= 0; --i) {
    if (tree.node_leaf(i)) continue;
    Cone& c = cone_[i];
    c.cosine = 0;
    const Cone& p = cone_[i + 1];
    const Cone& q = cone_[tree.node_right(i)];
    c.altitude = std::min(p.altitude, q.altitude);
    if (p.cosine <= 0 || q.cosine <= 0) continue;
    holding(p.axis, p, q, c);
    holding(q.axis, p, q, c);
    const Vec3 bisector = p.axis + q.axis;
    if (bisector.norm() > 0) holding(bisector.normalized(), p, q, c);
    c.cosine -= kCosineSlack;  // rounding
    c.sine = c.cosine > 0 ? std::sqrt(1 - c.cosine * c.cosine) : 1.0;
  }
}

double SelfCulling::select(const AabbTree& tree, const VecX& xa, const VecX& xb, bool moving, double r,
                           std::vector<char>& skip) {
  // The top-most regions that pass, from the root down.
  const int nodes = tree.node_count();
  skip.assign(nodes, 0);
  double reach = std::numeric_limits<double>::infinity();
  std::vector<int> stack{0};
  while (!stack.empty()) {
    const int i = stack.back();
    stack.pop_back();
    const Cone& c = cone_[i];
    bool pass = false;
    if (!never_[i] && c.cosine > 0) {
      const double bound = (moving ? c.cosine * c.cosine : c.cosine) * c.altitude;
      if (bound >= kSafety * r) {
        ++stats_.contour_checks;
        const double clearance = contour_clearance(i, c.axis, xa, xb, moving, r);
        pass = clearance >= kSafety * r;
        if (pass) reach = std::min(reach, std::min(bound, clearance) / kSafety);
        if (!pass) ++stats_.contour_failures;
      }
    }
    if (pass) {
      skip[i] = 1;
    } else if (!tree.node_leaf(i)) {
      stack.push_back(tree.node_right(i));
      stack.push_back(i + 1);
    }
  }
  return std::isfinite(reach) ? reach : 0.0;
}

double SelfCulling::contour_clearance(int node, const Vec3& axis, const VecX& xa, const VecX& xb, bool moving,
                                      double r) {
  // A basis of the plane orthogonal to the axis.
  Vec3 helper = std::abs(axis.x()) < 0.6 ? Vec3::UnitX() : Vec3::UnitY();
  const Vec3 u = axis.cross(helper).normalized();
  const Vec3 w = axis.cross(u);
  auto project = [&](const VecX& x, int i) {
    const Vec3 p = at(x, i);
    return std::array<double, 2>{p.dot(u), p.dot(w)};
  };
  // Pairs whose boxes are farther apart than the probe are clear by that much; those nearer are
  // measured.
  const double probe = kKeptProbe * kSafety * std::max(r, widest_r_);
  const double grow = 0.5 * probe;
  segments_.clear();
  for (int k = contour_begin_[node]; k < contour_begin_[node + 1]; ++k) {
    const auto& e = contour_[k];
    Segment s;
    s.a = e[0];
    s.b = e[1];
    const auto pa = project(xa, s.a), pb = project(xa, s.b);
    for (int d = 0; d < 2; ++d) {
      s.lo[d] = std::min(pa[d], pb[d]);
      s.hi[d] = std::max(pa[d], pb[d]);
    }
    if (moving) {
      const auto qa = project(xb, s.a), qb = project(xb, s.b);
      for (int d = 0; d < 2; ++d) {
        s.lo[d] = std::min({s.lo[d], qa[d], qb[d]});
        s.hi[d] = std::max({s.hi[d], qa[d], qb[d]});
      }
    }
    for (int d = 0; d < 2; ++d) {
      s.lo[d] -= grow;
      s.hi[d] += grow;
    }
    segments_.push_back(s);
  }
  sorted_.resize(segments_.size());
  for (size_t k = 0; k < sorted_.size(); ++k) sorted_[k] = static_cast<int>(k);
  std::sort(sorted_.begin(), sorted_.end(), [&](int p, int q) {
    return segments_[p].lo[0] < segments_[q].lo[0] || (segments_[p].lo[0] == segments_[q].lo[0] && p < q);
  });
  // How far a vertex's projection moves over the step.
  auto motion = [&](int i) {
    if (!moving) return 0.0;
    const auto p = project(xa, i), q = project(xb, i);
    return std::hypot(q[0] - p[0], q[1] - p[1]);
  };
  // Segments s and t share the end `c`: how far each far end stays from the other segment at
  // every time of the step (the least of the two).
  auto far_ends_clearance = [&](const Segment& s, const Segment& t, int c) {
    const int fs = s.a == c ? s.b : s.a, ft = t.a == c ? t.b : t.a;
    if (fs == ft) return 0.0;  // the same edge twice
    const double mc = motion(c), mfs = motion(fs), mft = motion(ft);
    const auto pc = project(xa, c), pfs = project(xa, fs), pft = project(xa, ft);
    return std::min(point_segment_distance(pfs, pc, pft) - mfs - std::max(mc, mft),
                    point_segment_distance(pft, pc, pfs) - mft - std::max(mc, mfs));
  };
  // Segments s and t sharing no end: their boxes' separation along either axis (a bound on
  // their distance at every time of the step: each box holds its segment throughout).
  auto box_gap = [&](const Segment& s, const Segment& t) {
    double gap = -std::numeric_limits<double>::infinity();
    for (int d = 0; d < 2; ++d) gap = std::max({gap, s.lo[d] - t.hi[d] + probe, t.lo[d] - s.hi[d] + probe});
    return gap;
  };
  double clearance = probe;
  for (size_t i = 0; i < sorted_.size(); ++i) {
    const Segment& s = segments_[sorted_[i]];
    for (size_t j = i + 1; j < sorted_.size(); ++j) {
      const Segment& t = segments_[sorted_[j]];
      if (t.lo[0] > s.hi[0]) break;
      if (t.lo[1] > s.hi[1] || s.lo[1] > t.hi[1]) continue;
      const bool sa = s.a == t.a || s.a == t.b, sb = s.b == t.a || s.b == t.b;
      if (sa && sb) return 0;
      clearance = std::min(clearance, sa || sb ? far_ends_clearance(s, t, sa ? s.a : s.b) : box_gap(s, t));
      if (clearance < kSafety * r) return 0;  // fails at the call's reach: no need to go on
    }
  }
  return clearance;
}

}  // namespace weft
