// The bounding-volume tree against brute force on random triangle soups: the same box
// queries, self pairs and tree-tree pairs as comparing every box with every other, after
// building, after refitting to moved positions, and with swept, grown boxes.
#include <gtest/gtest.h>

#include <random>
#include <set>

#include "collision/aabb_tree.hpp"

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

TEST(AabbTree, EmptyTreeHasNoPairs) {
  const AabbTree empty(Triangles3{}, nullptr);
  int calls = 0;
  empty.for_each_self_pair([&](int, int) { ++calls; });
  empty.for_each_overlapping(Box{Vec3::Constant(-1e9), Vec3::Constant(1e9)}, [&](int) { ++calls; });
  EXPECT_EQ(calls, 0);
  EXPECT_EQ(empty.triangle_count(), 0);
}

}  // namespace
}  // namespace weft
