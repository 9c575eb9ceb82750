"""Benchmark: throughput of a Monte Carlo study of the default swing with 1
and 2 workers, in one run.

Run: python benchmarks/bench_montecarlo.py [SAMPLES]   (default 200; prints
figures, not a test).  Goal (issue 14): 1000 default swings in <= 60 s on 2
workers, near-linear scaling from 1 to 2 workers.
"""
import os
import shutil
import sys
import tempfile
import time

from bplir_drake.analysis import montecarlo as mc


def study_wall(samples: int, workers: int) -> tuple[float, dict]:
    """(wall s, outcome counts) of a fresh default study of ``samples``."""
    out = tempfile.mkdtemp(prefix="bplir-bench-")
    try:
        t0 = time.perf_counter()
        summary = mc.run_study(mc.Study(samples=samples, seed=0), out, workers=workers)
        return time.perf_counter() - t0, summary["outcomes"]
    finally:
        shutil.rmtree(out, ignore_errors=True)


def main():
    samples = int(sys.argv[1]) if len(sys.argv) > 1 else 200
    walls = {}
    for w in (1, 2):
        walls[w], outcomes = study_wall(samples, w)
        print(f"{samples}-sample study, {w} worker(s): {walls[w]:.1f} s wall, "
              f"{samples / walls[w]:.2f} swings/s ({outcomes})")
    print(f"speed-up 1 -> 2 workers: {walls[1] / walls[2]:.2f}x on {os.cpu_count()} cores")
    print(f"1000 swings on 2 workers (extrapolated): {1000 * walls[2] / samples:.0f} s; "
          "goal <= 60 s")


if __name__ == "__main__":
    main()
