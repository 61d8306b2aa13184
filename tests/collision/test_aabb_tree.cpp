// The bounding-volume tree against brute force on random triangle soups: the same box
// queries, self pairs and tree-tree pairs as comparing every box with every other, after
// building, after refitting to moved positions, and with swept, grown boxes; the same nearest
// triangle as measuring every one.
#include <gtest/gtest.h>

#include <random>
#include <set>

#include "collision/aabb_tree.hpp"
#include "collision/geometry.hpp"
#include "weft/threads.hpp"

namespace weft {
namespace {

using Triangles3 = std::vector<std::array<int, 3>>;

struct Soup {
  VecX x;  ///< 3 per vertex
  Triangles3 triangles;
};

// Small triangles scattered in a unit cube, vertices shared between some of them.
Soup random_soup(std::mt19937& rng, int n_triangles) {
  std::uniform_real_distribution<double> u(0, 1), small(-0.05, 0.05);
  std::uniform_int_distribution<int> pick(0, 2);
  Soup s;
  std::vector<Vec3> v;
  for (int f = 0; f < n_triangles; ++f) {
    std::array<int, 3> t;
    const Vec3 centre(u(rng), u(rng), u(rng));
    for (int k = 0; k < 3; ++k) {
      if (f > 0 && k == 0 && pick(rng) == 0) {  // reuse a vertex of the previous triangle
        t[k] = s.triangles.back()[pick(rng)];
        continue;
      }
      t[k] = static_cast<int>(v.size());
      v.push_back(centre + Vec3(small(rng), small(rng), small(rng)));
    }
    s.triangles.push_back(t);
  }
  s.x.resize(3 * static_cast<int>(v.size()));
  for (size_t i = 0; i < v.size(); ++i) s.x.segment<3>(3 * static_cast<int>(i)) = v[i];
  return s;
}

Box triangle_box(const VecX& x, const std::array<int, 3>& t, double margin, const VecX* x_end = nullptr) {
  Box b;
  for (int i : t) {
    b.add(x.segment<3>(3 * i));
    if (x_end) b.add(x_end->segment<3>(3 * i));
  }
  b.lo -= Vec3::Constant(margin);
  b.hi += Vec3::Constant(margin);
  return b;
}

std::vector<Box> all_boxes(const Soup& s, double margin, const VecX* x_end = nullptr) {
  std::vector<Box> boxes;
  for (const auto& t : s.triangles) boxes.push_back(triangle_box(s.x, t, margin, x_end));
  return boxes;
}

std::set<std::pair<int, int>> self_pairs(const AabbTree& tree) {
  std::set<std::pair<int, int>> pairs;
  tree.for_each_self_pair([&](int i, int j) {
    EXPECT_NE(i, j);
    // Each unordered pair once.
    EXPECT_TRUE(pairs.insert({std::min(i, j), std::max(i, j)}).second) << i << " " << j;
  });
  return pairs;
}

std::set<std::pair<int, int>> brute_self_pairs(const std::vector<Box>& boxes) {
  std::set<std::pair<int, int>> pairs;
  for (size_t i = 0; i < boxes.size(); ++i)
    for (size_t j = i + 1; j < boxes.size(); ++j)
      if (boxes[i].overlaps(boxes[j])) pairs.insert({static_cast<int>(i), static_cast<int>(j)});
  return pairs;
}

TEST(AabbTree, SelfPairsMatchBruteForce) {
  std::mt19937 rng(3);
  for (int n : {1, 2, 3, 17, 400}) {
    Soup s = random_soup(rng, n);
    AabbTree tree(s.triangles, s.x.data());
    const auto expected = brute_self_pairs(all_boxes(s, 0));
    EXPECT_EQ(self_pairs(tree), expected) << n << " triangles";
    if (n == 400) EXPECT_GT(expected.size(), 100u);  // the soup is dense enough to test something

    // Moved positions, refitted; then grown boxes; then swept boxes.
    VecX moved = s.x;
    std::normal_distribution<double> g(0, 0.03);
    for (int i = 0; i < moved.size(); ++i) moved[i] += g(rng);
    std::swap(s.x, moved);
    tree.refit(s.x.data());
    EXPECT_EQ(self_pairs(tree), brute_self_pairs(all_boxes(s, 0)));
    tree.refit(s.x.data(), 0.01);
    EXPECT_EQ(self_pairs(tree), brute_self_pairs(all_boxes(s, 0.01)));
    tree.refit(moved.data(), s.x.data(), 0.002);
    Soup start = s;
    start.x = moved;
    EXPECT_EQ(self_pairs(tree), brute_self_pairs(all_boxes(start, 0.002, &s.x)));
  }
}

TEST(AabbTree, CollectedSelfPairsAreTheTraversalsInItsOrderOnOneThreadAndOnTwo) {
  std::mt19937 rng(11);
  for (int n : {1, 2, 5, 40, 3000}) {
    Soup s = random_soup(rng, n);
    AabbTree tree(s.triangles, s.x.data());
    // A filter keeping about half the pairs, so that the pieces join with gaps between them.
    auto keep = [](int i, int j) { return (i + 3 * j) % 2 == 0; };
    std::vector<std::array<int, 2>> serial;
    tree.for_each_self_pair([&](int i, int j) {
      if (keep(i, j)) serial.push_back({i, j});
    });
    if (n == 3000) EXPECT_GT(serial.size(), 1000u);  // enough pairs for many pieces
    for (int threads : {1, 2}) {
      set_thread_count(threads);
      std::vector<std::array<int, 2>> collected = {{-1, -1}};  // replaced, not appended to
      std::vector<std::vector<std::array<int, 2>>> pieces;
      tree.collect_self_pairs(keep, collected, pieces);
      EXPECT_EQ(collected, serial) << n << " triangles, " << threads << " threads";
    }
    set_thread_count(0);
  }
  std::vector<std::array<int, 2>> none = {{1, 2}};
  std::vector<std::vector<std::array<int, 2>>> pieces;
  AabbTree(Triangles3{}, nullptr).collect_self_pairs([](int, int) { return true; }, none, pieces);
  EXPECT_TRUE(none.empty());
}

TEST(AabbTree, BoxQueryMatchesBruteForce) {
  std::mt19937 rng(4);
  Soup s = random_soup(rng, 300);
  AabbTree tree(s.triangles, s.x.data());
  const auto boxes = all_boxes(s, 0);
  std::uniform_real_distribution<double> u(-0.1, 1.1), size(0, 0.3);
  for (int q = 0; q < 200; ++q) {
    Box query;
    query.lo = Vec3(u(rng), u(rng), u(rng));
    query.hi = query.lo + Vec3(size(rng), size(rng), size(rng));
    std::set<int> found, expected;
    tree.for_each_overlapping(query, [&](int f) { EXPECT_TRUE(found.insert(f).second); });
    for (size_t f = 0; f < boxes.size(); ++f)
      if (boxes[f].overlaps(query)) expected.insert(static_cast<int>(f));
    EXPECT_EQ(found, expected);
  }
}

TEST(AabbTree, PairsBetweenTreesMatchBruteForce) {
  std::mt19937 rng(5);
  for (int n : {1, 50, 300}) {
    const Soup a = random_soup(rng, n), b = random_soup(rng, 2 * n + 1);
    const AabbTree ta(a.triangles, a.x.data()), tb(b.triangles, b.x.data());
    std::set<std::pair<int, int>> found, expected;
    ta.for_each_pair(tb, [&](int i, int j) { EXPECT_TRUE(found.insert({i, j}).second); });
    const auto ba = all_boxes(a, 0), bb = all_boxes(b, 0);
    for (size_t i = 0; i < ba.size(); ++i)
      for (size_t j = 0; j < bb.size(); ++j)
        if (ba[i].overlaps(bb[j])) expected.insert({static_cast<int>(i), static_cast<int>(j)});
    EXPECT_EQ(found, expected) << n;
  }
}

double distance_to(const Soup& s, int f, const Vec3& p) {
  auto v = [&](int i) { return Vec3(s.x.segment<3>(3 * i)); };
  const auto& t = s.triangles[f];
  return closest_point_triangle(p, v(t[0]), v(t[1]), v(t[2])).distance;
}

TEST(AabbTree, NearestMatchesBruteForce) {
  std::mt19937 rng(6);
  const Soup s = random_soup(rng, 300);
  const AabbTree tree(s.triangles, s.x.data());
  std::uniform_real_distribution<double> u(-0.2, 1.2), r(0, 0.3);
  int found = 0, none = 0;
  for (int q = 0; q < 500; ++q) {
    const Vec3 p(u(rng), u(rng), u(rng));
    const double reach = r(rng);
    double least = std::numeric_limits<double>::infinity();
    for (int f = 0; f < static_cast<int>(s.triangles.size()); ++f) least = std::min(least, distance_to(s, f, p));
    double nearest = -1;
    const int f = tree.nearest(p, reach, [&](int g) { return distance_to(s, g, p); }, nearest);
    if (least > reach) {
      EXPECT_EQ(f, -1) << q;
      EXPECT_EQ(nearest, reach);
      ++none;
    } else {
      ASSERT_GE(f, 0) << q;
      EXPECT_EQ(nearest, least) << q;
      EXPECT_EQ(distance_to(s, f, p), least) << q;
      ++found;
    }
  }
  EXPECT_GT(found, 50);  // both outcomes exercised
  EXPECT_GT(none, 50);
}

TEST(AabbTree, NearestOfTiedTrianglesIsTheFirstInTheTreesOrder) {
  // Two triangles whose nearest points to p are their corners p -+ (1/4, 1/4, 0), at exactly
  // the same distance: A below, lying along the axes (its box as far from p as it is), B above,
  // leaning across the diagonal (its box nearer p than it is, so a search opening the nearer
  // box first meets B first). Each has three copies shifted away along x, filling one leaf of
  // the tree each, A's first in the tree's order.
  const Vec3 p(0.5, 0.5, 0.5);
  Soup s;
  std::vector<Vec3> v;
  auto add = [&](const Vec3& a, const Vec3& b, const Vec3& c) {
    const int i = static_cast<int>(v.size());
    v.insert(v.end(), {a, b, c});
    s.triangles.push_back({i, i + 1, i + 2});
  };
  const Vec3 ca = p - Vec3(0.25, 0.25, 0), cb = p + Vec3(0.25, 0.25, 0);
  for (int k = 0; k < 4; ++k) {
    const Vec3 shift(0.5 * k, 0, 0);
    add(ca - shift, ca - shift - Vec3(0.25, 0, 0), ca - shift + Vec3(0, -0.25, 0.125));
  }
  for (int k = 0; k < 4; ++k) {
    const Vec3 shift(0.5 * k, 0, 0);
    add(cb + shift, cb + shift + Vec3(0.25, -0.125, 0), cb + shift + Vec3(-0.125, 0.25, 0.125));
  }
  s.x.resize(3 * static_cast<int>(v.size()));
  for (size_t i = 0; i < v.size(); ++i) s.x.segment<3>(3 * static_cast<int>(i)) = v[i];
  const AabbTree tree(s.triangles, s.x.data());
  const double tie = distance_to(s, 0, p);
  ASSERT_EQ(distance_to(s, 4, p), tie);  // A (0) and B (4) tie exactly
  for (int f = 0; f < 8; ++f)
    if (f != 0 && f != 4) ASSERT_GT(distance_to(s, f, p), tie);
  // The first of the two in for_each_overlapping's order: A.
  int first = -1;
  Box all;
  all.add(Vec3::Constant(-10));
  all.add(Vec3::Constant(10));
  tree.for_each_overlapping(all, [&](int f) {
    if (first < 0 && (f == 0 || f == 4)) first = f;
  });
  ASSERT_EQ(first, 0);
  for (double reach : {tie, 0.4, 5.0}) {
    double nearest = 0;
    EXPECT_EQ(tree.nearest(p, reach, [&](int g) { return distance_to(s, g, p); }, nearest), first) << reach;
    EXPECT_EQ(nearest, tie);
  }
  double nearest = 0;
  EXPECT_EQ(tree.nearest(p, 0.99 * tie, [&](int g) { return distance_to(s, g, p); }, nearest), -1);
}

TEST(AabbTree, EmptyTreeHasNoPairs) {
  const AabbTree empty(Triangles3{}, nullptr);
  int calls = 0;
  empty.for_each_self_pair([&](int, int) { ++calls; });
  empty.for_each_overlapping(Box{Vec3::Constant(-1e9), Vec3::Constant(1e9)}, [&](int) { ++calls; });
  EXPECT_EQ(calls, 0);
  double nearest = 0;
  EXPECT_EQ(empty.nearest(Vec3::Zero(), 1.0, [&](int) { return 0.0; }, nearest), -1);
  EXPECT_EQ(empty.triangle_count(), 0);
}

}  // namespace
}  // namespace weft
