"""A plan made elsewhere (``plan.file``): a CSV of time, state and elbow
torque that the swing tracks instead of the planner's, with the tracking
gains solved on the nominal model with the config's LQR weights.

The columns are named by ``plan.file_columns`` (time, q1, q2, q1', q2',
torque, in that order; ``bplir plan`` writes ``t,q1,q2,q1d,q2d,tau``, the
default), extra columns are ignored.  With ``plan.file_angles = "robot"``
the angles, rates and torque are the robot description's joint coordinates
(``[robot] file``) and are mapped to the package's.  Times start at 0
(the first row's time is subtracted)."""
from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np

from ..csvfile import numeric_columns
from ..params import BplirParams, ParameterError
from ..params.robot_file import describe_robot
from .swing_plan import MIN_PLAN_STEP, SwingPlan

#: the fewest rows a plan file may have, and the plausible magnitudes of its
#: angles (rad), rates (rad/s) and torques (N m)
MIN_PLAN_ROWS, MAX_PLAN_ANGLE, MAX_PLAN_RATE, MAX_PLAN_TORQUE = 10, 50.0, 100.0, 500.0
#: the longest plan (s: a swing lasts seconds) and the longest time between
#: two of its rows (s: the plan is interpolated between rows, not extrapolated)
MAX_PLAN_DURATION, MAX_PLAN_GAP = 60.0, 1.0


@functools.lru_cache(maxsize=8)
def _read(path: str, mtime: float, columns: tuple) -> np.ndarray:
    cols, _ = numeric_columns(Path(path), "plan file", columns, ParameterError)
    data = np.column_stack([np.asarray(cols[c]) for c in columns])
    _check(path, data)
    return data


def _check(path: str, data: np.ndarray) -> None:
    if len(data) < MIN_PLAN_ROWS:
        raise ParameterError(f"plan.file {path} has {len(data)} rows; allowed: at least "
                             f"{MIN_PLAN_ROWS}")
    if not np.all(np.isfinite(data)):
        raise ParameterError(f"plan.file {path} has missing or non-finite values")
    if np.any(np.diff(data[:, 0]) <= 0):
        k = int(np.argmax(np.diff(data[:, 0]) <= 0))
        raise ParameterError(f"plan.file {path}: time is not increasing at row {k + 2}")
    span, gaps = data[-1, 0] - data[0, 0], np.diff(data[:, 0])
    if gaps.min() < MIN_PLAN_STEP:
        k = int(np.argmin(gaps))
        raise ParameterError(f"plan.file {path}: rows {k + 1} and {k + 2} are {gaps[k]:.3g} s "
                             f"apart; allowed at least {MIN_PLAN_STEP:g} s between rows")
    if span > MAX_PLAN_DURATION:
        raise ParameterError(f"plan.file {path} spans {span:g} s; allowed at most "
                             f"{MAX_PLAN_DURATION:g} s (one swing)")
    if gaps.max() > MAX_PLAN_GAP:
        k = int(np.argmax(gaps))
        raise ParameterError(f"plan.file {path}: {gaps[k]:g} s between rows {k + 1} and "
                             f"{k + 2}; allowed at most {MAX_PLAN_GAP:g} s between rows")
    for cols, limit, what in (((1, 2), MAX_PLAN_ANGLE, "angles (rad)"),
                              ((3, 4), MAX_PLAN_RATE, "rates (rad/s)"),
                              ((5,), MAX_PLAN_TORQUE, "torque (N m)")):
        worst = float(np.abs(data[:, cols]).max())
        if worst > limit:
            raise ParameterError(f"plan.file {path}: {what} up to {worst:g}; allowed "
                                 f"[-{limit:g}, {limit:g}]")


def read_plan_file(params: BplirParams) -> SwingPlan:
    """The plan of ``plan.file`` as a :class:`SwingPlan` (status
    ``"external"``) in the package's angles; its torque must lie within
    ``controller.torque_limit``."""
    pp = params.plan
    path = Path(pp.file)
    if not path.is_file():
        raise ParameterError(f"plan.file = '{pp.file}': no such file")
    data = _read(str(path.resolve()), path.stat().st_mtime, tuple(pp.file_columns)).copy()
    t, x, tau = data[:, 0] - data[0, 0], data[:, 1:5], data[:, 5]
    if pp.file_angles == "robot":
        if not params.robot.file:
            raise ParameterError("plan.file_angles = 'robot' needs a robot description "
                                 "(robot.file); allowed: package without one")
        d = describe_robot(params.robot)
        x, tau = d.from_file_state(x), d.sign2 * tau
    limit = params.controller.torque_limit
    if np.abs(tau).max() > limit + 1e-9:
        raise ParameterError(f"plan.file {pp.file}: torque up to {np.abs(tau).max():g} N m; "
                             f"allowed within controller.torque_limit = {limit:g} N m")
    return SwingPlan(times=t, states=x, torque=tau, friction=np.zeros((len(t), 2)),
                     solved=True, feasible=True, solver="file",
                     incline_deg=params.scenario.incline_deg, torque_limit=limit,
                     power_limit=params.motor.power_rating, tolerance=math.nan,
                     status="external")
