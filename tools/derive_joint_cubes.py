#!/usr/bin/env python3
"""Writes data/body/joint_cubes.obj: the `joint-*` groups of MakeHuman's base.obj that the rig
names (CUBE strategy), with their vertices copied verbatim (decimetres) and faces re-indexed.

Usage: tools/derive_joint_cubes.py BASE_OBJ RIG_JSON OUT_OBJ
"""
import json
import sys

base_path, rig_path, out_path = sys.argv[1:4]
rig = json.load(open(rig_path))
wanted = set()
for bone in rig.values():
    for end in ("head", "tail"):
        if bone[end]["strategy"] == "CUBE":
            wanted.add(bone[end]["cube_name"])

vertices, groups, group = [], {}, None
for line in open(base_path):
    if line.startswith("v "):
        vertices.append(line.split()[1:4])
    elif line.startswith("g "):
        group = line.split()[1]
    elif line.startswith("f ") and group in wanted:
        groups.setdefault(group, []).append([int(t.split("/")[0]) - 1 for t in line.split()[1:]])

missing = wanted - set(groups)
if missing:
    sys.exit("groups not found in %s: %s" % (base_path, sorted(missing)))
with open(out_path, "w") as out:
    out.write("# Joint-centre cubes of the MakeHuman hm08 base mesh (CC0 1.0), derived from base.obj\n")
    out.write("# by tools/derive_joint_cubes.py: the joint-* groups the rig names, decimetres as in base.obj.\n")
    for name in sorted(groups):
        used = sorted({i for face in groups[name] for i in face})
        local = {}
        out.write("g %s\n" % name)
        for i in used:
            local[i] = len(local)
        # vertex numbers restart per group in the relative (negative) form, so each group stands alone
        for i in used:
            out.write("v %s %s %s\n" % tuple(vertices[i]))
        for face in groups[name]:
            out.write("f %s\n" % " ".join(str(local[i] - len(used)) for i in face))
