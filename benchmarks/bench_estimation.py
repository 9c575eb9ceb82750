"""Benchmark: estimation on realistic IMUs (issue 20).

Run: python benchmarks/bench_estimation.py [--logs N] [--first SEED] [--duration S]
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
* the self-calibrating filter (``EstimatorParams.self_calibrating``: bias,
  accelerometer-misalignment, gyro-scale and IMU-distance states, Heun's
  second-order step, those states held for the first 2 s) tuned to the
  IMUs' own noise (``with_sensor_noise``: R from Table 5.1, Q 0.05 m/s^2
  on the accelerometer inputs), and its RTS smoother;
and each one's ratio to the floor.  Angle errors are wrapped to (-pi, pi].

Two truths.  The ratios to the floor are against the encoders, as the
issue asks: they lead the IMU samples by 0-20 ms, which costs every
estimator (the floor included) about offset x rate, several mrad on most
logs.  The estimators' own error is against the true state at the IMU
sample times ("estimation error"); the smoother-below-filter check is
made on both, and only the second is the smoother's doing (against the
encoders the offset term swamps the 0.2-0.5 mrad the smoother gains).

Seeds: logs 0-17 were used while building the self-calibrating filter
(logs 0-5 first; logs 6-17 then showed the wrong convergence from a 1 rad
start that the 2 s hold fixes, and the missing angle wrap) and to choose
Heun's step and the 0.05 m/s^2 process noise.  Logs 100 and up are held
out: ``--first 100 --logs 24`` and ``--first 200 --logs 24`` are what the
README reports (log 117 was looked at to find the trapezoid step's bias;
200-223 were first run after the tuning was fixed).
"""
import argparse
import dataclasses as dc
import math

import numpy as np

from bplir_drake.analysis.estimation.filter_study import (
    angle_rmse, encoder_truth, realistic_imu_log)
from bplir_drake.estimation import aligned_truth, encoder_lead, estimate, gyro_integral
from bplir_drake.params import preset


