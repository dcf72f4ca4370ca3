"""benchlib.py - what the Python drivers of bench/ share: the --build/--out command line and the test programs
of a build that they run."""
import argparse
import os
import sys


def parser(doc):
    """an ArgumentParser described by the first line of doc, with --build (default build) and --out (bench/out)"""
    ap = argparse.ArgumentParser(description=doc.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default=os.path.join("bench", "out"))
    return ap


def test_exe(build, name):
    """the absolute path of BUILD/tests/NAME; exits with a message where it is not built"""
    exe = os.path.abspath(os.path.join(build, "tests", name))
    if not os.path.exists(exe):
        sys.exit("no %s: build the project first (cmake --build %s)" % (exe, build))
    return exe
