"""The swing diagram's ports, for a Drake user who composes it into a
diagram of their own.

Outputs (always; the signal names of each are :data:`SWING_SIGNALS`):
``true_state`` (the simulated robot), ``estimate`` (what the controller
reads), ``imu`` (the sampled IMU readings, with every error the scenario
draws), ``command`` (the controller's torque before the actuation delay),
``torque`` (delivered by the driver) and ``voltage`` (the winding's).

Inputs (on request, :func:`~bplir_drake.diagrams.build_swing`'s
``external_torque``, ``estimate_input`` and ``action_input``): ``action``,
the elbow command as a share of the torque limit in [-1, 1], in the
controller's place (a learning environment's action); ``external_torque``, two
generalized forces (N m on q1 and q2) added to friction and the
scenario's wind and gusts -- a disturbance, a knock, a fault -- and
``estimate``, the state (q1, q2, q1', q2') the controller and the
gripper interlock read, in place of the package's EKF, so a user's own
estimator (fed from ``imu`` and anything else) can be wired in.

**Timing of the estimate.**  Every sampled system ticks at ``t_k = k T``
(``T = controller.period``): the ``estimate`` output read at a time in
``(t_k, t_{k+1}]`` is the estimate of the state at ``t_k`` (from IMU
sample k) -- a logger that publishes at the ticks themselves reads the
previous tick's.  Logged beside ``true_state`` at the same times it
therefore lags by up to a tick, a tenth of a radian in the elbow's fast
swing; :func:`estimate_times` gives the time each logged value
estimates.
"""
from __future__ import annotations

import numpy as np

from ..systems.action import ActionTorque
from .parts import torque_limit

#: the signal names of each output port of a swing diagram, by port
SWING_SIGNALS = {
    "true_state": ("q1", "q2", "q1d", "q2d"),
    "estimate": ("q1", "q2", "q1d", "q2d"),
    "imu": ("gyro1", "gyro2", "acc1_x", "acc1_y", "acc2_x", "acc2_y"),
    "command": ("torque_command",),
    "torque": ("torque",),
    "voltage": ("voltage",),
}

#: the output ports of a swing diagram
SWING_PORTS = tuple(SWING_SIGNALS)

#: the input ports a swing diagram may have, with their signal names
SWING_INPUTS = {"external_torque": ("tau1", "tau2"), "estimate": ("q1", "q2", "q1d", "q2d"),
                "action": ("torque_share",)}


def add_external_torque(builder, other=None):
    """An ``external_torque`` input (2 generalized forces, N m) exported from
    the diagram, added to ``other`` (the scenario's disturbance output, or
    None); returns the output port of their sum."""
    from pydrake.systems.primitives import Adder, PassThrough

    if other is None:
        through = builder.AddNamedSystem("external_torque", PassThrough(2))
        builder.ExportInput(through.get_input_port(), "external_torque")
        return through.get_output_port()
    add = builder.AddNamedSystem("external_torque", Adder(2, 2))
    builder.Connect(other, add.get_input_port(0))
    builder.ExportInput(add.get_input_port(1), "external_torque")
    return add.get_output_port(0)


def add_estimate_input(builder):
    """An ``estimate`` input (q1, q2, q1', q2') exported from the diagram;
    returns ``(system, its output port)`` for the controller and the
    interlock to read."""
    from pydrake.systems.primitives import PassThrough

    through = builder.AddNamedSystem("estimate_input", PassThrough(4))
    builder.ExportInput(through.get_input_port(), "estimate")
    return through, through.get_output_port()


def add_action_input(builder, params, state_port) -> dict:
    """The controller's place taken by an ``action`` input exported from the
    diagram (:class:`~bplir_drake.systems.action.ActionTorque`, its
    ``state`` input fed from ``state_port``); returns ``{"controller": it}``."""
    ctrl = builder.AddNamedSystem("controller", ActionTorque(torque_limit(params)))
    builder.Connect(state_port, ctrl.GetInputPort("state"))
    builder.ExportInput(ctrl.GetInputPort("action"), "action")
    return {"controller": ctrl}


def export_swing_ports(builder, robot, estimate_port, controller, imu_port) -> None:
    """Export the output ports of :data:`SWING_SIGNALS`."""
    builder.ExportOutput(robot.plant.get_state_output_port(), "true_state")
    builder.ExportOutput(estimate_port, "estimate")
    builder.ExportOutput(imu_port, "imu")
    builder.ExportOutput(controller.GetOutputPort("torque"), "command")
    builder.ExportOutput(robot.motor.GetOutputPort("torque"), "torque")
    builder.ExportOutput(robot.motor.GetOutputPort("voltage"), "voltage")


def estimate_times(t, period: float) -> np.ndarray:
    """The time of the state each value of the ``estimate`` output, read at
    times ``t`` (s), estimates: ``t_k`` for a read in ``(t_k, t_{k+1}]``
    (the value at 0 is the start's).  ``period``: ``controller.period``."""
    k = np.ceil(np.asarray(t, dtype=float) / period - 1e-9) - 1.0
    return np.maximum(k, 0.0) * period
