#!/usr/bin/env python3
"""Writes the meshes the renderer draws (configs/meshes/visual/*.obj), generated, not downloaded:

    /usr/bin/python3 tools/generate_render_assets.py configs/meshes/visual

  f450.obj (+ f450.mtl)   F450-class quadrotor, FRD body frame at the centre of mass: 450 mm motor-to-motor
                          diagonal (hubs at 0.225 m, X layout as configs/vehicles/parts/f450.yaml), 10"
                          propeller discs, two plates, landing gear
  platform.obj (+ .mtl)   the three-star platform of Table I: 0.2 x 0.2 x 0.05 m hub, arms to the joints at
                          d_h 0.48 m, 120 deg apart, d_v 0.07 m below, a ball socket at each joint
  pole.obj                the 1 m, 15 mm radius pole of configs/vehicles/three_star_pole.yaml, along x
  wall.obj                a 4 x 3 m wall panel, 0.2 m thick, standing on z = 0 (NED: up is -z)
  docking_cone.obj        the docking funnel of seed Fig. 6: mouth radius 0.08 m, apex toward +z
  docking_cylinder.obj    the docking probe: 0.02 m radius, 0.12 m long, along +z

Units are metres, axes FRD/NED like every iapsim body. The output is deterministic (same bytes every run):
no randomness, fixed formatting. Texture coordinates are in metres along each face (the scene's
texture_scale_m sets how often a texture repeats).
"""
import math
import os
import sys


class Mesh:
    def __init__(self):
        self.groups = []  # (name, material, vertices [(p, n, uv)], triangles [(a, b, c)])

    def group(self, name, material=None):
        self.groups.append((name, material, [], []))

    def _add(self, corners, normal):
        _, _, vertices, triangles = self.groups[-1]
        base = len(vertices)
        origin = corners[0]
        u_axis = _normalized(_sub(corners[1], corners[0]))
        v_axis = _cross(normal, u_axis)
        for p in corners:
            d = _sub(p, origin)
            vertices.append((p, normal, (_dot(d, u_axis), _dot(d, v_axis))))
        for i in range(1, len(corners) - 1):
            triangles.append((base, base + i, base + i + 1))

    def box(self, center, size):
        cx, cy, cz = center
        hx, hy, hz = (s / 2 for s in size)
        for axis in range(3):
            for sign in (-1, 1):
                normal = [0.0, 0.0, 0.0]
                normal[axis] = float(sign)
                u, v = [a for a in range(3) if a != axis]
                if sign < 0:
                    u, v = v, u  # counter-clockwise seen from outside
                corners = []
                for du, dv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                    p = [0.0, 0.0, 0.0]
                    p[axis] = sign
                    p[u], p[v] = du, dv
                    corners.append((cx + p[0] * hx, cy + p[1] * hy, cz + p[2] * hz))
                self._add(corners, tuple(normal))

    def cylinder(self, a, b, radius, segments=24, caps=True, radius_b=None):
        """A (truncated) cone from a (radius) to b (radius_b, default radius)."""
        radius_b = radius if radius_b is None else radius_b
        axis = _normalized(_sub(b, a))
        x = _normalized(_cross(axis, (0.0, 0.0, 1.0) if abs(axis[2]) < 0.9 else (1.0, 0.0, 0.0)))
        y = _cross(axis, x)
        length = _norm(_sub(b, a))
        slope = (radius - radius_b) / length
        ring = [(math.cos(2 * math.pi * i / segments), math.sin(2 * math.pi * i / segments)) for i in range(segments)]
        for i in range(segments):
            (c0, s0), (c1, s1) = ring[i], ring[(i + 1) % segments]
            def at(center, r, c, s):
                return _add(center, _add(_scale(x, r * c), _scale(y, r * s)))
            cm, sm = (c0 + c1) / 2, (s0 + s1) / 2
            normal = _normalized(_add(_add(_scale(x, cm), _scale(y, sm)), _scale(axis, slope)))
            corners = [at(a, radius, c0, s0), at(a, radius, c1, s1), at(b, radius_b, c1, s1), at(b, radius_b, c0, s0)]
            if radius_b == 0.0:
                corners = corners[:3]
            self._add(corners, normal)
        if caps:
            for center, r, sign in ((a, radius, -1.0), (b, radius_b, 1.0)):
                if r <= 0.0:
                    continue
                points = [_add(center, _add(_scale(x, r * c), _scale(y, r * s))) for c, s in ring]
                if sign < 0:
                    points.reverse()
                self._add(points, _scale(axis, sign))

    def sphere(self, center, radius, segments=16):
        stacks = segments // 2
        for j in range(stacks):
            t0, t1 = math.pi * j / stacks, math.pi * (j + 1) / stacks
            for i in range(segments):
                p0, p1 = 2 * math.pi * i / segments, 2 * math.pi * (i + 1) / segments
                def at(t, p):
                    return (math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t))
                quad = [at(t0, p0), at(t1, p0), at(t1, p1), at(t0, p1)]
                if j == 0:
                    quad = [quad[0], quad[1], quad[2]]
                elif j == stacks - 1:
                    quad = [quad[0], quad[1], quad[3]]
                mid = _normalized(tuple(sum(c[k] for c in quad) for k in range(3)))
                self._add([_add(center, _scale(n, radius)) for n in quad], mid)

    def write(self, path, mtl=None):
        lines = ["# generated by tools/generate_render_assets.py; do not edit"]
        if mtl:
            lines.append("mtllib " + mtl)
        offset = 1
        for name, material, vertices, triangles in self.groups:
            lines.append("o " + name)
            if material:
                lines.append("usemtl " + material)
            for p, n, uv in vertices:
                lines.append("v %.6f %.6f %.6f" % p)
                lines.append("vn %.6f %.6f %.6f" % n)
                lines.append("vt %.6f %.6f" % uv)
            for t in triangles:
                lines.append("f " + " ".join("%d/%d/%d" % (offset + i, offset + i, offset + i) for i in t))
            offset += len(vertices)
        with open(path, "w") as out:
            out.write("\n".join(lines) + "\n")


