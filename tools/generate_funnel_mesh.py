#!/usr/bin/env python3
"""Writes the peg-in-hole funnel (seed §VI-E, Fig. 15) as an OBJ of convex pieces.

    python3 tools/generate_funnel_mesh.py > configs/meshes/funnel.obj

The funnel is a solid of revolution about its z axis: a cone-frustum wall from the mouth (z = 0, the frame's
origin at the mouth's centre) narrowing toward +z into a tube, the hole, closed at its far end. Every wall has
the same thickness. Placed with identity rotation in the NED world, the mouth faces up; rpy_deg [0, -90, 0]
turns it to face +x, toward a pole carried along the platform's -x axis.

The funnel is not convex, so its cone and tube walls are cut into `segments` wedges around the axis, each
wedge a closed convex piece (an OBJ object), and the floor is one more; iapsim collides a convex mesh as one
hull per object. Together the pieces are the funnel's closed surface (plus the faces where neighbours touch).
Pieces rather than the same surface as a Bullet triangle mesh, because they collide more robustly (measured
with 1 ms steps): a 30 mm pole dropped into the triangle mesh still bounced at 0.1 m/s after 5 s, and a ball
in the hole sank 0.6 mm into the floor where its sliver triangles meet (contact normals tilted by 14 deg);
in the pieces the pole is at rest within a second and the ball lies on the floor to 2 micrometres. The pole
costs about 0.25 ms a step either way.

The paper draws the funnel in Fig. 15 without giving its dimensions in the text; the defaults are stated
assumptions sized for a 30 mm pole: 200 mm mouth, 50 mm hole, 45 degree wall, 100 mm deep hole, 5 mm walls.
The output is deterministic (same arguments, same bytes); the script checks that every piece is closed,
wound outward and convex.
"""
import argparse
import math


def profile(mouth_radius, hole_radius, cone_length, hole_depth, wall):
    """The funnel's cross-section in the (r, z) half-plane as convex quadrilaterals (cone wall, tube wall,
    floor), each counter-clockwise in (r, z); r = 0 corners lie on the axis."""
    floor_z = cone_length + hole_depth
    # unit normal of the cone's inner surface, pointing into the wall (away from the cavity)
    length = math.hypot(cone_length, mouth_radius - hole_radius)
    normal = (cone_length / length, (mouth_radius - hole_radius) / length)
    rim_inner = (mouth_radius, 0.0)
    rim_outer = (mouth_radius + wall * normal[0], wall * normal[1])
    throat_inner = (hole_radius, cone_length)
    # the outer cone surface (parallel to the inner one) meets the outer tube surface r = hole_radius + wall
    direction = (hole_radius - mouth_radius, cone_length)
    s = (hole_radius + wall - rim_outer[0]) / direction[0]
    throat_outer = (hole_radius + wall, rim_outer[1] + s * direction[1])
    floor_inner = (hole_radius, floor_z)
    floor_outer = (hole_radius + wall, floor_z + wall)
    return {
        "cone": [throat_inner, rim_inner, rim_outer, throat_outer],
        "tube": [floor_inner, throat_inner, throat_outer, floor_outer],
        "floor": [(0.0, floor_z), floor_inner, floor_outer, (0.0, floor_z + wall)],
    }


class Vertices:
    """Vertices shared by the pieces: a profile corner at an angle step, one vertex on the axis."""

    def __init__(self, segments):
        self.segments = segments
        self.index = {}
        self.points = []

    def at(self, corner, step):
        r, z = corner
        key = (corner, 0 if r == 0.0 else step % self.segments)
        if key not in self.index:
            angle = 2.0 * math.pi * key[1] / self.segments
            self.index[key] = len(self.points)
            self.points.append((r * math.cos(angle), r * math.sin(angle), z))
        return self.index[key]


def wedge(quad, step, vertices, caps=True):
    """The triangles of `quad` swept from angle step `step` to the next: the four faces its edges sweep
    (collapsed to triangles, or nothing, on the axis) and, with `caps`, its two end caps."""
    near = [vertices.at(c, step) for c in quad]
    far = [vertices.at(c, step + 1) for c in quad]
    # a quad counter-clockwise in (r, z) faces -theta: seen from outside, the near cap is as listed
    polygons = [near, far[::-1]] if caps else []
    for i in range(4):
        j = (i + 1) % 4
        polygons.append([near[i], far[i], far[j], near[j]])
    triangles = []
    for polygon in polygons:
        corners = [v for n, v in enumerate(polygon) if v != polygon[n - 1]]  # drop repeats (the axis)
        for n in range(1, len(corners) - 1):
            triangles.append((corners[0], corners[n], corners[n + 1]))
    return triangles


