#!/usr/bin/env python3
"""dump2vtk.py - convert LAMMPS / LIGGGHTS 'dump custom' text files to VTK for ParaView.

Every snapshot becomes one PolyData file of vertices (one per atom) with every dump column
as point data; vx vy vz are also written as the vector "velocity" (fx fy fz as "force",
omegax omegay omegaz as "omega"). Columns x y z (or xu yu zu, or xs ys zs) are required.

Written for each snapshot, in OUTDIR (default: beside the dump):
  PREFIX_NNNNNN.vtk   legacy VTK PolyData (binary unless --ascii)
  PREFIX_NNNNNN.vtp   VTK XML PolyData (only with --format vtp|both; default both)
and for the series:
  PREFIX.pvd          ParaView collection of the .vtp files with their times
  PREFIX.vtk.series   ParaView (>= 5.5) file-series of the .vtk files with their times
ParaView's .pvd reader accepts VTK XML files only, so the .pvd lists the .vtp files; open
PREFIX.pvd (or PREFIX.vtk.series) in ParaView to get the time series.

Times: the dump's 'ITEM: TIME' (LAMMPS: dump_modify ID time yes) when present, else
timestep * --dt, else the timestep number.

  python3 tools/dump2vtk.py 'dump.dambreak2d.*' --dt 3.867e-5 -o vtk/
  python3 tools/dump2vtk.py dump.all --rename 'f_water[1]=density' 'f_water[2]=pressure'

Standard library + numpy only.
"""
import argparse
import base64
import json
import os
import re
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from dumputil import read_all  # noqa: E402

VECTORS = (("velocity", ("vx", "vy", "vz")), ("force", ("fx", "fy", "fz")),
           ("omega", ("omegax", "omegay", "omegaz")))
INTEGER_COLUMNS = ("id", "type", "mol", "proc", "procp1")


def safe_name(name):
    """VTK array names: no whitespace; f_water[1] -> f_water_1."""
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", name).strip("_") or "column"


def arrays_of(snap, renames):
    """[(name, values, is_int)] scalars and [(name, n x 3 values)] vectors of one snapshot."""
    pos = snap.position_columns()
    scalars, vectors, used = [], [], set(pos)
    for vname, comps in VECTORS:
        if all(c in snap.columns for c in comps):
            vectors.append((vname, np.column_stack([snap.col(c) for c in comps])))
    for c in snap.columns:
        if c in used:
            continue
        vals = snap.col(c)
        is_int = c in INTEGER_COLUMNS and np.all(vals == np.round(vals))
        scalars.append((safe_name(renames.get(c, c)), vals, is_int))
    return scalars, vectors


def write_legacy(path, snap, xyz, scalars, vectors, binary):
    n = len(xyz)

    def block(values, dtype):
        if binary:
            return np.ascontiguousarray(values, dtype=dtype).tobytes() + b"\n"
        fmt = "%d" if dtype.endswith("i4") else "%.9g"
        flat = np.asarray(values).reshape(len(values), -1)
        return ("\n".join(" ".join(fmt % v for v in row) for row in flat) + "\n").encode()

    with open(path, "wb") as f:
        f.write(b"# vtk DataFile Version 3.0\n")
        f.write(("%s step %d\n" % (os.path.basename(snap.path), snap.step)).encode()[:255])
        f.write(b"BINARY\n" if binary else b"ASCII\n")
        f.write(b"DATASET POLYDATA\n")
        f.write(b"POINTS %d double\n" % n)
        f.write(block(xyz, ">f8"))
        f.write(b"VERTICES %d %d\n" % (n, 2 * n))
        f.write(block(np.column_stack([np.ones(n, dtype=np.int64), np.arange(n)]), ">i4"))
        f.write(b"POINT_DATA %d\n" % n)
        for name, vals in vectors:
            f.write(b"VECTORS %s double\n" % name.encode())
            f.write(block(vals, ">f8"))
        for name, vals, is_int in scalars:
            f.write(b"SCALARS %s %s 1\nLOOKUP_TABLE default\n" % (name.encode(), b"int" if is_int else b"double"))
            f.write(block(vals, ">i4" if is_int else ">f8"))


