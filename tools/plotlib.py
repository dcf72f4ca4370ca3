"""plotlib.py - what the plot scripts of examples/ and tests/verification/ share: matplotlib without a display,
the command line "[input.csv] [out.png]", labelled axes and the saved figure."""
import sys


def pyplot():
    """matplotlib.pyplot on the Agg backend (no display needed)"""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def src_out(default_src, default_out, argv=None):
    """(input, output) from argv[1] and argv[2], else the defaults"""
    argv = sys.argv if argv is None else argv
    return (argv[1] if len(argv) > 1 else default_src, argv[2] if len(argv) > 2 else default_out)


def csv_plot(default_src, default_out, argv=None):
    """pyplot, the rows of the input CSV (dicts by column name) and the output name; arguments [input.csv] [out.png]"""
    import csv
    src, out = src_out(default_src, default_out, argv)
    with open(src) as f:
        rows = list(csv.DictReader(f))
    return pyplot(), rows, out


def axes(ax, xlabel, ylabel, title=None, fontsize=8, **legend):
    """labels, title, legend (fontsize, further legend arguments) and a light grid"""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    ax.legend(fontsize=fontsize, **legend)
    ax.grid(alpha=0.3)


def save(fig, out, dpi=120):
    """tight layout, write out, say so"""
    fig.tight_layout()
    fig.savefig(out, dpi=dpi)
    print("wrote", out)