#: the logs' gyro-bias random walk (rad/s/sqrt(s))
DRIFT = 0.002


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logs", type=int, default=6)
    ap.add_argument("--first", type=int, default=0,
                    help="seed of the first log (logs 0-17 were used while building and "
                         "tuning the self-calibrating filter; 100 and up are held out)")
    ap.add_argument("--duration", type=float, default=25.0)
    args = ap.parse_args()
    p = preset()
    # the gyros' bias random walk as its datasheet would give it (the logs'
    # 0.002 rad/s/sqrt(s)); the default filter assumes 0.001
    calibrating = dc.replace(p.estimator.chapter5().self_calibrating().with_sensor_noise(p.imu),
                             bias_walk=DRIFT)
    methods = {"chapter-5 filter": dc.replace(p.estimator.chapter5(), estimate_bias=False),
               "project filter": p.estimator.chapter5(), "self-calibrating filter": calibrating}
    rows = []
    for seed in range(args.first, args.first + args.logs):
        run, err = realistic_imu_log(p, seed, args.duration, drift=DRIFT)
        t = run.t
        encoders = encoder_truth(run, err)   # the encoders lead the IMU samples
        lead = encoder_lead(t, encoders, run.imu)   # estimated from the log
        truths = {"encoders": encoders, "aligned": aligned_truth(t, encoders, lead),
                  "true state": run.truth[:, :2]}
        x_true0 = run.truth[0]
        bias = np.array([err["gyro_bias1"], err["gyro_bias2"], 0, 0, 0, 0])
        angles = {"floor": gyro_integral(t, run.imu - bias, x_true0)}
        x0 = x_true0 + np.r_[err["start_error_rad"], 0.0, 0.0]
        row = {"log": seed, "lead error": lead - err["time_offset_s"]}
        for name, est in methods.items():
            r = estimate(t, run.imu, est, x0, smooth=(name != "chapter-5 filter"))
            angles[name] = r.x[:, :2]
            if r.smoothed is not None:
                angles[name.replace("filter", "smoother")] = r.smoothed[:, :2]
            if r.misalignment is not None:
                row["misalignment error"] = r.smoothed_misalignment[-1] - np.array(
                    [err["misalign1"], err["misalign2"]])
                row["scale error"] = r.smoothed_gyro_scale[-1] - np.array(
                    [err["gyro_scale1"], err["gyro_scale2"]])
                row["position error"] = r.smoothed_imu_position[-1] - np.array(
                    [err["r1"], err["r2"]])
        for what, truth in truths.items():
            row[what] = {n: angle_rmse(t, theta, truth) for n, theta in angles.items()}
        rows.append(row)
        print(f"log {seed}: start error {np.round(err['start_error_rad'], 2)} rad, "
              f"biases {err['gyro_bias1']:+.3f}/{err['gyro_bias2']:+.3f} rad/s, scale "
              f"{err['gyro_scale1']:+.3f}/{err['gyro_scale2']:+.3f}, misalignment "
              f"{math.degrees(err['misalign1']):+.1f}/{math.degrees(err['misalign2']):+.1f} deg, "
              f"offset {1e3 * err['time_offset_s']:.1f} ms (estimated "
              f"{1e3 * lead:.1f} ms)")
    names = ["floor", "chapter-5 filter", "project filter", "project smoother",
             "self-calibrating filter", "self-calibrating smoother"]
    print("\nangle RMSE after 5 s against the encoders (rad), theta1 / theta2, and the ratio "
          "to the floor")
    print("| log | " + " | ".join(names) + " |")
    print("|" + " --- |" * (len(names) + 1))
    for row in rows:
        e = row["encoders"]
        cells = [f"{e['floor'][0]:.4f} / {e['floor'][1]:.4f}"]
        for n in names[1:]:
            v, q = e[n], e[n] / e["floor"]
            cells.append(f"{v[0]:.4f} / {v[1]:.4f} ({q[0]:.2f}x / {q[1]:.2f}x)")
        print(f"| {row['log']} | " + " | ".join(cells) + " |")
    print("\nself-calibrating estimation error (against the true state at the IMU sample "
          "times), mrad, theta1 / theta2: filter -> smoother")
    for row in rows:
        f, sm = (1e3 * row["true state"][f"self-calibrating {k}"] for k in ("filter", "smoother"))
        print(f"log {row['log']}: {f[0]:.2f} / {f[1]:.2f} -> {sm[0]:.2f} / {sm[1]:.2f}")
    print("\nencoder lead estimated from the logs, error (ms): max "
          f"{1e3 * max(abs(r['lead error']) for r in rows):.2f}")
    for what, label in (("encoders", "against the encoders"),
                        ("aligned", "against the encoders moved onto the IMU clock by the "
                                    "estimated lead"),
                        ("true state", "against the true state")):
        worst = {n: np.max([row[what][n] / row[what]["floor"] for row in rows], axis=0)
                 for n in names[1:]}
        print(f"\n{label}: worst ratio to the floor over the logs (theta1 / theta2): "
              + "; ".join(f"{n} {w[0]:.2f}x / {w[1]:.2f}x" for n, w in worst.items()))
        for kind in ("project", "self-calibrating"):
            below = sum(int(np.sum(row[what][f"{kind} smoother"] < row[what][f"{kind} filter"]))
                        for row in rows)
            print(f"  {kind} smoother below its filter: {below} of {2 * len(rows)} log-angles")
    print("self-calibration, smoothed estimate at the end minus the truth: misalignment (deg) "
          + "; ".join(f"log {r['log']} {np.round(np.degrees(r['misalignment error']), 2)}"
                      for r in rows))
    print("gyro scale error (%) "
          + "; ".join(f"log {r['log']} {np.round(100 * r['scale error'], 2)}" for r in rows))
    print("IMU distance error (mm) "
          + "; ".join(f"log {r['log']} {np.round(1e3 * r['position error'], 1)}" for r in rows))


if __name__ == "__main__":
    main()
