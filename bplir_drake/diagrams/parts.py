"""Pieces every BPLIR diagram shares: the :class:`Built` record, the plant
with its friction (and external forces), the two IMUs, the zero-order hold
that feeds a continuous signal to a sampled system, and schedule sources."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydrake.systems.primitives import ConstantVectorSource, TrajectorySource, ZeroOrderHold

from ..systems.pysystem import release_system
from ..params import BplirParams, FrictionParams, PlantParams
from ..systems.friction import JointFriction, friction_system
from ..systems.imu import ImuSampler
from ..systems.plant import add_acrobot_plant


@dataclass
class Built:
    """A built diagram with handles to its parts.

    ``systems`` maps names (``"friction"``, ``"motor"``, ``"ekf"``, ...) to
    subsystems, ``loggers`` names to Drake log sinks or
    :class:`~bplir_drake.systems.schedule.TickLogger` objects.  ``params`` are the
    parameters it was built from; ``q0`` is the simulated robot's start
    configuration (rad) of a swing, and ``structure`` what a context cannot
    change (:func:`~bplir_drake.diagrams.swing.swing_structure`), for the
    builders that support per-context samples.
    """

    diagram: Any
    plant: Any
    systems: dict[str, Any] = field(default_factory=dict)
    loggers: dict[str, Any] = field(default_factory=dict)
    params: BplirParams | None = None
    q0: Any = None
    structure: str | None = None

    def __getitem__(self, name):
        return self.systems[name]

    def release(self) -> None:
        """Let the diagram go once nothing will run it again: pydrake
        (1.51) keeps a diagram with Python systems alive forever through
        the reference cycles it records between a builder, a diagram and
        their systems (``_pydrake_internal_ref_cycle_peers``), which pass
        through C++ ownership where Python's collector cannot see them, and
        through the ports and callbacks our systems hold; a process that
        builds diagrams in a loop (a study whose samples differ in structure)
        grew by about 3 MB a build.  Dropping those records on every system
        of the tree, and our systems' own references
        (:func:`~bplir_drake.systems.pysystem.release_system`), lets Python free
        the diagram with the last reference to it.  The handles in this
        object are cleared."""
        stack = [self.diagram] if self.diagram is not None else []
        while stack:
            system = stack.pop()
            if hasattr(system, "GetSystems"):
                stack.extend(system.GetSystems())
            getattr(system, "__dict__", {}).pop(_REF_CYCLE_PEERS, None)
            release_system(system)
        self.diagram = self.plant = None
        self.systems, self.loggers = {}, {}


#: the attribute in which pydrake records the reference cycles of a system
_REF_CYCLE_PEERS = "_pydrake_internal_ref_cycle_peers"


def sampled(builder, port, period: float):
    """``port`` sampled at the ticks ``k period`` and held (C++
    ``ZeroOrderHold``): a discrete system of the tick schedule
    (:mod:`~bplir_drake.systems.schedule`) computes its tick result from its
    inputs, so a continuous signal it reads must be held over the tick."""
    hold = builder.AddSystem(ZeroOrderHold(period, port.size()))
    builder.Connect(port, hold.get_input_port(0))
    return hold.get_output_port(0)


def torque_source(builder, elbow_torque, interpolation: str = "zoh"):
    """A constant (float) or a schedule ``(times, values)``: ``values[i]``
    holds from ``times[i]`` until ``times[i + 1]`` (``interpolation =
    "zoh"``), or runs linearly to ``values[i + 1]`` (``"linear"``); the last
    value holds on."""
    if isinstance(elbow_torque, tuple):
        from pydrake.trajectories import PiecewisePolynomial

        times, values = (np.asarray(a, dtype=float) for a in elbow_torque)
        if times.size == 1:
            return builder.AddSystem(ConstantVectorSource([float(values[0])]))
        # Drake's zero-order hold ignores the value at the final break: the last
        # value held on a million seconds (linear: flat past the last sample)
        times = np.append(times, times[-1] + 1e6)
        values = np.append(values, values[-1])
        hold = (PiecewisePolynomial.FirstOrderHold if interpolation == "linear"
                else PiecewisePolynomial.ZeroOrderHold)
        return builder.AddSystem(TrajectorySource(hold(times, values.reshape(1, -1))))
    return builder.AddSystem(ConstantVectorSource([float(elbow_torque)]))


@dataclass
class Robot:
    """The simulated robot in a swing diagram: plant, friction, external
    forces and motor."""

    plant: Any
    friction: Any
    disturbance: Any
    motor: Any


def add_plant_with_friction(builder, plant_params: PlantParams,
                            friction_params: FrictionParams, *, scene_graph=False,
                            disturbance=None, linearizable: bool = False,
                            friction_in_context: bool = False):
    """Plant + friction force element wired into the applied-force port.

    ``disturbance`` (optional) is an output port of 2 generalized forces
    (e.g. wind or a knock) added to the friction force.  The friction is the
    C++ symbolic system (:func:`~bplir_drake.systems.friction.friction_system`,
    with its dissipated-energy state) for simulation -- its coefficients
    settable per context with ``friction_in_context=True`` -- or with
    ``linearizable=True`` the templated :class:`JointFriction` (no extra
    state, converts to AutoDiffXd for ``Linearize``).
    """
    from pydrake.systems.primitives import Adder

    out = add_acrobot_plant(builder, plant_params, scene_graph=scene_graph)
    plant = out[0] if scene_graph else out
    friction = builder.AddSystem(JointFriction(friction_params) if linearizable
                                 else friction_system(friction_params,
                                                      in_context=friction_in_context))
    friction.set_name("joint_friction")
    builder.Connect(plant.get_state_output_port(), friction.get_input_port(0))
    if disturbance is None:
        builder.Connect(friction.get_output_port(0),
                        plant.get_applied_generalized_force_input_port())
    else:
        add = builder.AddSystem(Adder(2, 2))
        add.set_name("external_forces")
        builder.Connect(friction.get_output_port(0), add.get_input_port(0))
        builder.Connect(disturbance, add.get_input_port(1))
        builder.Connect(add.get_output_port(0),
                        plant.get_applied_generalized_force_input_port())
    return out, friction


def add_imu_sensors(builder, plant, params: BplirParams):
    """Drake's Gyroscope and Accelerometer on each link (C++, ideal: the
    true kinematics at the IMU's radius); returns their measurement output
    ports ``[(gyro1, accel1), (gyro2, accel2)]``."""
    from pydrake.math import RigidTransform
    from pydrake.systems.sensors import Accelerometer, Gyroscope

    g = params.simulated_plant.g
    ports = []
    for i, (link, r) in enumerate((("link1", params.imu.r1), ("link2", params.imu.r2)), 1):
        body = plant.GetBodyByName(link)
        X_BS = RigidTransform([0.0, -r, 0.0])
        gyro = builder.AddSystem(Gyroscope(body, X_BS))
        acc = builder.AddSystem(Accelerometer(body, X_BS, [0.0, -g, 0.0]))
        gyro.set_name(f"gyroscope{i}")
        acc.set_name(f"accelerometer{i}")
        builder.Connect(plant.get_body_poses_output_port(), gyro.get_body_poses_input_port())
        builder.Connect(plant.get_body_spatial_velocities_output_port(),
                        gyro.get_body_velocities_input_port())
        for port, sys_port in ((plant.get_body_poses_output_port(), acc.get_body_poses_input_port()),
                               (plant.get_body_spatial_velocities_output_port(),
                                acc.get_body_velocities_input_port()),
                               (plant.get_body_spatial_accelerations_output_port(),
                                acc.get_body_accelerations_input_port())):
            builder.Connect(port, sys_port)
        ports.append((gyro.get_measurement_output_port(), acc.get_measurement_output_port()))
    return ports


def add_imus(builder, plant, params: BplirParams, seed: int):
    """Drake Gyroscope/Accelerometer on each link + the sampling/noise model."""
    sampler = builder.AddSystem(ImuSampler(params.imu, seed))
    sampler.set_name("imu")
    for i, (gyro, accel) in enumerate(add_imu_sensors(builder, plant, params), 1):
        builder.Connect(gyro, sampler.GetInputPort(f"gyro{i}"))
        builder.Connect(accel, sampler.GetInputPort(f"accel{i}"))
    return sampler


def pulse_source(builder, knock):
    """Generalized-force pulse on joint 1: ``knock = (t_start, duration, torque)``
    (:func:`pulses_source` of that one pulse)."""
    t0, dur, tq = knock
    return pulses_source(builder, [(t0, (tq, 0.0), dur)])


def pulses_source(builder, pulses):
    """Generalized forces on joints 1 and 2 of the torque ``pulses``
    ``[(start s, (tau1, tau2) N m, duration s)]`` (knocks; overlapping ones
    add), zero elsewhere: a zero-order-hold ``TrajectorySource``."""
    from pydrake.trajectories import PiecewisePolynomial

    edges = sorted({0.0} | {max(float(t), 0.0) for t, _, _ in pulses}
                   | {max(float(t + d), 0.0) for t, _, d in pulses})
    edges.append(edges[-1] + 1.0)
    vals = np.zeros((2, len(edges)))
    for t, amp, d in pulses:
        on = [(t - 1e-12 <= e < t + d - 1e-12) for e in edges]
        vals[:, on] += np.asarray(amp, dtype=float)[:, None]
    return builder.AddSystem(TrajectorySource(
        PiecewisePolynomial.ZeroOrderHold(np.array(edges), vals)))


def torque_limit(params: BplirParams) -> float:
    """The elbow's torque limit (N m): the smaller of the motor's and the
    controller's, as the driver applies it."""
    return min(params.motor.torque_limit, params.controller.torque_limit)
