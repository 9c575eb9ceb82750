"""Estimation on simulated swings: EKF and gyro integral against the truth.

The scenario mirrors 5.5: a free response, an actuated phase (elbow torque)
and a knock on link 1, with the IMU model of Table 5.1.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...diagrams import build_sensor_swing
from ...estimation import gyro_integral
from ...params import BplirParams
from ...simulate import logs, make_simulator, run
from ...systems.plant import absolute_from_relative
from ...io import Result
import dataclasses as dc
import math
from ...estimation import plot_estimate

#: the default scenario of 5.5: free response, actuation, knock
DEFAULT_TORQUE = ((0.0, 3.0, 3.6), (0.0, 3.0, 0.0))
DEFAULT_KNOCK = (6.0, 0.1, 4.0)


@dataclass
class EstimationRun(Result):
    """The EKF on a simulated swing: filter ticks (s), the true and estimated absolute states, the
    gyro integral, the samples it used, covariance diagonal and gyro-bias estimates, its
    start estimate and seed."""
    t: np.ndarray          # filter ticks
    truth: np.ndarray      # (N, 4) absolute
    estimate: np.ndarray   # (N, 4) absolute
    gyro_integral: np.ndarray  # (N, 2)
    imu: np.ndarray        # (N, 6) samples the filter used
    cov_diag: np.ndarray
    gyro_bias: np.ndarray
    x0_estimate: np.ndarray
    seed: int

    @property
    def error(self) -> np.ndarray:
        """Estimate minus truth at each tick, (N, 4) rad and rad/s."""
        return self.estimate - self.truth

    def rmse(self, t_from: float = 0.0) -> np.ndarray:
        """Root-mean-square error of each state from ``t_from`` (s) on."""
        m = self.t >= t_from
        return np.sqrt(np.mean(self.error[m] ** 2, axis=0))

    def rmse_gyro_integral(self, t_from: float = 0.0) -> np.ndarray:
        """Root-mean-square angle error (rad) of the gyro integral (5.41) from ``t_from`` (s) on."""
        m = self.t >= t_from
        return np.sqrt(np.mean((self.gyro_integral[m] - self.truth[m, :2]) ** 2, axis=0))

    def convergence_time(self, tol: float = 0.05) -> float:
        """First time after which both angle errors stay below ``tol``."""
        bad = np.abs(self.error[:, :2]).max(axis=1) >= tol
        if not bad.any():
            return float(self.t[0])
        k = int(np.nonzero(bad)[0][-1])
        return float(self.t[k + 1]) if k + 1 < len(self.t) else float("inf")

    def plot(self, axes=None):
        """EKF and gyro-integral angles against the truth, and their errors (three axes)."""

        return plot_estimate(self.t, self.estimate, self.gyro_integral, axes, truth=self.truth)

    def summary(self) -> dict:
        """RMS errors, convergence time and seed as JSON-ready data."""
        r = self.rmse()
        return {"rmse_theta1_rad": float(r[0]), "rmse_theta2_rad": float(r[1]),
                "rmse_omega1_rad_s": float(r[2]), "rmse_omega2_rad_s": float(r[3]),
                "rmse_gyro_integral_rad": self.rmse_gyro_integral().tolist(),
                "convergence_time_s": self.convergence_time(),
                "max_angle_error_after_convergence_rad": float(
                    np.abs(self.error[self.t >= self.convergence_time(), :2]).max(initial=0.0)),
                "seed": self.seed}


def simulate_estimation(params: BplirParams, q0=(0.8, 0.4), duration: float = 10.0, *,
                        initial_error=(0.0, 0.0, 0.0, 0.0), elbow_torque=DEFAULT_TORQUE,
                        knock=DEFAULT_KNOCK, seed: int | None = None,
                        estimator=None) -> EstimationRun:
    """Simulate plant + IMUs + EKF from rest at ``q0`` (relative angles); the
    filter (``estimator``, by default ``params.estimator.chapter5()``) starts
    at the true absolute state plus ``initial_error``."""
    seed = params.scenario.seed if seed is None else seed
    x_true0 = absolute_from_relative(np.array([q0[0], q0[1], 0.0, 0.0]))
    x0_est = x_true0 + np.asarray(initial_error, dtype=float)
    built = build_sensor_swing(params, x0_est, elbow_torque=elbow_torque, knock=knock,
                               seed=seed, log_period=0.002, estimator=estimator)
    sim = make_simulator(built, q0)
    run(sim, duration)
    lg = logs(built, sim)
    est, imu = lg["estimate"], lg["imu"]
    st = lg["state"]
    truth_rel = st.at(est.t)
    truth = absolute_from_relative(truth_rel)
    n = min(len(est.t), len(imu.t))
    gyr = gyro_integral(imu.t[:n], imu.data[:n], x0_est)
    return EstimationRun(est.t[:n], truth[:n], est.data[:n], gyr, imu.data[:n],
                         lg["covariance"].data[:n], lg["bias"].data[:n], x0_est, seed)


def realistic_imu_log(params: BplirParams, seed: int, duration: float = 25.0, *,
                      drift: float = 0.002):
    """(simulated run, drawn errors) of a log whose IMUs carry what real ones
    do (``benchmarks/bench_estimation.py``), drawn from ``seed``:
    gyro biases within +/-0.03 rad/s plus a 0.002 rad/s/sqrt(s) random walk,
    gyro scale errors within +/-2 %, accelerometer misalignments within
    +/-3 deg, IMU positions off by up to +/-2 cm from the filter's geometry
    (``params.estimator``), a 0-20 ms lead of the encoders (the truth) over
    the IMU samples, and a start error of up to 1 rad per angle for the
    estimators.  The errors are returned with the run (``errors``).
    ``drift``: the bias random walk (0: constant biases, to check their
    recovery)."""

    p = params.imu
    rng = np.random.default_rng([seed, 20])
    errors = {"gyro_bias1": rng.uniform(-0.03, 0.03), "gyro_bias2": rng.uniform(-0.03, 0.03),
              "gyro_drift": float(drift),
              "gyro_scale1": rng.uniform(-0.02, 0.02), "gyro_scale2": rng.uniform(-0.02, 0.02),
              "misalign1": math.radians(rng.uniform(-3, 3)),
              "misalign2": math.radians(rng.uniform(-3, 3)),
              "r1": p.r1 + rng.uniform(-0.02, 0.02), "r2": p.r2 + rng.uniform(-0.02, 0.02)}
    offset = rng.uniform(0.0, 0.020)
    start_error = np.r_[rng.uniform(-1.0, 1.0, 2), 0.0, 0.0]
    real = params.with_(imu=dc.replace(p, **errors))   # the filter keeps params.estimator's geometry
    run_ = simulate_estimation(real, duration=duration, seed=seed)
    return run_, errors | {"time_offset_s": offset, "start_error_rad": start_error[:2].tolist()}


def encoder_truth(run_: EstimationRun, errors: dict) -> np.ndarray:
    """The absolute angles the encoders report at the IMU sample times of a
    :func:`realistic_imu_log` (they lead by ``time_offset_s``)."""
    t = run_.t
    return np.column_stack([np.interp(t + errors["time_offset_s"], t, run_.truth[:, i])
                            for i in range(2)])


def angle_rmse(t, theta, truth, after: float = 5.0) -> np.ndarray:
    """RMSE per angle after ``after`` s, of errors wrapped to (-pi, pi]
    (an estimate a full turn away is the same pose)."""
    late = np.asarray(t) >= t[0] + after
    e = np.remainder(np.asarray(theta)[late] - truth[late] + np.pi, 2 * np.pi) - np.pi
    return np.sqrt(np.mean(e ** 2, axis=0))
