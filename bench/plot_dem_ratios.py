#!/usr/bin/env python3
"""plot_dem_ratios.py - the loop time of the GPU DEM pair styles (CPU backend) over the stock styles' on the same
scene, engine and rank count, from the tables dem_bench.py prints (one or more of its outputs).

  /usr/bin/python3 bench/plot_dem_ratios.py OUT.png BENCH_OUTPUT.txt [BENCH_OUTPUT.txt ...]

A bar below 1 is /gpu faster than stock. The single runs of a shared machine scatter by about 0.1 (bench/RESULTS.md
gives interleaved A/B rounds, bench/dem_ab.sh, where a ratio is close to 1)."""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
import plotlib  # noqa: E402


def rows(path):
    """(scene, grains, engine, ranks, stock?) -> loop time, from the markdown rows of a dem_bench.py output"""
    out = {}
    for line in open(path):
        w = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(w) < 6 or not w[1].isdigit() or not (w[3].startswith("stock") or "/gpu" in w[3]):
            continue  # (the headers, and the rows of the ratio table)
        try:
            loop = float(w[5])
        except ValueError:
            continue
        ranks = 2 if "2 ranks" in w[3] else 1
        out[(w[0], int(w[1]), w[2], ranks, w[3].startswith("stock"))] = loop
    return out


def main(argv):
    if len(argv) < 3:
        print(__doc__)
        return 2
    data = {}
    for p in argv[2:]:
        data.update(rows(p))
    bars = []
    for (scene, grains, engine, ranks, stock), t in sorted(data.items()):
        if stock or (scene, grains, engine, ranks, True) not in data:
            continue
        bars.append(("%s %s, %d grains, %d rank%s" % (engine, scene, grains, ranks, "s" if ranks > 1 else ""),
                     t / data[(scene, grains, engine, ranks, True)]))
    if not bars:
        print("no pairs of stock and /gpu rows found")
        return 1
    plt = plotlib.pyplot()
    fig, ax = plt.subplots(figsize=(7, 0.32 * len(bars) + 1.2))
    y = range(len(bars))
    ax.barh(list(y), [b[1] for b in bars], color=["tab:green" if b[1] < 1.0 else "tab:red" for b in bars])
    ax.axvline(1.0, color="k", lw=0.8)
    ax.set_yticks(list(y))
    ax.set_yticklabels([b[0] for b in bars], fontsize=7)
    for k, b in enumerate(bars):
        ax.text(b[1] + 0.01, k, "%.2f" % b[1], va="center", fontsize=7)
    ax.set_xlabel("loop time, /gpu (CPU backend) / stock")
    ax.set_title("GPU DEM pair styles on the CPU against the stock styles", fontsize=9)
    ax.grid(alpha=0.3, axis="x")
    plotlib.save(fig, argv[1])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
