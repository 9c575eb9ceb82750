"""The swing's sensing in the diagram: the two IMUs on the simulated links
and the kinematic EKF (or a user's estimator, or the diagram's estimate
input), and the jaw's line sensor the EKF fuses when the robot has one."""
from __future__ import annotations

import math

from ..params import BplirParams, ParameterError
from ..systems.ekf import KinematicEkf
from ..systems.line_sensor import LineSensor
from ..systems.plant import absolute_from_relative
from .parts import Robot, add_imus
from .plugin import make_plugin
from .swing_ports import add_estimate_input
from .swing_setup import SwingSetup


def add_sensing(builder, params: BplirParams, robot: Robot, setup: SwingSetup, seed: int,
                estimator=None, estimate_input: bool = False):
    """Two IMUs on the simulated links and the kinematic EKF (nominal
    geometry, started in the state the robot believes, ``setup.believed``,
    with the standstill calibration made in the true pose ``setup.q0``,
    :meth:`SwingSetup.calibration`), or a user's estimator
    (``estimator``, a factory, or ``estimator.plugin``: :mod:`.plugin`), or,
    with ``estimate_input``, the diagram's ``estimate`` input (:mod:`.swing_ports`).
    Returns ``(sampler, estimator, estimate port)``."""
    sampler = add_imus(builder, robot.plant, params, seed)
    if estimate_input:
        if estimator is not None or params.estimator.plugin:
            raise ParameterError("estimate_input replaces the estimator; give no estimator "
                                 "plug-in with it")
        return (sampler, *add_estimate_input(builder))
    if estimator is not None or params.estimator.plugin:

        user = builder.AddNamedSystem("estimator", make_plugin(params, "estimator", estimator))
        builder.Connect(sampler.GetOutputPort("imu"), user.GetInputPort("imu"))
        return sampler, user, user.GetOutputPort("state")
    ekf = builder.AddNamedSystem("ekf", kinematic_ekf(params, setup, seed))
    builder.Connect(sampler.GetOutputPort("imu"), ekf.GetInputPort("imu"))
    add_line_sensor(builder, params, robot, seed, ekf)
    return sampler, ekf, ekf.GetOutputPort("estimate_relative")


def kinematic_ekf(params: BplirParams, setup: SwingSetup, seed: int) -> KinematicEkf:
    """The swing's EKF (nominal geometry, started in the state the robot
    believes, with the standstill calibration of ``seed``), not yet in a
    diagram; it fuses the jaw's line sensor when the robot has one."""
    est = params.estimator
    ls = params.line_sensor
    alpha = math.radians(params.scenario.incline_deg)
    line = (params.plant.l1, params.plant.l2, alpha, ls.filter_sigma) if ls.fitted else None
    return KinematicEkf(
        est, absolute_from_relative(setup.believed),
        sigmas=(est.start_angle_sigma, est.start_rate_sigma, est.start_bias_sigma),
        calibration=setup.calibration(params, seed), line=line)


def add_line_sensor(builder, params: BplirParams, robot: Robot, seed: int, ekf,
                    now: bool = False) -> None:
    """The jaw's line sensor on the simulated robot, read by ``ekf`` (a
    system with a ``line_gap`` input), when the robot has one: its held
    sample, or with ``now`` the sample it takes at this instant (for a
    system that samples at the tick's event)."""
    ls = params.line_sensor
    if not ls.fitted:
        return
    true = params.simulated_plant
    sensor = builder.AddNamedSystem("line_sensor", LineSensor(
        ls, true.l1, true.l2, math.radians(params.scenario.incline_deg), params.imu.period,
        seed))
    builder.Connect(robot.plant.get_state_output_port(), sensor.state_port)
    builder.Connect(sensor.GetOutputPort("line_gap_now" if now else "line_gap"),
                    ekf.GetInputPort("line_gap"))
