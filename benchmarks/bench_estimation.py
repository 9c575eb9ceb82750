"""Benchmark: estimation on realistic IMUs (issue 20).

Run: python benchmarks/bench_estimation.py [--logs N] [--duration S]
(prints a table; not a test)

Each log is a free swing of the simulated robot (25 s: an elbow torque
step, then a knock on link 1, as in chapter 5's tests) whose IMUs carry
what real ones do, drawn per log from its seed: gyro biases within
+/-0.03 rad/s plus a random walk (0.002 rad/s/sqrt(s)), gyro scale errors
within +/-2 %, accelerometer misalignments within +/-3 deg, IMU positions
off by up to +/-2 cm from the filter's geometry, and a time offset of 0-20
ms between the IMU samples and the joint encoders used as truth.  The
estimators start up to 1 rad off in each angle (the floor starts exactly).

Angle RMSE after 5 s, per log and link, for
* the floor: the gyro integral (5.41) from the true start with the true
  constant bias removed;
* the chapter-5 filter (the dissertation's tuning, no bias states);
* the project's filter (bias states, the same tuning) and its RTS smoother;
and each one's ratio to the floor.
"""
import argparse
import dataclasses as dc
import math

import numpy as np

from bplir_drake.analysis.estimation.study import simulate_estimation
from bplir_drake.estimation import estimate, gyro_integral
from bplir_drake.params import preset


def draw_log(p, seed: int, duration: float):
    """(simulated run, drawn errors) of log ``seed``."""
    rng = np.random.default_rng([seed, 20])
    errors = {"gyro_bias1": rng.uniform(-0.03, 0.03), "gyro_bias2": rng.uniform(-0.03, 0.03),
              "gyro_drift": 0.002,
              "gyro_scale1": rng.uniform(-0.02, 0.02), "gyro_scale2": rng.uniform(-0.02, 0.02),
              "misalign1": math.radians(rng.uniform(-3, 3)),
              "misalign2": math.radians(rng.uniform(-3, 3)),
              "r1": p.imu.r1 + rng.uniform(-0.02, 0.02), "r2": p.imu.r2 + rng.uniform(-0.02, 0.02)}
    offset = rng.uniform(0.0, 0.020)
    start_error = np.r_[rng.uniform(-1.0, 1.0, 2), 0.0, 0.0]
    real = p.with_(imu=dc.replace(p.imu, **errors))   # the filter keeps p.estimator's geometry
    run = simulate_estimation(real, duration=duration, seed=seed)
    return run, errors | {"time_offset_s": offset, "start_error_rad": start_error[:2].tolist()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logs", type=int, default=6)
    ap.add_argument("--duration", type=float, default=25.0)
    args = ap.parse_args()
    p = preset()
    methods = {"chapter-5 filter": dc.replace(p.estimator, estimate_bias=False),
               "project filter": p.estimator}
    rows = []
    for seed in range(args.logs):
        run, err = draw_log(p, seed, args.duration)
        t = run.t
        # the encoders lead the IMU samples by the offset: truth at t + offset
        truth = np.column_stack([np.interp(t + err["time_offset_s"], t, run.truth[:, i])
                                 for i in range(2)])
        late = t >= t[0] + 5.0

        def rmse(theta):
            return np.sqrt(np.mean((theta[late] - truth[late]) ** 2, axis=0))

        x_true0 = run.truth[0]
        bias = np.array([err["gyro_bias1"], err["gyro_bias2"], 0, 0, 0, 0])
        floor = rmse(gyro_integral(t, run.imu - bias, x_true0))
        row = {"log": seed, "floor": floor}
        x0 = x_true0 + np.r_[err["start_error_rad"], 0.0, 0.0]
        for name, est in methods.items():
            r = estimate(t, run.imu, est, x0, smooth=(name == "project filter"))
            row[name] = rmse(r.x[:, :2])
            if r.smoothed is not None:
                row["project smoother"] = rmse(r.smoothed[:, :2])
        rows.append(row)
        print(f"log {seed}: start error {np.round(err['start_error_rad'], 2)} rad, "
              f"biases {err['gyro_bias1']:+.3f}/{err['gyro_bias2']:+.3f} rad/s, scale "
              f"{err['gyro_scale1']:+.3f}/{err['gyro_scale2']:+.3f}, misalignment "
              f"{math.degrees(err['misalign1']):+.1f}/{math.degrees(err['misalign2']):+.1f} deg, "
              f"offset {1e3 * err['time_offset_s']:.0f} ms")
    names = ["floor", "chapter-5 filter", "project filter", "project smoother"]
    print("\nangle RMSE after 5 s (rad), theta1 / theta2, and the ratio to the floor")
    print("| log | " + " | ".join(names) + " |")
    print("|" + " --- |" * (len(names) + 1))
    for row in rows:
        cells = [f"{row['floor'][0]:.4f} / {row['floor'][1]:.4f}"]
        for n in names[1:]:
            v, q = row[n], row[n] / row["floor"]
            cells.append(f"{v[0]:.4f} / {v[1]:.4f} ({q[0]:.2f}x / {q[1]:.2f}x)")
        print(f"| {row['log']} | " + " | ".join(cells) + " |")
    worst = {n: np.max([row[n] / row["floor"] for row in rows], axis=0) for n in names[1:]}
    print("\nworst ratio to the floor over the logs (theta1 / theta2): "
          + "; ".join(f"{n} {w[0]:.2f}x / {w[1]:.2f}x" for n, w in worst.items()))
    better = all(np.all(row["project smoother"] < row["project filter"]) for row in rows)
    print(f"smoother below the filter on every log and angle: {better}")


if __name__ == "__main__":
    main()
