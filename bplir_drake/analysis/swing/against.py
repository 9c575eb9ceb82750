"""A swing against a logged run of the robot: the simulated joint angles
at the log's times (its clock from 0 at the swing's start), each joint's
RMSE over the time both cover, and a figure of both (with the plan both
tracked, when there is one) -- how closely the closed loop reproduces a
hardware run."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...planning.file import read_plan_file
from ...io import Result
from ...plotting import figure_axes, finish


@dataclass
class LogComparison(Result):
    """Times (s), logged and simulated angles (N, 2) rad over the time the
    log and the swing both cover, what the log is called, and the tracked
    plan's angles at those times (N, 2) rad, if the swing tracked one."""

    t: np.ndarray
    logged: np.ndarray
    simulated: np.ndarray
    label: str = "logged run"
    reference: np.ndarray | None = None

    @property
    def rmse(self) -> np.ndarray:
        """Each joint's RMSE (rad)."""
        return np.sqrt(np.mean((self.simulated - self.logged) ** 2, axis=0))

    def summary(self) -> dict:
        """Samples, span, RMSE and largest difference per joint."""
        err = np.abs(self.simulated - self.logged)
        return {"log": self.label, "samples": int(len(self.t)),
                "duration_s": float(self.t[-1] - self.t[0]), "rmse_rad": self.rmse.tolist(),
                "largest_difference_rad": err.max(axis=0).tolist()}

    def plot(self, axes=None):
        """Both runs' q1 and q2 (two axes)."""
        fig, ax = figure_axes(axes, 2, 1, figsize=(9, 6), sharex=True)
        for i, a in enumerate(ax):
            a.plot(self.t, self.logged[:, i], "k", lw=2, alpha=0.4, label=self.label)
            a.plot(self.t, self.simulated[:, i], "C0", lw=1, label="simulated closed loop")
            if self.reference is not None:
                a.plot(self.t, self.reference[:, i], "k--", lw=0.8, label="plan")
            a.set_ylabel(f"q{i + 1} [rad]")
            a.grid(True, alpha=0.3)
            a.legend(fontsize=8, loc="best")
        ax[1].set_xlabel("time [s]")
        return finish(fig, f"Swing against {self.label}: RMSE {self.rmse[0]:.3f} / "
                           f"{self.rmse[1]:.3f} rad")


def compare_with_log(result, log, label: str = "logged run") -> LogComparison:
    """``result`` (a swing) against ``log`` (a
    :class:`~bplir_drake.analysis.identification.calibration.CalibrationLog`,
    its clock from 0) over the time both cover, with the angles of the plan
    file the swing tracked (:func:`tracked_plan_file`), if any."""
    state = result.logs["state"]
    inside = log.t <= state.t[-1]
    if inside.sum() < 2:
        raise ValueError(f"the log and the swing share less than two samples "
                         f"(the swing lasts {state.t[-1]:.3g} s)")
    t = log.t[inside]
    plan = tracked_plan_file(result.params)
    reference = None if plan is None else np.column_stack(
        [np.interp(t, plan.times, plan.states[:, i], right=np.nan) for i in (0, 1)])
    return LogComparison(t, log.q[inside], state.at(t)[:, :2], label, reference)


def tracked_plan_file(params):
    """The plan of ``plan.file`` when the swing of ``params`` tracked it (its
    clock the swing's), else None."""
    if not params.plan.file or params.resolved().path.mode != "plan":
        return None
    return read_plan_file(params)