def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _scale(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _norm(a):
    return math.sqrt(_dot(a, a))


def _normalized(a):
    n = _norm(a)
    return (a[0] / n, a[1] / n, a[2] / n)


def write_mtl(path, materials):
    lines = ["# generated by tools/generate_render_assets.py; do not edit"]
    for name, (r, g, b), shininess in materials:
        lines += ["newmtl " + name, "Kd %.3f %.3f %.3f" % (r, g, b), "Ns %.1f" % shininess]
    with open(path, "w") as out:
        out.write("\n".join(lines) + "\n")


def f450(folder):
    mesh = Mesh()
    mesh.group("plates", "frame")
    mesh.box((0.0, 0.0, -0.025), (0.14, 0.14, 0.004))
    mesh.box((0.0, 0.0, 0.015), (0.12, 0.12, 0.004))
    mesh.group("battery", "battery")
    mesh.box((0.0, 0.0, -0.05), (0.14, 0.045, 0.03))
    arm = 0.225
    for k, angle_deg in enumerate((45, 135, 225, 315)):
        a = math.radians(angle_deg)
        hub = (arm * math.cos(a), arm * math.sin(a), 0.0)
        # front arms red, rear arms white, as F450 kits come
        mesh.group("arm%d" % (k + 1), "arm_front" if math.cos(a) > 0 else "arm_rear")
        mesh.cylinder(_scale(hub, 0.25), hub, 0.012, 12)
        mesh.group("motor%d" % (k + 1), "motor")
        mesh.cylinder(_add(hub, (0, 0, -0.005)), _add(hub, (0, 0, -0.035)), 0.014, 16)
        mesh.group("propeller%d" % (k + 1), "propeller")
        mesh.cylinder(_add(hub, (0, 0, -0.038)), _add(hub, (0, 0, -0.041)), 0.127, 32)
    mesh.group("landing_gear", "frame")
    for sx in (-1, 1):
        for sy in (-1, 1):
            mesh.cylinder((0.05 * sx, 0.05 * sy, 0.017), (0.08 * sx, 0.08 * sy, 0.16), 0.005, 8)
    mesh.write(os.path.join(folder, "f450.obj"), "f450.mtl")
    write_mtl(os.path.join(folder, "f450.mtl"), [
        ("frame", (0.12, 0.12, 0.13), 32), ("battery", (0.2, 0.3, 0.8), 16), ("arm_front", (0.8, 0.12, 0.08), 48),
        ("arm_rear", (0.92, 0.92, 0.9), 48), ("motor", (0.6, 0.6, 0.62), 96), ("propeller", (0.05, 0.05, 0.05), 16)])


def platform(folder):
    mesh = Mesh()
    mesh.group("hub", "hub")
    mesh.box((0.0, 0.0, 0.0), (0.2, 0.2, 0.05))
    mesh.group("arms", "arm")
    for k in range(3):
        a = 2 * math.pi * k / 3
        joint = (0.48 * math.cos(a), 0.48 * math.sin(a), 0.07)
        mesh.cylinder((0.09 * math.cos(a), 0.09 * math.sin(a), 0.0), _add(joint, (0, 0, -0.03)), 0.012, 12)
        mesh.cylinder(_add(joint, (0, 0, -0.03)), _add(joint, (0, 0, -0.02)), 0.012, 12)
    mesh.group("joints", "joint")
    for k in range(3):
        a = 2 * math.pi * k / 3
        mesh.sphere((0.48 * math.cos(a), 0.48 * math.sin(a), 0.07), 0.022)
    mesh.write(os.path.join(folder, "platform.obj"), "platform.mtl")
    write_mtl(os.path.join(folder, "platform.mtl"), [
        ("hub", (0.2, 0.2, 0.22), 32), ("arm", (0.7, 0.7, 0.72), 64), ("joint", (0.85, 0.65, 0.2), 96)])


def simple(folder):
    pole = Mesh()
    pole.group("pole")
    pole.cylinder((-0.5, 0.0, 0.0), (0.5, 0.0, 0.0), 0.015, 16)
    pole.write(os.path.join(folder, "pole.obj"))
    wall = Mesh()
    wall.group("wall")
    wall.box((0.0, 0.0, -1.5), (0.2, 4.0, 3.0))
    wall.write(os.path.join(folder, "wall.obj"))
    cone = Mesh()
    cone.group("funnel")
    cone.cylinder((0.0, 0.0, -0.04), (0.0, 0.0, 0.04), 0.08, 32, radius_b=0.02)
    cone.write(os.path.join(folder, "docking_cone.obj"))
    probe = Mesh()
    probe.group("probe")
    probe.cylinder((0.0, 0.0, -0.06), (0.0, 0.0, 0.06), 0.02, 24)
    probe.write(os.path.join(folder, "docking_cylinder.obj"))


def main():
    folder = sys.argv[1] if len(sys.argv) > 1 else "configs/meshes/visual"
    os.makedirs(folder, exist_ok=True)
    f450(folder)
    platform(folder)
    simple(folder)


if __name__ == "__main__":
    main()
