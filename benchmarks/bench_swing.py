"""Benchmark: wall time of one full closed-loop swing, and its parts.

Run: python benchmarks/bench_swing.py   (prints figures; not a test)
"""
import time

from bplir_drake.analysis.swing import run_swing
from bplir_drake.diagrams import build_swing
from bplir_drake.params import preset


def main():
    p = preset()
    t0 = time.perf_counter()
    b = build_swing(p)
    t_build = time.perf_counter() - t0
    runs = []
    for seed in range(5):
        t0 = time.perf_counter()
        r = run_swing(p, seed=seed)
        runs.append((time.perf_counter() - t0, r.summary["swing_time_s"], r.summary["outcome"]))
    wall = sum(w for w, _, _ in runs) / len(runs)
    sim = sum(s for _, s, _ in runs) / len(runs)
    print(f"build the swing diagram: {t_build * 1e3:.0f} ms ({len(b.diagram.GetSystems())} systems)")
    print(f"one swing (EKF in the loop, {sim:.2f} s simulated until the interlock decides): "
          f"{wall:.2f} s wall = {sim / wall:.2f} simulated s per wall s")
    print("outcomes:", [o for _, _, o in runs])
    print("goal (issue 6): 30 simulated s per wall s -- not met; the Python systems "
          "(path predictor at 100 Hz, EKF, IMU sampler, interlock at 500 Hz) dominate")


if __name__ == "__main__":
    main()
