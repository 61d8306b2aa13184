// The weld (weld_seams): the vertices a seam merges become one vertex at their mean position,
// whether two or three of them meet there, and a stitch left open keeps its two sides apart.
#include <gtest/gtest.h>

#include "weft/garment/sewing.hpp"

using namespace weft;

TEST(Weld, AWeldedVertexLandsAtTheMeanOfTheVerticesItMerges) {
  // Three triangles of three panels: 1 and 3 sewn (stitch 0), 2, 5 and 7 sewn (stitches 1 and 2:
  // three vertices into one), 4 and 6 on stitch 3, left open.
  PlacedGarment placed;
  TriMesh& m = placed.mesh;
  m.positions.resize(9, 3);
  m.positions << 0, 0, 0,  1, 0, 0,  0, 1, 0,      // panel 0
                 1.2, 0.1, 0.3,  2, 0, 0,  0.1, 1.4, -0.2,  // panel 1
                 2.1, 0.1, 0.1,  0.3, 1.1, 0.5,  2, 2, 0;   // panel 2
  for (int i = 0; i < 9; ++i) m.pattern.emplace_back(m.positions(i, 0), m.positions(i, 1));
  m.triangles = {{0, 1, 2}, {3, 4, 5}, {6, 7, 8}};
  placed.panel_first_vertex = {0, 3, 6, 9};
  placed.panel_of_triangle = {0, 1, 2};
  placed.seam_pairs = {{1, 3}, {2, 5}, {5, 7}, {4, 6}};
  placed.seam_stitch = {0, 1, 2, 3};
  const SewnGarment w = weld_seams(placed, m.positions, {3});
  ASSERT_EQ(w.welded_vertex.size(), 9u);
  EXPECT_EQ(w.welded_vertex[1], w.welded_vertex[3]);
  EXPECT_EQ(w.welded_vertex[2], w.welded_vertex[5]);
  EXPECT_EQ(w.welded_vertex[2], w.welded_vertex[7]);
  EXPECT_NE(w.welded_vertex[4], w.welded_vertex[6]) << "the open stitch is not welded";
  EXPECT_EQ(w.mesh.num_vertices(), 6);
  // Every welded vertex is the mean of the vertices it merges (one of them: where it was).
  for (int v = 0; v < w.mesh.num_vertices(); ++v) {
    Vec3 sum = Vec3::Zero();
    int count = 0;
    for (int i = 0; i < 9; ++i)
      if (w.welded_vertex[i] == v) {
        sum += m.positions.row(i).transpose();
        ++count;
      }
    ASSERT_GT(count, 0);
    EXPECT_LT((Vec3(w.mesh.positions.row(v).transpose()) - sum / count).norm(), 1e-14) << "vertex " << v;
  }
  EXPECT_EQ(w.mesh.triangles.size(), 3u);
}
