#!/usr/bin/env python3
"""stl_shapes.py - write ASCII STL meshes of simple containers (box, drum, tilted box) for
fix mesh/surface (the DEM walls) and fix sph/wall mesh (the SPH dummy walls).

Facet normals point INTO the container (towards the fluid / the grains), and the vertex
order of every facet is counter-clockwise seen from that side, so the normal given by the
winding and the written "facet normal" agree.

Command line (prints to stdout unless -o is given):
  stl_shapes.py box      --lo 0 0 0 --hi 0.1 0.1 0.2 [--open-top] [-o box.stl]
  stl_shapes.py cylinder --center 0 0 0 --axis 0 1 0 --radius 0.1 --length 0.05
                         [--segments 48] [--open-ends] [-o drum.stl]
  stl_shapes.py tilted   --lo 0 0 0 --hi 0.1 0.1 0.2 --angle 15 --axis 0 1 0
                         [--pivot X Y Z] [--open-top] [-o tilted.stl]

Importable: box(lo, hi, open_top=False), cylinder(center, axis, radius, length, segments=48,
closed=True), tilted_box(lo, hi, angle_deg, axis, pivot=None, open_top=False) return lists of
triangles (3 vertices each, tuples of 3 floats); write_stl(path_or_file, triangles, name).
Standard library only.
"""
import argparse
import math
import sys


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _unit(a):
    n = math.sqrt(_dot(a, a))
    if n == 0.0:
        raise ValueError("zero-length vector")
    return (a[0] / n, a[1] / n, a[2] / n)


def normal(tri):
    """Unit normal of a triangle by its vertex winding (right-hand rule)."""
    return _unit(_cross(_sub(tri[1], tri[0]), _sub(tri[2], tri[0])))


def _quad(a, b, c, d):
    """Two triangles of the quad a-b-c-d, wound so the normal points to the side from
    which a-b-c-d runs clockwise (the quads below are listed clockwise seen from inside)."""
    return [(a, c, b), (a, d, c)]


def box(lo, hi, open_top=False):
    """Closed (or open-top, +z face missing) box from corner lo to corner hi, normals inward."""
    x0, y0, z0 = (float(v) for v in lo)
    x1, y1, z1 = (float(v) for v in hi)
    if not (x1 > x0 and y1 > y0 and z1 > z0):
        raise ValueError("box: hi must exceed lo in x, y and z")
    p = lambda i, j, k: ((x0, x1)[i], (y0, y1)[j], (z0, z1)[k])
    tris = []
    # each quad is listed clockwise seen from inside the box (_quad reverses it)
    tris += _quad(p(0, 0, 0), p(0, 1, 0), p(1, 1, 0), p(1, 0, 0))  # bottom z=z0, normal +z
    if not open_top:
        tris += _quad(p(0, 0, 1), p(1, 0, 1), p(1, 1, 1), p(0, 1, 1))  # top z=z1, normal -z
    tris += _quad(p(0, 0, 0), p(0, 0, 1), p(0, 1, 1), p(0, 1, 0))  # x=x0, normal +x
    tris += _quad(p(1, 0, 0), p(1, 1, 0), p(1, 1, 1), p(1, 0, 1))  # x=x1, normal -x
    tris += _quad(p(0, 0, 0), p(1, 0, 0), p(1, 0, 1), p(0, 0, 1))  # y=y0, normal +y
    tris += _quad(p(0, 1, 0), p(0, 1, 1), p(1, 1, 1), p(1, 1, 0))  # y=y1, normal -y
    return tris


def _rotate(v, axis, angle, pivot):
    """Rodrigues rotation of point v by angle (rad) about the unit axis through pivot."""
    k = _unit(axis)
    r = _sub(v, pivot)
    c, s = math.cos(angle), math.sin(angle)
    kxr = _cross(k, r)
    kr = _dot(k, r)
    out = tuple(r[i] * c + kxr[i] * s + k[i] * kr * (1.0 - c) for i in range(3))
    return (out[0] + pivot[0], out[1] + pivot[1], out[2] + pivot[2])


def tilted_box(lo, hi, angle_deg, axis=(0.0, 1.0, 0.0), pivot=None, open_top=False):
    """box(lo, hi) rotated by angle_deg about axis through pivot (default: the box centre)."""
    if pivot is None:
        pivot = tuple(0.5 * (float(lo[i]) + float(hi[i])) for i in range(3))
    a = math.radians(float(angle_deg))
    return [tuple(_rotate(v, axis, a, pivot) for v in t) for t in box(lo, hi, open_top)]


