#!/usr/bin/env python3
"""Writes scenes/funnel.obj: a closed funnel with walls of 4 cm and rounded rims, its axis the
y axis: a cone from a mouth of radius 0.3 m at y = 0.6 m down to a neck of radius 0.07 m at
y = 0.3 m, then a straight spout down to y = 0.1 m. The wall's section (a band about the
profile line, closed by half circles at both rims) is turned about the axis, so the surface is
closed and has no sharp edge for the cloth to catch on.

Usage: tools/funnel_obj.py [OUT] (default scenes/funnel.obj)."""
import math
import sys

PROFILE = [(0.30, 0.60), (0.07, 0.30), (0.07, 0.10)]  # (radius, height) along the wall, m
HALF_WALL = 0.02    # m
ALONG = 0.015       # m, spacing of the section's points along the profile
CAP_STEPS = 8       # points on each rim's half circle
AROUND = 64         # segments about the axis


def section():
    """The wall's closed section in the (r, y) half plane, counter-clockwise."""
    # The profile sampled, with the unit normal of each piece (pointing to the outer side).
    pts, normals = [], []
    for (r0, y0), (r1, y1) in zip(PROFILE, PROFILE[1:]):
        length = math.hypot(r1 - r0, y1 - y0)
        tr, ty = (r1 - r0) / length, (y1 - y0) / length
        nr, ny = ty, -tr  # the tangent turned clockwise: the outer side of a wall going down
        steps = max(1, round(length / ALONG))
        for k in range(steps + (1 if (r1, y1) == PROFILE[-1] else 0)):
            s = k / steps
            pts.append((r0 + s * (r1 - r0), y0 + s * (y1 - y0)))
            normals.append((nr, ny))
    # Smooth the normals at the profile's corner.
    outer = [(r + HALF_WALL * nr, y + HALF_WALL * ny) for (r, y), (nr, ny) in zip(pts, normals)]
    inner = [(r - HALF_WALL * nr, y - HALF_WALL * ny) for (r, y), (nr, ny) in zip(pts, normals)]
    ring = list(outer)
    # Bottom rim: a half circle from the outer to the inner side about the profile's end.
    (re, ye), (nr, ny) = pts[-1], normals[-1]
    tr, ty = -ny, nr  # along the wall, pointing down (away from the profile)
    tr, ty = (-tr, -ty) if (tr * (pts[-1][0] - pts[-2][0]) + ty * (pts[-1][1] - pts[-2][1])) < 0 else (tr, ty)
    for k in range(1, CAP_STEPS):
        a = math.pi * k / CAP_STEPS
        ring.append((re + HALF_WALL * (math.cos(a) * nr + math.sin(a) * tr),
                     ye + HALF_WALL * (math.cos(a) * ny + math.sin(a) * ty)))
    ring.extend(reversed(inner))
    (rs, ys), (nr, ny) = pts[0], normals[0]
    tr, ty = (pts[0][0] - pts[1][0]), (pts[0][1] - pts[1][1])
    length = math.hypot(tr, ty)
    tr, ty = tr / length, ty / length  # along the wall, pointing up out of the mouth
    for k in range(1, CAP_STEPS):
        a = math.pi * k / CAP_STEPS
        ring.append((rs + HALF_WALL * (-math.cos(a) * nr + math.sin(a) * tr),
                     ys + HALF_WALL * (-math.cos(a) * ny + math.sin(a) * ty)))
    return ring


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "scenes/funnel.obj"
    ring = section()
    m = len(ring)
    # Orientation of the section: positive area in (r, y) means counter-clockwise.
    area = sum(r0 * y1 - r1 * y0 for (r0, y0), (r1, y1) in zip(ring, ring[1:] + ring[:1]))
    lines = ["# weft: a closed funnel with rounded rims (tools/funnel_obj.py)"]
    for j in range(AROUND):
        phi = 2 * math.pi * j / AROUND
        c, s = math.cos(phi), math.sin(phi)
        for r, y in ring:
            lines.append("v %.6f %.6f %.6f" % (r * c, y, -r * s))
    for j in range(AROUND):
        j1 = (j + 1) % AROUND
        for i in range(m):
            i1 = (i + 1) % m
            a, b, c, d = j * m + i + 1, j * m + i1 + 1, j1 * m + i1 + 1, j1 * m + i + 1
            if area < 0:
                lines.append("f %d %d %d" % (a, b, c))
                lines.append("f %d %d %d" % (a, c, d))
            else:
                lines.append("f %d %d %d" % (a, c, b))
                lines.append("f %d %d %d" % (a, d, c))
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