def check_piece(points, triangles):
    """Closed (each edge in two triangles, opposite ways), wound outward and convex (every vertex on or
    behind every face's plane)."""
    edges = set()
    for t in triangles:
        for n in range(3):
            edges.add((t[n], t[(n + 1) % 3]))
    if len(edges) != 3 * len(triangles) or any((j, i) not in edges for i, j in edges):
        raise SystemExit("a piece is not closed")
    used = sorted({v for t in triangles for v in t})
    centre = [sum(points[v][k] for v in used) / len(used) for k in range(3)]
    for a, b, c in triangles:
        pa, pb, pc = points[a], points[b], points[c]
        u = [pb[k] - pa[k] for k in range(3)]
        w = [pc[k] - pa[k] for k in range(3)]
        normal = (u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0])
        size = math.sqrt(sum(x * x for x in normal))
        height = lambda p: sum(normal[k] * (p[k] - pa[k]) for k in range(3)) / size
        if height(centre) >= 0.0:
            raise SystemExit("a piece is wound inward")
        if any(height(points[v]) > 1e-6 for v in used):  # the written coordinates are rounded
            raise SystemExit("a piece is not convex")


def number(value):
    text = f"{value:.9f}"  # nanometres
    return text[1:] if text == "-0.000000000" else text


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--mouth-radius-m", type=float, default=0.10, help="inner radius of the mouth")
    parser.add_argument("--hole-radius-m", type=float, default=0.025, help="inner radius of the hole")
    parser.add_argument("--cone-length-m", type=float, default=0.075, help="mouth to hole, along the axis")
    parser.add_argument("--hole-depth-m", type=float, default=0.10, help="throat to the hole's floor")
    parser.add_argument("--wall-m", type=float, default=0.005, help="thickness of every wall")
    parser.add_argument("--segments", type=int, default=48, help="pieces of each wall around the axis")
    args = parser.parse_args()
    if not (0.0 < args.hole_radius_m < args.mouth_radius_m and args.cone_length_m > 0.0
            and args.hole_depth_m > 0.0 and args.wall_m > 0.0 and args.segments >= 8):
        raise SystemExit("expected 0 < hole radius < mouth radius, positive lengths, 8 or more segments")

    quads = profile(args.mouth_radius_m, args.hole_radius_m, args.cone_length_m, args.hole_depth_m,
                    args.wall_m)
    vertices = Vertices(args.segments)
    pieces = []
    for name in ("cone", "tube"):  # annuli: a wedge per step
        for step in range(args.segments):
            pieces.append((f"{name}_{step:02d}", wedge(quads[name], step, vertices)))
    # the floor is a convex disc: one piece, swept all the way round (so no caps)
    floor = [t for step in range(args.segments) for t in wedge(quads["floor"], step, vertices, caps=False)]
    pieces.append(("floor", floor))
    # rounded as written, so the checks see what a reader gets
    points = [tuple(float(number(x)) for x in p) for p in vertices.points]
    for _, triangles in pieces:
        check_piece(points, triangles)

    print("# funnel for the peg-in-hole scenario (seed §VI-E), metres; axis +z from the mouth (z = 0) into")
    print("# the hole; one convex piece per object. Generated, do not edit:")
    print("# python3 tools/generate_funnel_mesh.py"
          f" --mouth-radius-m {args.mouth_radius_m} --hole-radius-m {args.hole_radius_m}"
          f" --cone-length-m {args.cone_length_m} --hole-depth-m {args.hole_depth_m}"
          f" --wall-m {args.wall_m} --segments {args.segments}")
    for x, y, z in points:
        print(f"v {number(x)} {number(y)} {number(z)}")
    for name, triangles in pieces:
        print(f"o {name}")
        for i, j, k in triangles:
            print(f"f {i + 1} {j + 1} {k + 1}")


if __name__ == "__main__":
    main()
