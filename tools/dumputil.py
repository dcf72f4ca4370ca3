"""dumputil.py - read LAMMPS / LIGGGHTS 'dump custom' text files (shared by dump2vtk.py and
render_snapshot.py). Standard library + numpy only."""
import glob
import os
import re

import numpy as np


class Snapshot:
    """One dump snapshot: step, box (3x2 array of lo/hi), column names, data (natoms x ncol)."""

    def __init__(self, step, box, columns, data, path, time=None):
        self.step, self.box, self.columns, self.data, self.path, self.time = step, box, columns, data, path, time

    def has(self, name):
        return name in self.columns

    def col(self, name):
        return self.data[:, self.columns.index(name)]

    def position_columns(self):
        """Names of the position columns: x y z, else unwrapped xu yu zu, else scaled xs ys zs."""
        for names in (("x", "y", "z"), ("xu", "yu", "zu")):
            if all(n in self.columns for n in names):
                return names
        if all(n in self.columns for n in ("xs", "ys", "zs")):
            return ("xs", "ys", "zs")
        raise ValueError("%s (step %d): the dump has no x y z columns (columns: %s)"
                         % (self.path, self.step, " ".join(self.columns)))

    def positions(self):
        names = self.position_columns()
        xyz = np.column_stack([self.col(n) for n in names])
        if names[0] == "xs":  # scaled coordinates of an orthogonal box
            lo, hi = self.box[:, 0], self.box[:, 1]
            xyz = lo + xyz * (hi - lo)
        return xyz


def natural_key(path):
    """Sort dump.10 after dump.9."""
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", path)]


def expand(patterns):
    """File names and glob patterns -> existing files in natural order."""
    files = []
    for p in patterns:
        hits = glob.glob(p) if any(c in p for c in "*?[") else [p]
        files.extend(sorted(hits, key=natural_key))
    missing = [f for f in files if not os.path.exists(f)]
    if missing:
        raise FileNotFoundError("no such dump file: %s" % ", ".join(missing))
    if not files:
        raise FileNotFoundError("no dump files match %s" % " ".join(patterns))
    return files


def read_dump(path):
    """Yield every snapshot of one dump file (a file may hold several)."""
    with open(path) as f:
        lines = iter(f)
        step = time = None
        natoms = 0
        box = np.zeros((3, 2))
        for line in lines:
            if not line.startswith("ITEM:"):
                continue
            item = line[5:].strip()
            if item.startswith("TIMESTEP"):
                step = int(next(lines).split()[0])
            elif item.startswith("TIME"):
                time = float(next(lines).split()[0])
            elif item.startswith("NUMBER OF ATOMS"):
                natoms = int(next(lines).split()[0])
            elif item.startswith("BOX BOUNDS"):
                for d in range(3):
                    w = next(lines).split()
                    box[d] = float(w[0]), float(w[1])  # triclinic tilt factors (3rd value) ignored
            elif item.startswith("ATOMS"):
                columns = item.split()[1:]
                rows = [next(lines) for _ in range(natoms)]
                data = np.loadtxt(rows, ndmin=2) if natoms else np.zeros((0, len(columns)))
                if data.shape[1] != len(columns):
                    raise ValueError("%s step %s: %d values per line for %d column names"
                                     % (path, step, data.shape[1], len(columns)))
                yield Snapshot(step, box.copy(), columns, data, path, time)
                time = None


def read_all(patterns):
    for path in expand(patterns):
        for snap in read_dump(path):
            yield snap
