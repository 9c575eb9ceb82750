"""Benchmark: cost of one EKF update and of estimating a 26 s log at 100 Hz.

Run: python benchmarks/bench_ekf.py   (prints figures; not a test)
"""
import time

import numpy as np

from bplir_drake.analysis.estimation.filter_study import simulate_estimation
from bplir_drake.estimation import estimate
from bplir_drake.params import preset
from bplir_drake.systems.ekf import ekf_step, initial_state


def main():
    p = preset()
    est = p.estimator.chapter5()
    # a 26 s log (the length of the dissertation's combined test)
    run = simulate_estimation(p, duration=26.0, seed=0)
    t, imu = run.t, run.imu
    s = initial_state(est, run.x0_estimate)
    u = imu[0, [2, 4]]
    n = 2000
    t0 = time.perf_counter()
    for k in range(n):
        s, u = ekf_step(s, u, imu[k % len(imu)], est)
    per_update = (time.perf_counter() - t0) / n
    t0 = time.perf_counter()
    res = estimate(t, imu, est, run.x0_estimate)
    whole = time.perf_counter() - t0
    print(f"EKF update (6 states, closed-form Jacobians): {per_update * 1e6:.0f} us")
    print(f"estimating a {t[-1] - t[0]:.1f} s log at 100 Hz ({len(t)} samples): {whole:.3f} s "
          f"({(t[-1] - t[0]) / whole:.0f}x real time)")
    print(f"angle RMSE on that log: {np.sqrt(np.mean((res.x[:, :2] - run.truth[:, :2]) ** 2, axis=0))}")


if __name__ == "__main__":
    main()
