// The per-frame checker: cloth-body pairs at the body's own crossings are counted apart, the
// others count; trees follow changed positions and changed triangles.
#include <gtest/gtest.h>

#include "weft/frame_check.hpp"

namespace weft {
namespace {

using Triangles3 = std::vector<std::array<int, 3>>;

// The cloth: the unit square in z = 0 as two triangles.
const std::vector<double> kClothXyz = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
const Triangles3 kClothTriangles = {{0, 1, 2}, {0, 2, 3}};

TEST(FrameChecker, BodyCrossingsAreCountedApart) {
  // Body triangle 0 pierces the cloth near (0.3, 0.3) and is crossed by body triangle 1 (the
  // body passing through itself there); body triangle 2 pierces the cloth near (0.8, 0.2) far
  // from any crossing.
  const std::vector<double> body = {
      0.3, 0.3, -1, 0.4, 0.3, 1, 0.3, 0.4, 1,            // triangle 0, through the cloth on x + y = 0.65
      0.2, 0.35, 0.5, 0.5, 0.35, 0.5, 0.35, 0.35, 0.9,  // triangle 1, in y = 0.35, through triangle 0
      0.8, 0.2, -1, 0.85, 0.2, 1, 0.8, 0.25, 1};         // triangle 2, through the cloth's triangle 0
  const Triangles3 body_triangles = {{0, 1, 2}, {3, 4, 5}, {6, 7, 8}};
  FrameChecker checker(8);
  const FrameIntersections r = checker.check({kClothXyz.data(), &kClothTriangles}, {{body.data(), &body_triangles}});
  EXPECT_EQ(r.cloth_self.count, 0u);
  ASSERT_EQ(r.cloth_body.size(), 1u);
  // Triangle 0 crosses both cloth triangles (its line x + y = 0.65 crosses the diagonal): both
  // pairs are at the crossing. Triangle 2 meets cloth triangle 0 only.
  EXPECT_EQ(r.cloth_body_at_body_crossings[0], 2u);
  EXPECT_EQ(r.cloth_body[0].count, 1u);
  EXPECT_EQ(r.cloth_body[0].examples, (std::vector<std::array<int, 2>>{{0, 2}}));
  EXPECT_EQ(r.count(), 1u);
}

TEST(FrameChecker, FollowsMovedPositionsAndNewTriangles) {
  FrameChecker checker;
  std::vector<double> body = {0.3, 0.3, 0.5, 0.4, 0.3, 1, 0.3, 0.4, 1};
  const Triangles3 one = {{0, 1, 2}};
  EXPECT_EQ(checker.check({kClothXyz.data(), &kClothTriangles}, {{body.data(), &one}}).count(), 0u);
  body[2] = -0.5;  // now through the cloth
  EXPECT_EQ(checker.check({kClothXyz.data(), &kClothTriangles}, {{body.data(), &one}}).count(), 2u);
  // A cloth with only the second triangle: a new tree for it.
  const Triangles3 second = {{0, 2, 3}};
  EXPECT_EQ(checker.check({kClothXyz.data(), &second}, {{body.data(), &one}}).count(), 1u);
}

}  // namespace
}  // namespace weft
