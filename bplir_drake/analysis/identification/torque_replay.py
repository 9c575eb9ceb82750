"""A logged torque replayed into the model: how long the simulated robot
follows the logged one.

The elbow torque of a log (zero-order hold between its samples) drives the
plant with friction from the log's first angles and rates; the simulated
angles are compared with the logged ones.  The figures a designer reads:
each joint's RMSE over the whole log and over windows, and the time at
which either joint first differs by more than a threshold -- a chaotic
double pendulum diverges from any model eventually, so the divergence time
is the honest measure of a model against hardware data.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...io import Result
from ...params import BplirParams
from ...plotting import figure_axes, finish
from .calibration import CalibrationLog, acrobot_log_angles, simulate_log


@dataclass
class TorqueReplay(Result):
    """A log replayed: times (s), logged and simulated angles (N, 2) rad, the
    divergence threshold (rad) and the RMSE window (s); optionally the angles
    of Drake's ``AcrobotPlant`` driven by the same torque (``acrobot``)."""

    t: np.ndarray
    logged: np.ndarray
    simulated: np.ndarray
    threshold: float
    window: float
    acrobot: np.ndarray | None = None

    def table(self) -> dict:
        """The replay as time series: ``t_s``, the logged and simulated angles
        (and Drake's AcrobotPlant's, when run), a column each."""
        out = {"t_s": self.t, "q1_logged_rad": self.logged[:, 0],
               "q2_logged_rad": self.logged[:, 1], "q1_simulated_rad": self.simulated[:, 0],
               "q2_simulated_rad": self.simulated[:, 1]}
        if self.acrobot is not None:
            out |= {"q1_acrobot_rad": self.acrobot[:, 0], "q2_acrobot_rad": self.acrobot[:, 1]}
        return out

    @property
    def error(self) -> np.ndarray:
        """Simulated less logged angles (N, 2), rad."""
        return self.simulated - self.logged

    @property
    def rmse(self) -> np.ndarray:
        """Each joint's RMSE over the whole log (rad)."""
        return np.sqrt(np.mean(self.error ** 2, axis=0))

    @property
    def divergence_time(self) -> float | None:
        """The first time (s) either joint differs by more than ``threshold``;
        None when it never does."""
        return self._first_beyond(self.error)

    def _first_beyond(self, error) -> float | None:
        beyond = np.any(np.abs(error) > self.threshold, axis=1)
        return float(self.t[np.argmax(beyond)]) if beyond.any() else None

    def window_rmse(self) -> list[dict]:
        """Each joint's RMSE over consecutive windows of ``window`` seconds."""
        rows = []
        for start in np.arange(self.t[0], self.t[-1], self.window):
            inside = (self.t >= start) & (self.t < start + self.window)
            if inside.sum() >= 2:
                r = np.sqrt(np.mean(self.error[inside] ** 2, axis=0))
                rows.append({"start_s": float(start), "rmse_rad": r.tolist()})
        return rows

    def summary(self) -> dict:
        """Samples, span, RMSE per joint (whole log and per window), the
        divergence threshold and time."""
        out = {"samples": int(len(self.t)), "duration_s": float(self.t[-1] - self.t[0]),
               "rmse_rad": self.rmse.tolist(), "divergence_threshold_rad": self.threshold,
               "divergence_time_s": self.divergence_time, "window_s": self.window,
               "windows": self.window_rmse()}
        if self.acrobot is not None:
            err = self.acrobot - self.logged
            out["acrobot"] = {"rmse_rad": np.sqrt(np.mean(err ** 2, axis=0)).tolist(),
                              "divergence_time_s": self._first_beyond(err),
                              "largest_difference_from_model_rad":
                                  float(np.abs(self.acrobot - self.simulated).max())}
        return out

    def plot(self, axes=None):
        """Logged and simulated q1 and q2, and their differences with the
        threshold and the divergence marked (three axes)."""
        fig, ax = figure_axes(axes, 3, 1, figsize=(9, 7), sharex=True)
        for i in range(2):
            ax[i].plot(self.t, self.logged[:, i], "k", lw=2, alpha=0.4, label="logged")
            ax[i].plot(self.t, self.simulated[:, i], "C0", lw=1, label="model, logged torque")
            if self.acrobot is not None:
                ax[i].plot(self.t, self.acrobot[:, i], "C1", lw=1, ls="--",
                           label="Drake AcrobotPlant")
            ax[i].set_ylabel(f"q{i + 1} [rad]")
            ax[i].legend(fontsize=8, loc="upper right")
        for i in range(2):
            ax[2].plot(self.t, self.error[:, i], f"C{i}", lw=1, label=f"q{i + 1}")
            if self.acrobot is not None:
                ax[2].plot(self.t, self.acrobot[:, i] - self.logged[:, i], f"C{i}", lw=0.8,
                           ls="--", label=f"q{i + 1}, AcrobotPlant")
        for sign in (-1, 1):
            ax[2].axhline(sign * self.threshold, color="0.5", ls="--", lw=0.8)
        td = self.divergence_time
        if td is not None:
            for a in ax:
                a.axvline(td, color="C3", lw=0.8, ls=":")
        ax[2].set_ylabel("model - log [rad]")
        ax[2].set_xlabel("time [s]")
        ax[2].legend(fontsize=8, loc="upper left")
        for a in ax:
            a.grid(True, alpha=0.3)
        when = "never" if td is None else f"at {td:.2f} s"
        return finish(fig, f"Logged torque replayed: RMSE {self.rmse[0]:.3f} / "
                           f"{self.rmse[1]:.3f} rad, beyond {self.threshold:g} rad {when}")


def replay_torque(params: BplirParams, log: CalibrationLog, *, threshold: float = 0.1,
                  window: float = 0.5, accuracy: float = 1e-8, interpolation: str = "zoh",
                  acrobot: bool = False) -> TorqueReplay:
    """Drive the nominal model of ``params`` (plant and friction) with the
    log's torque from its first state (error-controlled RK3 at
    ``accuracy``; the torque held between samples or ``interpolation =
    "linear"``); ``threshold`` (rad) marks the divergence, ``window`` (s)
    the RMSE windows; ``acrobot``: Drake's ``AcrobotPlant`` beside it
    (:func:`~.calibration.acrobot_log_angles`)."""
    if not (threshold > 0 and math.isfinite(threshold)):
        raise ValueError(f"threshold = {threshold!r} rad must be positive")
    sim = simulate_log(params, log, accuracy=accuracy, interpolation=interpolation)
    other = (acrobot_log_angles(params, log, accuracy=accuracy, interpolation=interpolation)
             if acrobot else None)
    return TorqueReplay(log.t, log.q, sim, float(threshold), float(window), other)
