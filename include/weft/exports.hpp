#pragma once
// The animation exports of `weft run` (docs/exports.md): OBJ frames with texture coordinates
// and normals, a glTF 2.0 binary (.glb) whose meshes play the run as morph targets, a PC2
// point cache with its rest mesh, and a USD ASCII stage (.usda) with time-sampled points.
#include <array>
#include <ostream>
#include <string>
#include <vector>

#include "weft/types.hpp"

namespace weft {

/// The formats `weft run --format` and a scene's output.formats accept, for messages.
constexpr const char* kOutputFormatNames = "obj, ply, glb, pc2, usda";

/// Checks a list of format names (`where` prefixes messages): each one of kOutputFormatNames,
/// obj and ply not both (both write DIR/frames/frame_NNNNN). Returns them without repeats, in
/// the order given. Throws InputError "WHERE: unknown output format 'X' (expected ...)".
std::vector<std::string> checked_output_formats(const std::vector<std::string>& names, const std::string& where);
/// "obj,glb" -> {"obj", "glb"} (spaces around names dropped; an empty item kept, so that
/// checked_output_formats refuses it).
std::vector<std::string> split_format_list(const std::string& text);

/// Area-weighted vertex normals of a triangle mesh: `xyz` holds 3 coordinates per vertex
/// (`vertex_count` of them); the result 3 floats per vertex, of unit length ((0, 0, 1) for a
/// vertex whose triangles have no area).
template <typename Real>
std::vector<float> vertex_normals(const Real* xyz, int vertex_count, const std::vector<std::array<int, 3>>& triangles);

/// Texture coordinates of a cloth, 2 per vertex: its pattern coordinates (m) in units of
/// `metres_per_unit` (the scene's cloth uv_scale), as the frames and animations hold them.
std::vector<float> pattern_texcoords(const std::vector<Vec2>& pattern, double metres_per_unit);

/// An OBJ file of a cloth frame: `v` (9 decimals, m), `vt` (2 per vertex, 7 decimals), `vn`
/// (3 per vertex, 7 decimals) and faces `f a/a/a` (1-based, one texture coordinate and one
/// normal per vertex; `f a//a` without texture coordinates).
void write_textured_obj(std::ostream& out, const double* xyz, int vertex_count, const std::vector<float>& texcoords,
                        const std::vector<float>& normals, const std::vector<std::array<int, 3>>& triangles);

/// An ASCII PLY file of a cloth frame: per vertex x, y, z (9 decimals, m) and the
/// added_viscosity (N s/m, 6 significant digits); faces as vertex index lists.
void write_ply_frame(std::ostream& out, const double* xyz, int vertex_count, const double* added_viscosity,
                     const std::vector<std::array<int, 3>>& triangles);

/// A mesh whose vertices move over the run, recorded frame by frame in single precision
/// (what the glb and PC2 files hold): a 129 x 129 cloth over 200 frames takes 40 MB of
/// positions, and a third as much again for the added viscosity when it is kept.
struct AnimatedMesh {
  std::string name;
  std::vector<std::array<int, 3>> triangles;
  std::vector<float> texcoords;  ///< 2 per vertex (OBJ convention, v up), or empty
  int vertex_count = 0;
  std::vector<float> positions;  ///< frame-major: frame f, vertex i, xyz at 3 * (f * vertex_count + i)
  std::vector<float> viscosity;  ///< added viscosity (N s/m), frame-major, or empty
  bool consistent = true;        ///< false once a frame came with another vertex count (then not exported)

  int frame_count() const { return vertex_count == 0 ? 0 : static_cast<int>(positions.size() / (3 * vertex_count)); }
  /// Appends a frame: 3 * count coordinates, and `count` viscosities when `viscosity_per_vertex`.
  void add_frame(const double* xyz, int count, const double* viscosity_per_vertex = nullptr);
};

/// glTF 2.0 binary: one node per mesh (the first the cloth), positions, normals, the texture
/// coordinates (glTF convention: v down, so 1 - v), a COLOR_0 from the peak added viscosity
/// when recorded, and one morph target per frame after the first, played by a weights
/// animation keyed at `frame_times` (linear between frames). Meshes that do not move get no
/// morph targets. Throws std::runtime_error when a mesh's frame count differs from the times'.
void write_glb(std::ostream& out, const std::vector<const AnimatedMesh*>& meshes, const std::vector<double>& frame_times);

/// PC2 point cache: "POINTCACHE2\0", version 1, point count, start frame 0, one sample per
/// frame, the sample count, then float32 x, y, z per point per frame (little-endian).
void write_pc2(std::ostream& out, const AnimatedMesh& mesh);

/// The first frame of `mesh` as an OBJ with texture coordinates and normals, vertices in the
/// cache's order (the rest mesh a PC2 cache is applied to).
void write_rest_obj(std::ostream& out, const AnimatedMesh& mesh);

/// USD ASCII (.usda): a stage in metres with Y up whose time codes are the frame numbers, at
/// timeCodesPerSecond = 1 / the mean interval of `frame_times` (24 for a single frame); under
/// the prim /weft one Mesh per mesh (the first the cloth), named as the mesh, with its
/// triangles, the texture coordinates as primvars:st (vertex interpolation, v up) when it has
/// them, and `points` time-sampled at every frame (points without samples for a mesh whose
/// frames are all alike). Coordinates are written in the shortest form that reads back as the
/// same float. Throws std::runtime_error when a mesh's frame count differs from the times'.
void write_usda(std::ostream& out, const std::vector<const AnimatedMesh*>& meshes, const std::vector<double>& frame_times);

/// The frames recorded so far, for a checkpoint (a resumed run's animations start from them):
/// each mesh's vertex count, frame count, positions and viscosities, then the frame times.
void write_recorded_frames(std::ostream& out, const std::vector<const AnimatedMesh*>& meshes,
                           const std::vector<double>& frame_times);
/// Reads what write_recorded_frames wrote into `meshes` (whose names and triangles are set,
/// the same count and vertex counts) and `frame_times`, keeping the first `frames`. Throws
/// InputError naming `file` when it does not fit or holds fewer frames.
void read_recorded_frames(const std::string& bytes, const std::string& file, const std::vector<AnimatedMesh*>& meshes,
                          std::vector<double>& frame_times, size_t frames);

}  // namespace weft