def write_vtp(path, snap, xyz, scalars, vectors):
    """VTK XML PolyData, binary (base64 inline) data arrays."""
    n = len(xyz)

    def darray(name, values, vtype, ncomp, dtype):
        raw = np.ascontiguousarray(values, dtype=dtype).tobytes()
        enc = base64.b64encode(np.uint32(len(raw)).tobytes() + raw).decode()
        nm = ' Name="%s"' % name if name else ""
        return ('<DataArray type="%s"%s NumberOfComponents="%d" format="binary">%s</DataArray>\n'
                % (vtype, nm, ncomp, enc))

    with open(path, "w") as f:
        f.write('<?xml version="1.0"?>\n')
        f.write('<VTKFile type="PolyData" version="0.1" byte_order="LittleEndian" header_type="UInt32">\n')
        f.write('<PolyData>\n<Piece NumberOfPoints="%d" NumberOfVerts="%d" NumberOfLines="0" '
                'NumberOfStrips="0" NumberOfPolys="0">\n' % (n, n))
        f.write("<Points>\n" + darray("", xyz, "Float64", 3, "<f8") + "</Points>\n")
        f.write("<Verts>\n" + darray("connectivity", np.arange(n), "Int64", 1, "<i8")
                + darray("offsets", np.arange(1, n + 1), "Int64", 1, "<i8") + "</Verts>\n")
        vec = ' Vectors="velocity"' if any(v[0] == "velocity" for v in vectors) else ""
        f.write("<PointData%s>\n" % vec)
        for name, vals in vectors:
            f.write(darray(name, vals, "Float64", 3, "<f8"))
        for name, vals, is_int in scalars:
            f.write(darray(name, vals, "Int32" if is_int else "Float64", 1, "<i4" if is_int else "<f8"))
        f.write("</PointData>\n</Piece>\n</PolyData>\n</VTKFile>\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("dumps", nargs="+", help="dump files or quoted glob patterns ('dump.*')")
    ap.add_argument("-o", "--outdir", help="output folder (default: the folder of the first dump)")
    ap.add_argument("-p", "--prefix", help="output name prefix (default: first dump name without its step)")
    ap.add_argument("--dt", type=float, help="timestep size: time = step * dt (when the dump has no TIME item)")
    ap.add_argument("--format", choices=("vtk", "vtp", "both"), default="both",
                    help="legacy .vtk, XML .vtp (+ .pvd), or both (default)")
    ap.add_argument("--ascii", action="store_true", help="legacy .vtk in ASCII instead of binary")
    ap.add_argument("--rename", nargs="*", default=[], metavar="COL=NAME",
                    help="rename columns, e.g. 'f_water[1]=density' 'f_water[2]=pressure'")
    args = ap.parse_args()

    renames = {}
    for r in args.rename:
        if "=" not in r:
            ap.error("--rename expects COL=NAME, got '%s'" % r)
        k, v = r.split("=", 1)
        renames[k] = v

    first = args.dumps[0]
    outdir = args.outdir or os.path.dirname(os.path.abspath(first))
    os.makedirs(outdir, exist_ok=True)
    prefix = args.prefix or re.sub(r"[.*_]*$", "", re.sub(r"[*\d]+$", "", os.path.basename(first))) or "dump"

    entries = []
    for snap in read_all(args.dumps):
        xyz = snap.positions()
        scalars, vectors = arrays_of(snap, renames)
        t = snap.time if snap.time is not None else (snap.step * args.dt if args.dt else float(snap.step))
        base = "%s_%06d" % (prefix, snap.step)
        if args.format in ("vtk", "both"):
            write_legacy(os.path.join(outdir, base + ".vtk"), snap, xyz, scalars, vectors, not args.ascii)
        if args.format in ("vtp", "both"):
            write_vtp(os.path.join(outdir, base + ".vtp"), snap, xyz, scalars, vectors)
        entries.append((t, base))
        print("step %d  t %g  %d atoms  -> %s.%s" % (snap.step, t, len(xyz), base,
                                                   "{vtk,vtp}" if args.format == "both" else args.format))
    if not entries:
        sys.exit("no snapshots found")
    entries.sort()
    if args.format in ("vtp", "both"):
        with open(os.path.join(outdir, prefix + ".pvd"), "w") as f:
            f.write('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n<Collection>\n')
            for t, base in entries:
                f.write('  <DataSet timestep="%.10g" group="" part="0" file="%s.vtp"/>\n' % (t, base))
            f.write("</Collection>\n</VTKFile>\n")
        print("wrote %s (%d snapshots): open it in ParaView" % (os.path.join(outdir, prefix + ".pvd"), len(entries)))
    if args.format in ("vtk", "both"):
        series = {"file-series-version": "1.0",
                  "files": [{"name": base + ".vtk", "time": t} for t, base in entries]}
        with open(os.path.join(outdir, prefix + ".vtk.series"), "w") as f:
            json.dump(series, f, indent=1)
        print("wrote %s" % os.path.join(outdir, prefix + ".vtk.series"))


if __name__ == "__main__":
    main()
