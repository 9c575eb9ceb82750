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
from ..results import Result

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
        from .plots import plot_estimate

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
                        knock=DEFAULT_KNOCK, seed: int | None = None) -> EstimationRun:
    """Simulate plant + IMUs + EKF from rest at ``q0`` (relative angles); the
    filter starts at the true absolute state plus ``initial_error``."""
    seed = params.scenario.seed if seed is None else seed
    x_true0 = absolute_from_relative(np.array([q0[0], q0[1], 0.0, 0.0]))
    x0_est = x_true0 + np.asarray(initial_error, dtype=float)
    built = build_sensor_swing(params, x0_est, elbow_torque=elbow_torque, knock=knock,
                               seed=seed, log_period=0.002)
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
