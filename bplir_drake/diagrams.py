"""Builders that wire the BPLIR systems into the diagrams users run.

All wiring of ports happens here; analysis code calls these builders.  Each
builder takes one :class:`~bplir_drake.params.BplirParams` and returns a
small record holding the diagram and handles to its named subsystems and
loggers.  The simulated plant always uses ``params.simulated_plant`` /
``params.simulated_friction``; controllers and estimators only ever see the
nominal blocks.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import (ConstantVectorSource, LogVectorOutput,
                                        TrajectorySource)

from .params import BplirParams, FrictionParams, PlantParams
from .systems.friction import JointFriction
from .systems.motor import MotorDriver
from .systems.plant import add_acrobot_plant


@dataclass
class Built:
    """A built diagram with handles to its parts (names -> systems/loggers)."""

    diagram: Any
    plant: Any
    systems: dict[str, Any] = field(default_factory=dict)
    loggers: dict[str, Any] = field(default_factory=dict)
    params: BplirParams | None = None

    def __getitem__(self, name):
        return self.systems[name]


def _torque_source(builder, elbow_torque):
    """A constant torque (float) or a zero-order-hold schedule (times, values)."""
    if isinstance(elbow_torque, tuple):
        from pydrake.trajectories import PiecewisePolynomial

        times, values = (np.asarray(a, dtype=float) for a in elbow_torque)
        if times.size == 1:
            return builder.AddSystem(ConstantVectorSource([float(values[0])]))
        traj = PiecewisePolynomial.ZeroOrderHold(times, values.reshape(1, -1))
        return builder.AddSystem(TrajectorySource(traj))
    return builder.AddSystem(ConstantVectorSource([float(elbow_torque)]))


def add_plant_with_friction(builder, plant_params: PlantParams,
                            friction_params: FrictionParams, *, scene_graph=False):
    """Plant + friction force element wired into the applied-force port."""
    out = add_acrobot_plant(builder, plant_params, scene_graph=scene_graph)
    plant = out[0] if scene_graph else out
    friction = builder.AddSystem(JointFriction(friction_params))
    friction.set_name("joint_friction")
    builder.Connect(plant.get_state_output_port(), friction.get_input_port(0))
    builder.Connect(friction.get_output_port(0),
                    plant.get_applied_generalized_force_input_port())
    return out, friction


def build_free_swing(params: BplirParams, elbow_torque=0.0, *, friction: bool = True,
                     motor: bool = False, log_period: float = 0.001) -> Built:
    """Free swing: plant + friction with a constant or scheduled elbow torque.

    ``elbow_torque`` is a float or a ``(times, values)`` zero-order-hold
    schedule (N m).  With ``motor=True`` the command passes through the motor
    and driver model.  Loggers: ``state`` (q1, q2, q1d, q2d), ``friction``
    (generalized friction force, = -f), ``torque`` (elbow torque applied).
    """
    builder = DiagramBuilder()
    fp = params.simulated_friction
    if not friction:
        from dataclasses import replace

        fp = replace(fp, enabled=False)
    plant, fr = add_plant_with_friction(builder, params.simulated_plant, fp)
    src = _torque_source(builder, elbow_torque)
    src.set_name("torque_command")
    systems = {"friction": fr, "source": src}
    if motor:
        drv = builder.AddSystem(MotorDriver(params.motor))
        drv.set_name("motor")
        builder.Connect(src.get_output_port(0), drv.GetInputPort("torque_command"))
        builder.Connect(plant.get_state_output_port(), drv.GetInputPort("state"))
        torque_port = drv.GetOutputPort("torque")
        systems["motor"] = drv
    else:
        torque_port = src.get_output_port(0)
    builder.Connect(torque_port, plant.get_actuation_input_port())
    loggers = {
        "state": LogVectorOutput(plant.get_state_output_port(), builder, log_period),
        "friction": LogVectorOutput(fr.get_output_port(0), builder, log_period),
        "torque": LogVectorOutput(torque_port, builder, log_period),
    }
    if motor:
        loggers["current"] = LogVectorOutput(drv.GetOutputPort("current"), builder, log_period)
        loggers["power"] = LogVectorOutput(drv.GetOutputPort("power"), builder, log_period)
    diagram = builder.Build()
    diagram.set_name("free_swing")
    return Built(diagram, plant, systems, loggers, params)


def build_plant_with_friction(params: BplirParams, *, nominal: bool = False) -> Built:
    """Plant + friction with the elbow actuation exported as the diagram's
    input and the plant state as its output: the object to linearise."""
    builder = DiagramBuilder()
    pp = params.plant if nominal else params.simulated_plant
    fp = params.friction if nominal else params.simulated_friction
    plant, fr = add_plant_with_friction(builder, pp, fp)
    builder.ExportInput(plant.get_actuation_input_port(), "elbow_torque")
    builder.ExportOutput(plant.get_state_output_port(), "state")
    diagram = builder.Build()
    diagram.set_name("plant_with_friction")
    return Built(diagram, plant, {"friction": fr}, {}, params)
