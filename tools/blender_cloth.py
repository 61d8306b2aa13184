"""Blender's cloth on a scene exported by weft: run inside Blender, not on its own.

    blender --background --factory-startup -t 1 --python tools/blender_cloth.py -- CASE.json OUT_DIR

tools/blender_compare.py writes CASE.json and runs this; see docs/notes/blender.md. CASE.json holds

    start       weft's cloth OBJ frame to start from (its triangles and positions)
    rest        weft's cloth OBJ frame whose edge lengths and angles are the rest shape
    body        the body's OBJ frames, one per output frame from the start on
    fps         output frames per second (1 / weft's frame_interval)
    frames      output frames to simulate after the start
    cloth       Blender ClothSettings attributes to set (name: value)
    collision   Blender ClothCollisionSettings attributes
    body_collision  Blender CollisionSettings attributes of the body

The meshes are read in weft's axes (metres, y up) and built in Blender's (z up): (x, y, z) ->
(x, -z, y); the cloth frames written back are in weft's axes again, with the start's vertex
order and triangles, as OUT_DIR/frames/frame_NNNNN.obj (frame 0 the start), so that
`weft check OUT_DIR` reads them. OUT_DIR/blender.json holds the wall and CPU seconds of the
simulation alone (Blender's frame changes, not the start-up, the scene's set-up or the
writing of frames), per frame and in all.
"""

import json
import os
import struct
import sys
import time

import bpy


def fail(message):
    print("blender_cloth.py: error: " + message, file=sys.stderr)
    sys.stderr.flush()
    os._exit(2)


def read_obj(path, want_faces):
    """Vertices (Blender's axes) and, if asked, triangles (0-based) of an OBJ file."""
    verts, faces = [], []
    try:
        with open(path) as f:
            for line_no, line in enumerate(f, 1):
                if line.startswith("v "):
                    p = line.split()
                    try:
                        x, y, z = float(p[1]), float(p[2]), float(p[3])
                    except (IndexError, ValueError):
                        fail("%s:%d: a vertex needs three numbers: %r" % (path, line_no, line.strip()))
                    verts.append((x, -z, y))
                elif want_faces and line.startswith("f "):
                    idx = [int(t.split("/")[0]) - 1 for t in line.split()[1:]]
                    if len(idx) != 3:
                        fail("%s:%d: a face must be a triangle: %r" % (path, line_no, line.strip()))
                    faces.append(tuple(idx))
    except OSError as e:
        fail("cannot read %s: %s" % (path, e.strerror))
    if not verts:
        fail("%s has no vertices" % path)
    return verts, faces


def set_attributes(target, values, what):
    for name, value in values.items():
        if not hasattr(target, name):
            fail("%s has no setting %r (Blender %s)" % (what, name, bpy.app.version_string))
        setattr(target, name, value)


