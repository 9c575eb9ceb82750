"""Benchmark: memory of ``bplir estimate`` on a long IMU log.

A log of ROWS rows (default 3.3 million: 9 h at 100 Hz, about 200 MB of
text) is written, then estimated by the ``bplir`` command in a process of
its own; its peak resident memory is printed beside the file's size and
the arrays the estimate keeps (the ratios are measured in this one run).

Run: python benchmarks/bench_long_log.py [ROWS] [--keep DIR]   (not a test)
"""
import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bplir_drake.systems.imu import IMU_COLUMNS


def write_log(path: Path, rows: int, seed: int = 0) -> None:
    """A still robot's readings with noise, written a block at a time."""
    rng = np.random.default_rng(seed)
    with open(path, "w") as f:
        f.write(",".join(("t",) + IMU_COLUMNS) + "\n")
        for a in range(0, rows, 100_000):
            n = min(100_000, rows - a)
            block = np.zeros((n, 7))
            block[:, 0] = (a + np.arange(n)) * 0.01
            block[:, 4] = block[:, 6] = 9.81
            block[:, 1:] += rng.normal(0.0, 0.01, (n, 6))
            np.savetxt(f, block, delimiter=",", fmt=["%.10g"] + ["%.6g"] * 6)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("rows", nargs="?", type=int, default=3_300_000)
    ap.add_argument("--keep", help="directory for the log and the estimate (default: temporary)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        where = Path(args.keep or tmp)
        where.mkdir(parents=True, exist_ok=True)
        log = where / "long_imu.csv"
        write_log(log, args.rows)
        size = log.stat().st_size
        t0 = time.perf_counter()
        p = subprocess.run([sys.executable, "-m", "bplir_drake.cli", "estimate", str(log),
                            "--out", str(where / "long_estimate.csv"), "--json"],
                           capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if p.returncode != 0:
            sys.exit(f"bplir estimate failed: {p.stderr.strip()}")
        peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024   # kB on Linux
        kept = args.rows * 8 * (1 + 6 + 4 + 6 + 2 + 2 + 1)   # t, samples, x, P diag, bias, ...
        print(f"log: {args.rows} rows, {size / 1e6:.0f} MB of text")
        print(f"bplir estimate: peak resident {peak / 2 ** 20:.0f} MiB "
              f"({peak / size:.2f}x the file, {peak / kept:.2f}x the arrays kept), "
              f"{wall:.0f} s ({args.rows / wall / 1e3:.0f} k rows/s)")
        print(f"limit of the hardening issue: 1024 MiB -> {'met' if peak <= 2 ** 30 else 'NOT met'}")
        if os.environ.get("BENCH_VERBOSE"):
            print(p.stdout)


if __name__ == "__main__":
    main()