def cylinder(center, axis, radius, length, segments=48, closed=True):
    """Drum: a cylinder of the given radius and length, centred at center, along axis;
    the mantle is a prism of `segments` flat facets whose vertices lie on the circle;
    closed=True adds the two end caps (fans around the axis). Normals point inward."""
    if radius <= 0 or length <= 0 or segments < 3:
        raise ValueError("cylinder: radius > 0, length > 0 and segments >= 3 are required")
    k = _unit(axis)
    # two unit vectors e1, e2 perpendicular to the axis with e1 x e2 = k
    helper = (1.0, 0.0, 0.0) if abs(k[0]) < 0.9 else (0.0, 1.0, 0.0)
    e1 = _unit(_cross(helper, k))
    e2 = _cross(k, e1)
    c = tuple(float(v) for v in center)
    half = 0.5 * float(length)

    def pt(i, s):
        t = 2.0 * math.pi * (i % segments) / segments
        ct, st = math.cos(t), math.sin(t)
        return tuple(c[j] + radius * (ct * e1[j] + st * e2[j]) + s * half * k[j] for j in range(3))

    c0 = tuple(c[j] - half * k[j] for j in range(3))
    c1 = tuple(c[j] + half * k[j] for j in range(3))
    tris = []
    for i in range(segments):
        a0, b0 = pt(i, -1), pt(i + 1, -1)
        a1, b1 = pt(i, +1), pt(i + 1, +1)
        # mantle facet, listed clockwise seen from the axis (normal inward)
        tris += _quad(a0, b0, b1, a1)
        if closed:
            tris.append((c0, a0, b0))  # end at -axis, normal +k (into the drum)
            tris.append((c1, b1, a1))  # end at +axis, normal -k
    return tris


def write_stl(out, triangles, name="sphdem"):
    """Write triangles as ASCII STL to a path or an open text file."""
    if isinstance(out, str):
        with open(out, "w") as f:
            return write_stl(f, triangles, name)
    out.write("solid %s\n" % name)
    for t in triangles:
        n = normal(t)
        out.write("  facet normal %.9g %.9g %.9g\n    outer loop\n" % n)
        for v in t:
            out.write("      vertex %.12g %.12g %.12g\n" % tuple(v))
        out.write("    endloop\n  endfacet\n")
    out.write("endsolid %s\n" % name)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="shape", required=True)
    for nm in ("box", "tilted"):
        p = sub.add_parser(nm)
        p.add_argument("--lo", type=float, nargs=3, required=True)
        p.add_argument("--hi", type=float, nargs=3, required=True)
        p.add_argument("--open-top", action="store_true", help="leave out the +z face")
        if nm == "tilted":
            p.add_argument("--angle", type=float, required=True, help="degrees")
            p.add_argument("--axis", type=float, nargs=3, default=[0.0, 1.0, 0.0])
            p.add_argument("--pivot", type=float, nargs=3, default=None, help="default: box centre")
    p = sub.add_parser("cylinder")
    p.add_argument("--center", type=float, nargs=3, default=[0.0, 0.0, 0.0])
    p.add_argument("--axis", type=float, nargs=3, default=[0.0, 1.0, 0.0])
    p.add_argument("--radius", type=float, required=True)
    p.add_argument("--length", type=float, required=True)
    p.add_argument("--segments", type=int, default=48)
    p.add_argument("--open-ends", action="store_true", help="no end caps")
    for p in sub.choices.values():
        p.add_argument("-o", "--output", default="-", help="STL file (default: stdout)")
        p.add_argument("--name", default=None, help="solid name")
    a = ap.parse_args(argv)
    if a.shape == "box":
        tris = box(a.lo, a.hi, a.open_top)
    elif a.shape == "tilted":
        tris = tilted_box(a.lo, a.hi, a.angle, a.axis, a.pivot, a.open_top)
    else:
        tris = cylinder(a.center, a.axis, a.radius, a.length, a.segments, not a.open_ends)
    name = a.name or a.shape
    if a.output == "-":
        write_stl(sys.stdout, tris, name)
    else:
        write_stl(a.output, tris, name)
    return 0


if __name__ == "__main__":
    sys.exit(main())
