"""Benchmark: one full closed-loop swing over 3 simulated seconds, and the
throughput of a Monte Carlo study with 1 and 2 workers.

Run: python benchmarks/bench_montecarlo.py [SAMPLES]   (default 200; prints
figures, not a test).  Goal (issue 6): >= 30 simulated s per wall s for one
swing and near-linear scaling with workers.
"""
import os
import shutil
import sys
import tempfile
import time

from bplir_drake.analysis import montecarlo as mc
from bplir_drake.diagrams import build_swing
from bplir_drake.params import preset
from bplir_drake.simulate import make_simulator, run


def one_swing_3s() -> tuple[float, float]:
    """(build s, simulate s) of the full loop advanced 3 s without stopping at
    the capture (the interlock decides, the simulation goes on)."""
    p = preset()
    build_swing(p)  # warm up imports and templates
    t0 = time.perf_counter()
    built = build_swing(p, seed=1)
    sim = make_simulator(built, built.q0, accuracy=1e-5)
    t1 = time.perf_counter()
    run(sim, 3.0)
    return t1 - t0, time.perf_counter() - t1


def study_throughput(samples: int, workers: int) -> float:
    out = tempfile.mkdtemp(prefix="bplir-bench-")
    try:
        t0 = time.perf_counter()
        mc.run_study(mc.Study(samples=samples, seed=0), out, workers=workers)
        return time.perf_counter() - t0
    finally:
        shutil.rmtree(out, ignore_errors=True)


def main():
    samples = int(sys.argv[1]) if len(sys.argv) > 1 else 200
    build, wall = one_swing_3s()
    print(f"one closed-loop swing, 3.0 s simulated: {wall:.2f} s wall "
          f"({3.0 / wall:.2f} simulated s per wall s; build {build * 1e3:.0f} ms); goal 30")
    times = {}
    for w in (1, 2):
        times[w] = study_throughput(samples, w)
        print(f"{samples}-sample study, {w} worker(s): {times[w]:.1f} s wall, "
              f"{samples / times[w]:.2f} swings/s")
    print(f"speed-up 1 -> 2 workers: {times[1] / times[2]:.2f}x on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
