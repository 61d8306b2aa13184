// The body's OBJ reader and writer: groups, polygons, relative indices, errors that name the
// file, and a write-read round trip.
#include <gtest/gtest.h>

#include <fstream>

#include "body/body_fixture.hpp"
#include "weft/body.hpp"
#include "weft/error.hpp"

namespace weft {
namespace {

std::string write_text(const std::string& text, const std::string& name) {
  const auto path = (test::scratch_dir("obj_io") / name).string();
  std::ofstream(path) << text;
  return path;
}

std::string read_error(const std::string& path) {
  try {
    read_obj(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(BodyObj, ReadsGroupsPolygonsAndRelativeIndices) {
  const std::string path = write_text(
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\n"
      "f 1 2 3\n"              // before any group: in no group
      "g left\nf 1 2 3 4\n"    // a quad: two triangles
      "g right\nf -5 -2 -1\n",  // relative indices: 2, 5, 6
      "groups.obj");
  const ObjMesh m = read_obj(path);
  ASSERT_EQ(m.positions.rows(), 6);
  EXPECT_EQ(m.positions.row(4), Vec3(2, 0, 0).transpose());
  ASSERT_EQ(m.triangles.rows(), 4);
  EXPECT_EQ(m.triangles.row(3), Eigen::RowVector3i(1, 4, 5));
  ASSERT_EQ(m.group_names, (std::vector<std::string>{"left", "right"}));
  EXPECT_EQ(m.group_vertices[0], (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(m.group_vertices[1], (std::vector<int>{1, 4, 5}));
}

TEST(BodyObj, WriteThenReadGivesTheSameMesh) {
  Points x(4, 3);
  x << 0, 0, 0, 1.25, 0, 0, 1, 1, 0.5, 0, 1, -0.125;
  Triangles t(2, 3);
  t << 0, 1, 2, 0, 2, 3;
  const auto path = (test::scratch_dir("obj_io_write") / "mesh.obj").string();
  write_obj(path, x, t);
  const ObjMesh m = read_obj(path);
  EXPECT_EQ(m.positions, x);  // exact: the values need neither more than 6 decimals nor double precision
  EXPECT_EQ(m.triangles, t);
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
}

TEST(BodyObj, ErrorsNameTheFileAndTheProblem) {
  const std::string missing = (test::scratch_dir("obj_io_missing") / "none.obj").string();
  EXPECT_EQ(read_error(missing), missing + ": cannot open OBJ file (no such file)");
  const std::string far = write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 7\n", "far.obj");
  EXPECT_EQ(read_error(far), far + ":4: face refers to vertex 7, out of range (the file has 3 vertices)");
  const std::string huge = write_text("v 0 0 0\nv 1 1e999 0\nv 1 1 0\nf 1 2 3\n", "huge.obj");
  EXPECT_EQ(read_error(huge), huge + ":2: number '1e999' is out of range");
  const std::string folder = (test::scratch_dir("obj_io_folder")).string();
  EXPECT_EQ(read_error(folder), folder + ": cannot open OBJ file (not a regular file)");
}

}  // namespace
}  // namespace weft