def write_pc2(path, frames):
    with open(path, "wb") as f:
        f.write(b"POINTCACHE2\0")
        f.write(struct.pack("<iiffi", 1, len(frames[0]), 0.0, 1.0, len(frames)))
        for verts in frames:
            f.write(struct.pack("<%df" % (3 * len(verts)), *[c for v in verts for c in v]))


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(argv) != 2:
        fail("usage: blender --background --python blender_cloth.py -- CASE.json OUT_DIR")
    case_path, out_dir = argv
    try:
        with open(case_path) as f:
            case = json.load(f)
    except (OSError, ValueError) as e:
        fail("cannot read %s: %s" % (case_path, e))
    frames_dir = os.path.join(out_dir, "frames")
    os.makedirs(frames_dir, exist_ok=True)

    scene = bpy.context.scene
    for ob in list(bpy.data.objects):
        bpy.data.objects.remove(ob)
    fps = int(round(case["fps"]))
    if abs(fps - case["fps"]) > 1e-6:
        fail("fps %r is not a whole number" % case["fps"])
    frames = int(case["frames"])
    scene.render.fps, scene.render.fps_base = fps, 1.0
    scene.gravity = (0.0, 0.0, -9.81)
    scene.frame_start, scene.frame_end = 1, 1 + frames

    # The body: its first frame as the mesh, every frame as a PC2 point cache played by a
    # Mesh Cache modifier, then the Collision modifier on the deformed mesh.
    body_files = case["body"]
    if len(body_files) < frames + 1:
        fail("%d body frames for %d frames after the start" % (len(body_files), frames))
    body_frames = []
    body_faces = None
    for k, path in enumerate(body_files[:frames + 1]):
        verts, faces = read_obj(path, k == 0)
        if k == 0:
            body_faces = faces
        elif len(verts) != len(body_frames[0]):
            fail("%s has %d vertices, the first body frame %d" % (path, len(verts), len(body_frames[0])))
        body_frames.append(verts)
    body_mesh = bpy.data.meshes.new("body")
    body_mesh.from_pydata(body_frames[0], [], body_faces)
    body = bpy.data.objects.new("body", body_mesh)
    scene.collection.objects.link(body)
    pc2 = os.path.join(out_dir, "body.pc2")
    write_pc2(pc2, body_frames)
    cache = body.modifiers.new("cache", "MESH_CACHE")
    cache.cache_format, cache.filepath = "PC2", pc2
    cache.forward_axis, cache.up_axis = "POS_Y", "POS_Z"
    cache.frame_start = 1.0  # cache frame 0 at scene frame 1
    body.modifiers.new("collision", "COLLISION")
    set_attributes(body.collision, case.get("body_collision", {}), "the body's collision settings")

    # The cloth: weft's start frame, with weft's rest frame as the rest shape key when it differs.
    start_verts, tris = read_obj(case["start"], True)
    cloth_mesh = bpy.data.meshes.new("cloth")
    cloth_mesh.from_pydata(start_verts, [], tris)
    cloth = bpy.data.objects.new("cloth", cloth_mesh)
    scene.collection.objects.link(cloth)
    mod = cloth.modifiers.new("cloth", "CLOTH")
    if case["rest"] != case["start"]:
        rest_verts, _ = read_obj(case["rest"], False)
        if len(rest_verts) != len(start_verts):
            fail("%s has %d vertices, %s %d" % (case["rest"], len(rest_verts), case["start"], len(start_verts)))
        cloth.shape_key_add(name="start", from_mix=False)
        rest_key = cloth.shape_key_add(name="rest", from_mix=False)
        rest_key.data.foreach_set("co", [c for v in rest_verts for c in v])
        rest_key.value = 0.0
        mod.settings.rest_shape_key = rest_key
    set_attributes(mod.settings, case.get("cloth", {}), "ClothSettings")
    set_attributes(mod.collision_settings, case.get("collision", {}), "ClothCollisionSettings")
    mod.point_cache.frame_start, mod.point_cache.frame_end = 1, 1 + frames

    n = len(start_verts)
    wall, cpu, per_frame = 0.0, 0.0, []
    for k in range(frames + 1):
        w0, c0 = time.perf_counter(), time.process_time()
        scene.frame_set(1 + k)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        evaluated = cloth.evaluated_get(depsgraph)
        co = [0.0] * (3 * n)
        evaluated.data.vertices.foreach_get("co", co)
        dw, dc = time.perf_counter() - w0, time.process_time() - c0
        wall, cpu = wall + dw, cpu + dc
        per_frame.append(round(dw, 4))
        if len(evaluated.data.vertices) != n:
            fail("the evaluated cloth has %d vertices, not %d" % (len(evaluated.data.vertices), n))
        lines = ["v %.9f %.9f %.9f\n" % (co[3 * i], co[3 * i + 2], -co[3 * i + 1]) for i in range(n)]
        lines += ["f %d %d %d\n" % (a + 1, b + 1, c + 1) for a, b, c in tris]
        path = os.path.join(frames_dir, "frame_%05d.obj" % k)
        with open(path + ".tmp", "w") as f:
            f.writelines(lines)
        os.replace(path + ".tmp", path)
    os.remove(pc2)
    result = {
        "blender": bpy.app.version_string,
        "frames": frames,
        "vertices": n,
        "triangles": len(tris),
        "sim_wall_seconds": round(wall, 3),
        "sim_cpu_seconds": round(cpu, 3),
        "frame_wall_seconds": per_frame,
    }
    with open(os.path.join(out_dir, "blender.json"), "w") as f:
        json.dump(result, f, indent=1)
    print("blender_cloth.py: %d frames in %.2f s (CPU %.2f s)" % (frames, wall, cpu))
    sys.stdout.flush()


try:
    main()
except SystemExit:
    raise
except BaseException:  # an error inside Blender must still end it with a non-zero status
    import traceback
    traceback.print_exc()
    os._exit(1)
os._exit(0)
