"""Open-loop diagrams: free swings (with or without the motor), the plant
with friction to linearise, and the sensor chain (IMUs + EKF) on a swing."""
from __future__ import annotations

import math
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput

from ..params import BplirParams
from ..systems.ekf import KinematicEkf
from ..systems.frictional_plant import frictional_plant
from ..systems.motor import MotorDriver
from ..systems.schedule import TickLogger
from .parts import Built, add_imus, add_plant_with_friction, pulse_source, pulses_source, torque_source
from dataclasses import replace


def build_free_swing(params: BplirParams, elbow_torque=0.0, *, friction: bool = True,
                     motor: bool = False, log_period: float = 0.001,
                     interpolation: str = "zoh") -> Built:
    """Free swing: plant + friction with a constant or scheduled elbow torque.

    ``elbow_torque`` is a float or a ``(times, values)`` schedule (N m), held
    between its samples (``interpolation = "zoh"``) or linear between them
    (``"linear"``).  With ``motor=True`` the command passes through the motor
    and driver model.  Loggers: ``state`` (q1, q2, q1d, q2d), ``friction``
    (generalized friction force, = -f), ``torque`` (elbow torque applied).
    """
    builder = DiagramBuilder()
    fp = params.simulated_friction
    if not friction:

        fp = replace(fp, enabled=False)
    plant, fr = add_plant_with_friction(builder, params.simulated_plant, fp)
    src = torque_source(builder, elbow_torque, interpolation)
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
    input and the plant state as its output: the object to linearise
    (:func:`~bplir_drake.systems.frictional_plant.frictional_plant` of the
    simulated robot, or of the nominal one)."""
    diagram = frictional_plant(params.plant if nominal else params.simulated_plant,
                               params.friction if nominal else params.simulated_friction)
    return Built(diagram, diagram.GetSubsystemByName("bplir_plant"),
                 {"friction": diagram.GetSubsystemByName("joint_friction")}, {}, params)


def build_sensor_swing(params: BplirParams, x0_estimate=(0.0, 0.0, 0.0, 0.0), *,
                       elbow_torque=0.0, knock=None, ekf: bool = True, seed: int | None = None,
                       log_period: float = 0.01, estimator=None) -> Built:
    """Open loop: plant + friction + two IMUs (+ EKF).

    ``elbow_torque`` as in :func:`build_free_swing`; ``knock = (t, duration,
    torque)`` applies a torque pulse on link 1 (the "knock" of 5.5).
    ``x0_estimate`` is the filter's initial absolute state, which may be
    far off: the filter is ``estimator``, by default ``params.estimator``
    with the dissertation's tuning for an unknown pose
    (:meth:`~bplir_drake.params.EstimatorParams.chapter5`).  Loggers:
    ``state``, ``imu`` (sampled IMU, at the IMU rate), ``estimate`` and
    ``covariance`` (at the filter rate) when the EKF is present.
    """
    builder = DiagramBuilder()
    seed = params.scenario.seed if seed is None else seed
    dist = pulse_source(builder, knock).get_output_port(0) if knock else None
    plant, fr = add_plant_with_friction(builder, params.simulated_plant,
                                        params.simulated_friction, disturbance=dist)
    src = torque_source(builder, elbow_torque)
    builder.Connect(src.get_output_port(0), plant.get_actuation_input_port())
    sampler = add_imus(builder, plant, params, seed)
    systems = {"friction": fr, "imu": sampler, "source": src}
    loggers = {"state": LogVectorOutput(plant.get_state_output_port(), builder, log_period),
               "imu": TickLogger(builder, sampler.GetOutputPort("imu"), params.imu.period)}
    if ekf:
        est_params = params.estimator.chapter5() if estimator is None else estimator
        est = builder.AddSystem(KinematicEkf(est_params, x0_estimate))
        est.set_name("ekf")
        builder.Connect(sampler.GetOutputPort("imu"), est.GetInputPort("imu"))
        systems["ekf"] = est
        for name, port in (("estimate", "estimate"), ("covariance", "covariance_diagonal"),
                           ("bias", "gyro_bias")):
            loggers[name] = TickLogger(builder, est.GetOutputPort(port), est_params.period)
    diagram = builder.Build()
    diagram.set_name("sensor_swing")
    return Built(diagram, plant, systems, loggers, params)


def build_damping(params: BplirParams, kp: float, kd: float, lean: float = 0.0, *,
                  log_period: float = 0.01, pulses=()) -> Built:
    """The robot hanging from its holding gripper after a swing that did not
    arrive, its elbow draining the swing: ``tau = kp (lean q1' - q2) - kd
    q2'`` (Drake's ``PidController`` on the elbow encoder's angle and rate,
    aiming the elbow against the shoulder's swing; the angle wrapped to
    [-pi, pi) by a ``WrapToSystem``, so an elbow that swung over the top
    settles a turn on instead of lifting its link back over), within the torque of the
    driver's continuous current (a ``Saturation``: the law's torques stay
    small and slow, so the dead-band, the current loop and the voltage
    envelope are left out).  The simulated plant with its friction; only
    C++ systems; ``pulses``: torque pulses on the joints while it damps
    (knocks, :func:`~.parts.pulses_source`).  Loggers ``state`` and ``torque``."""
    from pydrake.systems.controllers import PidController
    from pydrake.systems.primitives import MatrixGain, Saturation, WrapToSystem

    builder = DiagramBuilder()
    knocks = pulses_source(builder, pulses).get_output_port(0) if pulses else None
    plant, fr = add_plant_with_friction(builder, params.simulated_plant,
                                        params.simulated_friction, disturbance=knocks)
    encoder = builder.AddNamedSystem("elbow_encoder", MatrixGain(
        [[0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]))
    aim = builder.AddNamedSystem("aim", MatrixGain([[0.0, 0.0, lean, 0.0], [0.0] * 4]))
    wrap = builder.AddNamedSystem("elbow_wrap", WrapToSystem(2))
    wrap.set_interval(0, -math.pi, math.pi)
    pd = builder.AddNamedSystem("damping", PidController([kp], [0.0], [kd]))
    m = params.motor
    limit = min(m.torque_limit, params.controller.torque_limit, m.torque_per_amp * m.i_cont)
    sat = builder.AddNamedSystem("driver", Saturation([-limit], [limit]))
    state = plant.get_state_output_port()
    builder.Connect(state, encoder.get_input_port(0))
    builder.Connect(state, aim.get_input_port(0))
    builder.Connect(encoder.get_output_port(0), wrap.get_input_port(0))
    builder.Connect(wrap.get_output_port(0), pd.get_input_port_estimated_state())
    builder.Connect(aim.get_output_port(0), pd.get_input_port_desired_state())
    builder.Connect(pd.get_output_port_control(), sat.get_input_port())
    builder.Connect(sat.get_output_port(), plant.get_actuation_input_port())
    loggers = {"state": LogVectorOutput(state, builder, log_period),
               "torque": LogVectorOutput(sat.get_output_port(), builder, log_period)}
    diagram = builder.Build()
    diagram.set_name("damping")
    return Built(diagram, plant, {"friction": fr, "damping": pd}, loggers, params)


def build_acrobot(params: BplirParams, elbow_torque, *, log_period: float = 0.001,
                  interpolation: str = "zoh") -> Built:
    """Drake's own ``AcrobotPlant`` (its closed-form acrobot, the cross-check
    of ours) driven by ``elbow_torque`` as in :func:`build_free_swing`: the
    nominal links with the centres of mass on their axes (``lc1``, ``lc2``;
    it has no ``oc``) and viscous joint damping (``fv1``, ``fv2``; it has no
    Coulomb or drag term).  Logger: ``state``."""
    from pydrake.examples import AcrobotPlant

    builder = DiagramBuilder()
    acrobot = builder.AddNamedSystem("acrobot", AcrobotPlant())
    src = torque_source(builder, elbow_torque, interpolation)
    builder.Connect(src.get_output_port(0), acrobot.get_input_port(0))
    logger = LogVectorOutput(acrobot.get_output_port(0), builder, log_period)
    diagram = builder.Build()
    return Built(diagram, acrobot, {"source": src}, {"state": logger}, params)


def set_acrobot(built: Built, context, x0) -> None:
    """Write the :func:`build_acrobot` robot's parameters and the start
    state ``x0`` (q1, q2, q1', q2') into ``context`` (the diagram's root)."""
    acrobot, p, f = built.plant, built.params.plant, built.params.friction
    own = acrobot.GetMyMutableContextFromRoot(context)
    values = acrobot.get_mutable_parameters(own)
    for name, value in (("m1", p.m1), ("m2", p.m2), ("l1", p.l1), ("lc1", p.lc1),
                        ("lc2", p.lc2), ("Ic1", p.I1), ("Ic2", p.I2), ("gravity", p.g),
                        ("b1", f.fv1 if f.enabled else 0.0),
                        ("b2", f.fv2 if f.enabled else 0.0)):
        getattr(values, f"set_{name}")(value)
    own.SetContinuousState(list(map(float, x0)))
