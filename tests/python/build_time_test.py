#!/usr/bin/env python3
"""bench/build_time.py against schedules worked out by hand on a five-step build.

  a.o (4 s) ─┐
  b.o (2 s) ─┴─ lib.a (1 s) ─┐
  c.o (6 s) ────────────────┴─ app (3 s)      and `extra` (5 s), which the default target does not need.

On 2 workers in ninja's order (a, b, c): a [0, 4], b [0, 2], c [2, 8], lib [4, 5], app [8, 11]: 11 s.
Longest path first: c [0, 6], a [0, 4], b [4, 6], lib [6, 7], app [7, 10]: 10 s. With --cpu and --scale 2 every
duration doubles."""
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "..", "bench", "build_time.py")

MANIFEST = """ninja_required_version = 1.5
include rules.ninja
build a.o: CXX a.cc
build b.o: CXX b.cc
build c$ dir/c.o: CXX c.cc
build lib.a: AR a.o b.o || phony_order
build phony_order: phony
build app: LINK c$ dir/c.o lib.a
  FLAGS = -O2 $
      -g1
build extra: CXX x.cc
build all: phony app
default all
"""
# start, end (ms), mtime, output, hash; c starts after b as ninja would have started it
LOG = [(0, 4000, "a.o"), (0, 2000, "b.o"), (2000, 8000, "c dir/c.o"), (4000, 5000, "lib.a"), (8000, 11000, "app")]


def run(*args):
    return subprocess.run([sys.executable, SCRIPT, *args], check=True, capture_output=True, text=True).stdout


def line(out, start):
    return next(l for l in out.splitlines() if l.startswith(start))


def main():
    with tempfile.TemporaryDirectory() as d:
        open(os.path.join(d, "build.ninja"), "w").write(MANIFEST)
        with open(os.path.join(d, ".ninja_log"), "w") as f:
            f.write("# ninja log v5\n")
            for s, e, o in LOG:
                f.write(f"{s}\t{e}\t0\t{o}\tdeadbeef\n")
        out = run("estimate", d)
        assert "(11 s)" in line(out, "estimate, 2 workers, ninja's start order"), out
        assert "(10 s)" in line(out, "estimate, 2 workers, longest path first"), out
        assert "longest path = 0 min 09.0 s" in out, out  # c, app
        assert "sum/2 = 0 min 08.0 s" in out, out
        with open(os.path.join(d, "cpu.tsv"), "w") as f:
            for s, e, o in LOG:
                f.write(f"{(e - s) / 1000:.2f}\t{o}\n")
        out = run("estimate", d, "--cpu", os.path.join(d, "cpu.tsv"), "--scale", "2")
        assert "(22 s)" in line(out, "estimate, 2 workers, ninja's start order"), out
        out = run("estimate", d, "--workers", "1")
        assert "(16 s)" in line(out, "estimate, 1 workers, ninja's start order"), out
        out = run("calibrate", d, "--cpu", os.path.join(d, "cpu.tsv"), "--min-seconds", "1")
        assert "median 1.000" in out, out
    print("build_time: schedules as worked out by hand")


if __name__ == "__main__":
    main()
