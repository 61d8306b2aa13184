#pragma once
// Reading back what `weft run` wrote into an output folder, for `weft view` (docs/viewer.md):
// the frames' times and, per mesh (the cloth, then the colliders), its triangles, texture
// coordinates and positions frame by frame in single precision, with the added viscosity when
// the run wrote it.
#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "weft/run_frames.hpp"

namespace weft {

/// A PLY frame of `weft run --format ply`.
struct PlyFrame {
  std::vector<double> xyz;                      ///< 3 per vertex
  std::vector<std::array<int, 3>> triangles;    ///< polygons split as fans
  std::vector<double> added_viscosity;          ///< 1 per vertex when the file has the property, else empty
};

/// Reads an ASCII PLY file: a vertex element whose properties include x, y and z (and
/// optionally added_viscosity), then a face element of vertex index lists. Throws InputError
/// "FILE:LINE: ..." for anything else.
PlyFrame read_ply_frame(const std::filesystem::path& path);

/// One mesh of a run, as the viewer plays it.
struct RunMesh {
  std::string name;                 ///< "cloth", "body<k>" or "collider<k>"
  int vertex_count = 0;
  std::vector<std::uint32_t> indices;  ///< 3 per triangle, 0-based
  std::vector<float> texcoords;     ///< 2 per vertex (OBJ convention: v up), or empty
  int frames = 0;                   ///< 1 for a mesh that never moves, else the run's frame count
  std::vector<float> positions;     ///< frame-major: frame f, vertex i, xyz at 3 * (f * vertex_count + i), in m
  /// Added viscosity in N s/m, frame-major (`viscosity_frames` frames of vertex_count values), or empty.
  std::vector<float> viscosity;
  int viscosity_frames = 0;         ///< the run's frame count (PLY frames), 1 (the glb's peak per vertex) or 0
};

/// A run folder read back: where the positions came from and each mesh.
struct RunRecording {
  std::string positions_source;   ///< "glb" (DIR/animation.glb), "obj" or "ply" (DIR/frames)
  std::string viscosity_source;   ///< "ply" (per frame), "glb" (each vertex's peak over the run) or ""
  std::vector<double> times;      ///< the frames' times in s
  double uv_scale = 1;            ///< metres per unit of the texture coordinates (summary.json's uv_scale)
  std::vector<RunMesh> meshes;    ///< the cloth first
};

/// Reads the output folder `dir` of `weft run`: it must hold summary.json and either
/// animation.glb or frames (frames/frame_NNNNN.obj or .ply, numbered from 0 without gaps,
/// with the colliders' frames/body<k>_NNNNN.obj and collider<k>_NNNNN.obj). Positions come from
/// the glb when there is one (it is binary, so quick to read), else from the frames; the added
/// viscosity per frame from PLY frames, else each vertex's peak from the glb's vertex colours.
/// Times come from energy.csv's rows when it has one per frame, else from the glb's animation,
/// else from summary.json's frame_interval; the texture coordinates' scale from summary.json's
/// uv_scale (1 without it). Throws InputError naming the folder or file (and line) when `dir` is
/// missing, is not a run folder, or holds a file that cannot be read.
RunRecording read_run_folder(const std::string& dir);

}  // namespace weft
