"""A swing's set-up, computed once at the top of a build: where the
simulated robot starts and where the robot believes it starts, the
target, the geometry of its path and of the line, and the standstill
calibration it makes before swinging (:class:`SwingSetup`)."""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..params import BplirParams, ParameterError
from ..systems.standstill import ImuCalibration, calibrate_standstill
from ..systems.gripper import LineGeometry
from ..systems.imu import standstill_samples
from ..systems.line_sensor import standstill_readings
from ..systems.path import PathGeometry
from ..systems.plant import absolute_from_relative, start_configuration, target_configuration
from ..planning.file import read_plan_file


@dataclass(frozen=True)
class SwingSetup:
    """What every builder of a swing needs, computed once: the simulated
    robot's start pose ``q0`` and ``target`` (rad, its true lengths), the
    start state the robot believes (``believed``: q1, q2, q1', q2', the
    nominal lengths, or the plan file's first state), the path geometry
    (nominal) and the line geometry (true) of the interlock."""

    q0: np.ndarray
    target: np.ndarray
    believed: np.ndarray
    path: PathGeometry
    line: LineGeometry

    def calibration(self, params: BplirParams, seed: int) -> ImuCalibration:
        """The standstill calibration the robot makes in this set-up
        (:func:`standstill_calibration`)."""
        return standstill_calibration(params, self.q0, seed, self.believed)


def swing_setup(params: BplirParams) -> SwingSetup:
    """The :class:`SwingSetup` of ``params`` (the plan file, for a start in
    its first state, read once)."""
    sc = params.scenario
    alpha = math.radians(sc.incline_deg)
    true_p = params.simulated_plant
    believed = start_state(params)
    q0 = (believed[:2] if sc.start == "plan"
          else np.asarray(start_configuration(sc.start, sc.grip_spacing, true_p, alpha)))
    return SwingSetup(np.asarray(q0, dtype=float),
                      np.asarray(target_configuration(sc.grip_spacing, true_p, alpha)),
                      believed,
                      PathGeometry.from_scenario(params.plant, sc.grip_spacing, alpha,
                                                 params.gripper.capture_distance),
                      LineGeometry(true_p.l1, true_p.l2, alpha, sc.grip_spacing))


def swing_geometry(params: BplirParams):
    """(initial q, target q, path geometry, line geometry) of the scenario
    (:func:`swing_setup`).

    The path geometry uses the *nominal* link lengths (what the robot
    believes); the start pose of the simulated robot and the line geometry
    of the interlock use its true lengths."""
    setup = swing_setup(params)
    return setup.q0, setup.target, setup.path, setup.line


def believed_start(params: BplirParams) -> np.ndarray:
    """The start pose the robot computes (``scenario.start``): both grippers
    on the line at the scenario's grip spacing, with the *nominal* link
    lengths (rad), or hanging at rest below the holding gripper.  The
    simulated robot starts at the pose of its true lengths
    (:func:`swing_geometry`), a few mrad away with 2 mm length errors."""

    sc = params.scenario
    if sc.start == "plan":
        return start_state(params)[:2]
    return start_configuration(sc.start, sc.grip_spacing, params.plant,
                               math.radians(sc.incline_deg))


def start_state(params: BplirParams) -> np.ndarray:
    """The swing's start state (q1, q2, q1', q2'): the first state of
    ``plan.file`` with ``scenario.start = "plan"`` (the robot starts, and
    believes it starts, moving as the plan does), else at rest in
    :func:`believed_start`'s pose."""
    if params.scenario.start != "plan":
        return np.r_[believed_start(params), 0.0, 0.0]
    if not params.plan.file:
        raise ParameterError("scenario.start = 'plan' needs plan.file; allowed: line or "
                             "hanging without one")
    return np.asarray(read_plan_file(params).states[0], dtype=float)


def standstill_calibration(params: BplirParams, q0, seed: int,
                           believed=None) -> ImuCalibration:
    """The IMU calibration the robot makes before the swing, held on the line
    at rest in the true pose ``q0``: ``estimator.standstill_samples`` samples
    of the simulated sensors there
    (:func:`~bplir_drake.systems.imu.standstill_samples`, seeded by ``seed``)
    reduced by :func:`~bplir_drake.systems.standstill.calibrate_standstill`
    with the filter's gravity against the pose the robot believes it is in
    (``believed``, default :func:`believed_start`: the robot never reads its true pose); with a
    line sensor, as many of its readings there, whose mean is its offset
    (:func:`~bplir_drake.systems.line_sensor.standstill_readings`).  No
    calibration (identity) with 0 samples."""
    n = params.estimator.standstill_samples
    if n < 2:
        return ImuCalibration()
    theta = absolute_from_relative(np.asarray(q0[:2], dtype=float))
    samples = standstill_samples(params.imu, theta, params.simulated_plant.g, seed, n)
    believed = absolute_from_relative(np.asarray(
        believed_start(params) if believed is None else believed, dtype=float)[:2])
    calibration = calibrate_standstill(samples, believed, params.estimator.g)
    if params.line_sensor.fitted and params.scenario.start == "line":   # the gap is 0
        offset = float(np.mean(standstill_readings(params.line_sensor, seed, n)))
        calibration = replace(calibration, line_offset=offset)
    return calibration
