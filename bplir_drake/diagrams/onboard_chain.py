"""The default swing's computer wired as one system
(:class:`~bplir_drake.systems.onboard.OnboardComputer`): the IMU sampler,
the EKF, the delay identifier and predictor and the plan tracker, built by
the same functions that build them one by one, on the simulated robot's
IMUs.  :func:`fuses` says when a swing's chain is that one."""
from __future__ import annotations

from typing import Any

from pydrake.systems.primitives import Multiplexer

from ..params import BplirParams
from ..systems.imu import ImuSampler
from ..systems.onboard import OnboardComputer
from .parts import add_imu_sensors
from .sensors import add_line_sensor, kinematic_ekf
from .swing_controller import delay_compensation, plan_tracker


def fuses(params: BplirParams, use_estimator: bool, custom: bool) -> bool:
    """Whether the swing's chain runs as one system: the EKF in the loop
    feeding the plan tracker, no plug-in or external estimate (``custom``),
    and the IMUs, the filter and the controller on one tick."""
    T = params.controller.period
    return (use_estimator and not custom and params.path.mode == "plan"
            and params.imu.period == T and params.estimator.period == T)


def add_onboard(builder, params: BplirParams, robot, setup, seed: int,
                plan_gains) -> tuple[OnboardComputer, dict[str, Any]]:
    """The onboard computer on the robot's IMUs (and line sensor), as
    :func:`~bplir_drake.diagrams.sensors.add_sensing` and
    :func:`~bplir_drake.diagrams.swing_controller.add_swing_controller` would
    build its parts.  Returns it and the controller's roles (``controller``,
    and ``delay_id`` when it identifies the delay), each the one system."""
    ekf = kinematic_ekf(params, setup, seed)
    comp = delay_compensation(params, None, True, setup.believed[:2])
    tracker = plan_tracker(params, comp, setup.path, plan_gains)
    computer = builder.AddNamedSystem("onboard", OnboardComputer(
        ImuSampler(params.imu, seed), ekf, tracker, comp.identifier, comp.predictor))
    readings = builder.AddNamedSystem("imu_readings", Multiplexer([3, 3, 3, 3]))
    (gyro1, accel1), (gyro2, accel2) = add_imu_sensors(builder, robot.plant, params)
    for k, port in enumerate((gyro1, gyro2, accel1, accel2)):
        builder.Connect(port, readings.get_input_port(k))
    builder.Connect(readings.get_output_port(0), computer.GetInputPort("imu_readings"))
    add_line_sensor(builder, params, robot, seed, computer, now=True)
    roles = {"controller": computer}
    if comp.identifier is not None:
        roles["delay_id"] = computer
    if comp.predictor is not None:
        roles["predictor"] = computer
    return computer, roles
