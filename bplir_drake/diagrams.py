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
                                        TrajectorySource, ZeroOrderHold)

from .params import BplirParams, FrictionParams, PlantParams
from .systems.controller import CpflController
from .systems.disturbance import CommandDelay, delay_steps, disturbance_schedule, has_disturbance
from .systems.ekf import KinematicEkf
from .systems.friction import JointFriction, friction_system
from .systems.imu import ImuSampler
from .systems.schedule import TickLogger
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
    q0: Any = None  # the simulated robot's start configuration (swings)

    def __getitem__(self, name):
        return self.systems[name]


def sampled(builder, port, period: float):
    """``port`` sampled at the ticks ``k period`` and held (C++
    ``ZeroOrderHold``): a discrete system of the tick schedule
    (:mod:`~bplir_drake.systems.schedule`) computes its tick result from its
    inputs, so a continuous signal it reads must be held over the tick."""
    hold = builder.AddSystem(ZeroOrderHold(period, port.size()))
    builder.Connect(port, hold.get_input_port(0))
    return hold.get_output_port(0)


def _torque_source(builder, elbow_torque):
    """A constant (float) or a schedule ``(times, values)``: ``values[i]``
    holds from ``times[i]`` until ``times[i + 1]``; the last value holds on."""
    if isinstance(elbow_torque, tuple):
        from pydrake.trajectories import PiecewisePolynomial

        times, values = (np.asarray(a, dtype=float) for a in elbow_torque)
        if times.size == 1:
            return builder.AddSystem(ConstantVectorSource([float(values[0])]))
        # Drake's zero-order hold ignores the value at the final break
        times = np.append(times, times[-1] + 1e6)
        values = np.append(values, values[-1])
        traj = PiecewisePolynomial.ZeroOrderHold(times, values.reshape(1, -1))
        return builder.AddSystem(TrajectorySource(traj))
    return builder.AddSystem(ConstantVectorSource([float(elbow_torque)]))


def add_plant_with_friction(builder, plant_params: PlantParams,
                            friction_params: FrictionParams, *, scene_graph=False,
                            disturbance=None, linearizable: bool = False):
    """Plant + friction force element wired into the applied-force port.

    ``disturbance`` (optional) is an output port of 2 generalized forces
    (e.g. wind or a knock) added to the friction force.  The friction is the
    C++ symbolic system (:func:`~bplir_drake.systems.friction.friction_system`,
    with its dissipated-energy state) for simulation, or with
    ``linearizable=True`` the templated :class:`JointFriction` (no extra
    state, converts to AutoDiffXd for ``Linearize``).
    """
    from pydrake.systems.primitives import Adder

    out = add_acrobot_plant(builder, plant_params, scene_graph=scene_graph)
    plant = out[0] if scene_graph else out
    friction = builder.AddSystem(JointFriction(friction_params) if linearizable
                                 else friction_system(friction_params))
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


def add_imus(builder, plant, params: BplirParams, seed: int):
    """Drake Gyroscope/Accelerometer on each link + the sampling/noise model."""
    from pydrake.math import RigidTransform
    from pydrake.systems.sensors import Accelerometer, Gyroscope

    sampler = builder.AddSystem(ImuSampler(params.imu, seed))
    sampler.set_name("imu")
    g = params.simulated_plant.g
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
        builder.Connect(gyro.get_measurement_output_port(), sampler.GetInputPort(f"gyro{i}"))
        builder.Connect(acc.get_measurement_output_port(), sampler.GetInputPort(f"accel{i}"))
    return sampler


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
    plant, fr = add_plant_with_friction(builder, pp, fp, linearizable=True)
    builder.ExportInput(plant.get_actuation_input_port(), "elbow_torque")
    builder.ExportOutput(plant.get_state_output_port(), "state")
    diagram = builder.Build()
    diagram.set_name("plant_with_friction")
    return Built(diagram, plant, {"friction": fr}, {}, params)


def _pulse_source(builder, knock):
    """Generalized-force pulse on joint 1: ``knock = (t_start, duration, torque)``."""
    from pydrake.trajectories import PiecewisePolynomial

    t0, dur, tq = knock
    times = np.array([0.0, t0, t0 + dur, t0 + dur + 1.0])
    vals = np.array([[0.0, tq, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]])
    return builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(times, vals)))


def build_sensor_swing(params: BplirParams, x0_estimate=(0.0, 0.0, 0.0, 0.0), *,
                       elbow_torque=0.0, knock=None, ekf: bool = True, seed: int | None = None,
                       log_period: float = 0.01) -> Built:
    """Open loop: plant + friction + two IMUs (+ EKF).

    ``elbow_torque`` as in :func:`build_free_swing`; ``knock = (t, duration,
    torque)`` applies a torque pulse on link 1 (the "knock" of 5.5).
    ``x0_estimate`` is the filter's initial absolute state.  Loggers:
    ``state``, ``imu`` (sampled IMU, at the IMU rate), ``estimate`` and
    ``covariance`` (at the filter rate) when the EKF is present.
    """
    builder = DiagramBuilder()
    seed = params.scenario.seed if seed is None else seed
    dist = _pulse_source(builder, knock).get_output_port(0) if knock else None
    plant, fr = add_plant_with_friction(builder, params.simulated_plant,
                                        params.simulated_friction, disturbance=dist)
    src = _torque_source(builder, elbow_torque)
    builder.Connect(src.get_output_port(0), plant.get_actuation_input_port())
    sampler = add_imus(builder, plant, params, seed)
    systems = {"friction": fr, "imu": sampler, "source": src}
    loggers = {"state": LogVectorOutput(plant.get_state_output_port(), builder, log_period),
               "imu": TickLogger(builder, sampler.get_output_port(0), params.imu.period)}
    if ekf:
        est = builder.AddSystem(KinematicEkf(params.estimator, x0_estimate))
        est.set_name("ekf")
        builder.Connect(sampler.get_output_port(0), est.get_input_port(0))
        systems["ekf"] = est
        for name, port in (("estimate", "estimate"), ("covariance", "covariance_diagonal"),
                           ("bias", "gyro_bias")):
            loggers[name] = TickLogger(builder, est.GetOutputPort(port), params.estimator.period)
    diagram = builder.Build()
    diagram.set_name("sensor_swing")
    return Built(diagram, plant, systems, loggers, params)


def build_cpfl_plant(params: BplirParams) -> Built:
    """Simulated plant + friction behind the *nominal* CPFL inner loop, with
    the outer-loop signal ``v`` as the diagram input and the plant state as
    output: linearising it from v to q2 gives the plant family the outer loop
    is designed for (4.7)."""
    from dataclasses import replace

    builder = DiagramBuilder()
    plant, fr = add_plant_with_friction(builder, params.simulated_plant,
                                        params.simulated_friction, linearizable=True)
    ctrl = replace(params.controller, k_num=(0.0,), k_den=(1.0,), f_num=(1.0,), f_den=(1.0,),
                   aw_gain=0.0, sign_correct=False, torque_limit=1e9)
    c = builder.AddSystem(CpflController(params.plant, ctrl, params.friction, continuous=True))
    c.set_name("cpfl")
    builder.Connect(plant.get_state_output_port(), c.GetInputPort("state"))
    builder.Connect(builder.AddSystem(ConstantVectorSource([0.0])).get_output_port(0),
                    c.GetInputPort("reference"))
    builder.Connect(builder.AddSystem(ConstantVectorSource([1e9])).get_output_port(0),
                    c.GetInputPort("torque_available"))
    builder.ExportInput(c.GetInputPort("feedforward"), "v")
    builder.Connect(c.GetOutputPort("torque"), plant.get_actuation_input_port())
    builder.ExportOutput(plant.get_state_output_port(), "state")
    diagram = builder.Build()
    diagram.set_name("cpfl_plant")
    return Built(diagram, plant, {"friction": fr, "controller": c}, {}, params)


def build_control_loop(params: BplirParams, reference=0.0, *, continuous: bool = False,
                       motor: bool = False, torque_limit: float | None = None,
                       input_disturbance=None, log_period: float = 0.002) -> Built:
    """Closed loop on the true state: plant + friction + CPFL/outer loop
    (nominal parameters) tracking ``reference`` (float or (times, values)
    zero-order-hold schedule of q2_ref).  ``motor=True`` puts the motor and
    driver between controller and plant (and feeds its deliverable torque
    back for anti-windup); otherwise the controller's torque is applied
    directly.  ``input_disturbance`` is an elbow-torque schedule (times,
    values) added to the applied torque.
    ``continuous=True`` builds the continuous-time controller (the loop can
    then be linearised; with the reference exported as input ``reference``
    when ``reference`` is None)."""
    from dataclasses import replace

    from pydrake.systems.primitives import Adder

    builder = DiagramBuilder()
    plant, fr = add_plant_with_friction(builder, params.simulated_plant,
                                        params.simulated_friction, linearizable=continuous)
    ctrl = params.controller if torque_limit is None else replace(params.controller,
                                                                  torque_limit=torque_limit)
    c = builder.AddSystem(CpflController(params.plant, ctrl, params.friction,
                                         continuous=continuous))
    c.set_name("controller")

    def held(port):  # the discrete controller reads its inputs at its ticks
        return port if continuous else sampled(builder, port, ctrl.period)

    builder.Connect(held(plant.get_state_output_port()), c.GetInputPort("state"))
    if reference is None:
        builder.ExportInput(c.GetInputPort("reference"), "reference")
    else:
        src = _torque_source(builder, reference)
        src.set_name("reference")
        builder.Connect(held(src.get_output_port(0)), c.GetInputPort("reference"))
    builder.Connect(held(builder.AddSystem(ConstantVectorSource([0.0])).get_output_port(0)),
                    c.GetInputPort("feedforward"))
    torque = c.GetOutputPort("torque")
    systems = {"friction": fr, "controller": c}
    if motor:
        drv = builder.AddSystem(MotorDriver(replace(params.motor, torque_limit=ctrl.torque_limit)))
        drv.set_name("motor")
        builder.Connect(torque, drv.GetInputPort("torque_command"))
        builder.Connect(plant.get_state_output_port(), drv.GetInputPort("state"))
        builder.Connect(drv.GetOutputPort("available"), c.GetInputPort("torque_available"))
        torque = drv.GetOutputPort("torque")
        systems["motor"] = drv
    else:
        builder.Connect(held(builder.AddSystem(ConstantVectorSource([ctrl.torque_limit]))
                             .get_output_port(0)), c.GetInputPort("torque_available"))
    if input_disturbance is not None:
        dist = _torque_source(builder, input_disturbance)
        add = builder.AddSystem(Adder(2, 1))
        builder.Connect(torque, add.get_input_port(0))
        builder.Connect(dist.get_output_port(0), add.get_input_port(1))
        torque = add.get_output_port(0)
    builder.Connect(torque, plant.get_actuation_input_port())
    builder.ExportOutput(plant.get_state_output_port(), "state")
    loggers = {"state": LogVectorOutput(plant.get_state_output_port(), builder, log_period),
               "torque": LogVectorOutput(torque, builder, log_period),
               "v": LogVectorOutput(c.GetOutputPort("v"), builder, log_period),
               "torque_unsaturated": LogVectorOutput(c.GetOutputPort("torque_unsaturated"),
                                                     builder, log_period)}
    diagram = builder.Build()
    diagram.set_name("control_loop")
    return Built(diagram, plant, systems, loggers, params)


def swing_geometry(params: BplirParams):
    """(initial q, target q, path geometry, line geometry) of the scenario,
    from the *nominal* link lengths (what the robot believes) -- the start
    pose of the simulated robot uses its true lengths."""
    import math

    from .systems.gripper import LineGeometry
    from .systems.path import PathGeometry
    from .systems.plant import initial_configuration, target_configuration

    sc = params.scenario
    alpha = math.radians(sc.incline_deg)
    true_p = params.simulated_plant
    q0 = initial_configuration(sc.grip_spacing, true_p, alpha)
    qT = target_configuration(sc.grip_spacing, true_p, alpha)
    initial_configuration(sc.grip_spacing, params.plant, alpha)  # validates for the model too
    pg = PathGeometry.from_scenario(params.plant, sc.grip_spacing, alpha, sc.capture_distance)
    lg = LineGeometry(true_p.l1, true_p.l2, alpha, sc.grip_spacing)
    return q0, qT, pg, lg


def build_swing(params: BplirParams, *, seed: int | None = None, use_estimator: bool | None = None,
                log_period: float = 0.005, plan_gains=None) -> Built:
    """The full closed loop of one swing.

    True (possibly perturbed) plant + friction + disturbances (wind, gusts,
    torque noise; :mod:`~bplir_drake.systems.disturbance`), an optional
    actuation delay, motor/driver, two IMUs,
    kinematic EKF (nominal geometry), path generator and CPFL controller
    (nominal plant), gripper interlock (true contact sensing), loggers.  With
    ``use_estimator=False`` the path and controller read the true state
    (sampled at their tick) instead of the estimate.

    With ``path.mode = "plan"`` the path generator and CPFL controller are
    replaced by a :class:`~bplir_drake.systems.plan_tracker.PlanTracker`
    built from ``plan_gains`` (Drake's finite-horizon LQR result along a
    planned swing, :func:`bplir_drake.analysis.swing_plan.tracking_plan`).
    """
    from dataclasses import replace

    from .systems.gripper import GripperInterlock
    from .systems.path import PathGenerator
    from .systems.plant import absolute_from_relative

    sc = params.scenario
    seed = sc.seed if seed is None else seed
    use_est = sc.use_estimator if use_estimator is None else use_estimator
    q0, _, pg, lg = swing_geometry(params)
    builder = DiagramBuilder()
    wind = None
    if has_disturbance(sc):  # wind, gusts, torque noise: one seeded schedule
        from pydrake.trajectories import PiecewisePolynomial

        times, torques = disturbance_schedule(sc, seed, params.controller.period)
        wind = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(
            np.append(times, times[-1] + 1e6), np.vstack([torques, torques[-1]]).T)))
        wind.set_name("disturbance")
        wind = wind.get_output_port(0)
    plant, fr = add_plant_with_friction(builder, params.simulated_plant,
                                        params.simulated_friction, disturbance=wind)
    ctrl_p = params.controller
    motor = builder.AddSystem(MotorDriver(replace(params.motor,
                                                  torque_limit=min(params.motor.torque_limit,
                                                                   ctrl_p.torque_limit))))
    motor.set_name("motor")
    builder.Connect(plant.get_state_output_port(), motor.GetInputPort("state"))
    builder.Connect(motor.GetOutputPort("torque"), plant.get_actuation_input_port())
    sampler = add_imus(builder, plant, params, seed)
    est = params.estimator.for_loop()
    x0_abs = absolute_from_relative(np.array([q0[0], q0[1], 0.0, 0.0]))
    ekf = builder.AddSystem(KinematicEkf(est, x0_abs,
                                         sigmas=(est.start_angle_sigma, est.start_rate_sigma,
                                                 est.start_bias_sigma)))
    ekf.set_name("ekf")
    builder.Connect(sampler.get_output_port(0), ekf.get_input_port(0))
    T = ctrl_p.period
    state_port = (ekf.GetOutputPort("estimate_relative") if use_est
                  else sampled(builder, plant.get_state_output_port(), T))
    if params.path.mode == "plan":
        from .systems.plan_tracker import PlanTracker

        if plan_gains is None:
            raise ValueError("path.mode = 'plan' needs the tracking gains of a planned swing")
        ctrl = path = builder.AddSystem(PlanTracker(plan_gains, ctrl_p.torque_limit, T,
                                                    indexing=params.path.plan_indexing))
        ctrl.set_name("plan_tracker")
        builder.Connect(state_port, ctrl.get_input_port(0))
    else:
        fv1 = params.friction.fv1 if params.path.predict_friction else 0.0
        path = builder.AddSystem(PathGenerator(params.plant, params.path, pg, T, fv1))
        path.set_name("path")
        builder.Connect(state_port, path.get_input_port(0))
        ctrl = builder.AddSystem(CpflController(params.plant, ctrl_p, params.friction,
                                                use_prefilter=False))
        ctrl.set_name("controller")
        builder.Connect(state_port, ctrl.GetInputPort("state"))
        builder.Connect(path.GetOutputPort("reference"), ctrl.GetInputPort("reference"))
        builder.Connect(path.GetOutputPort("feedforward"), ctrl.GetInputPort("feedforward"))
        builder.Connect(motor.GetOutputPort("available"), ctrl.GetInputPort("torque_available"))
    command = ctrl.GetOutputPort("torque")
    steps = delay_steps(sc.actuation_delay, ctrl_p.period)
    if steps:
        delay = builder.AddSystem(CommandDelay(1, ctrl_p.period, steps))
        delay.set_name("actuation_delay")
        builder.Connect(command, delay.get_input_port(0))
        command = delay.get_output_port(0)
    if ctrl_p.compute_latency > 0:  # the command reaches the driver this long after the sample
        hold = builder.AddNamedSystem("compute_latency", ZeroOrderHold(T, 1, ctrl_p.compute_latency))
        builder.Connect(command, hold.get_input_port(0))
        command = hold.get_output_port(0)
    builder.Connect(command, motor.GetInputPort("torque_command"))
    lock = builder.AddSystem(GripperInterlock(lg, sc, T))
    lock.set_name("interlock")
    builder.Connect(plant.get_state_output_port(), lock.GetInputPort("state"))
    builder.Connect(motor.GetOutputPort("tripped"), lock.GetInputPort("tripped"))
    builder.Connect(ekf.GetOutputPort("estimate_relative"), lock.GetInputPort("estimate"))
    builder.Connect(motor.GetOutputPort("torque"), lock.GetInputPort("torque"))
    loggers = {
        "state": LogVectorOutput(plant.get_state_output_port(), builder, log_period),
        "torque": LogVectorOutput(motor.GetOutputPort("torque"), builder, log_period),
        "power": LogVectorOutput(motor.GetOutputPort("power"), builder, log_period),
        "current": LogVectorOutput(motor.GetOutputPort("current"), builder, log_period),
        "friction": LogVectorOutput(fr.get_output_port(0), builder, log_period),
        "estimate": TickLogger(builder, ekf.GetOutputPort("estimate_relative"), T),
        "command": TickLogger(builder, ctrl.GetOutputPort("torque"), T),
        "reference": TickLogger(builder, path.GetOutputPort("reference"), T),
        "imu": TickLogger(builder, sampler.get_output_port(0), params.imu.period),
    }
    if params.path.mode != "plan":
        loggers["v"] = TickLogger(builder, ctrl.GetOutputPort("v"), T)
        loggers["blend_end"] = TickLogger(builder, path.GetOutputPort("blend_end"), T)
    diagram = builder.Build()
    diagram.set_name("brachiation_swing")
    systems = {"friction": fr, "motor": motor, "imu": sampler, "ekf": ekf, "path": path,
               "controller": ctrl, "interlock": lock}
    return Built(diagram, plant, systems, loggers, params, q0)


def build_cpfl_step(params: BplirParams, v_schedule, log_period: float = 0.002) -> Built:
    """Step tests of the CPFL loop (4.7): simulated plant + friction + motor,
    the *discrete* nominal CPFL controller with no outer loop (K = 0, F = 1)
    and the outer-loop signal ``v`` from a schedule (times, values)."""
    from dataclasses import replace

    builder = DiagramBuilder()
    plant, fr = add_plant_with_friction(builder, params.simulated_plant,
                                        params.simulated_friction)
    ctrl = replace(params.controller, k_num=(0.0,), k_den=(1.0,), f_num=(1.0,), f_den=(1.0,),
                   aw_gain=0.0, sign_correct=False)
    c = builder.AddSystem(CpflController(params.plant, ctrl, params.friction))
    motor = builder.AddSystem(MotorDriver(params.motor))
    T = params.controller.period
    builder.Connect(sampled(builder, plant.get_state_output_port(), T), c.GetInputPort("state"))
    builder.Connect(sampled(builder, builder.AddSystem(ConstantVectorSource([0.0]))
                            .get_output_port(0), T), c.GetInputPort("reference"))
    builder.Connect(sampled(builder, _torque_source(builder, v_schedule).get_output_port(0), T),
                    c.GetInputPort("feedforward"))
    builder.Connect(motor.GetOutputPort("available"), c.GetInputPort("torque_available"))
    builder.Connect(c.GetOutputPort("torque"), motor.GetInputPort("torque_command"))
    builder.Connect(plant.get_state_output_port(), motor.GetInputPort("state"))
    builder.Connect(motor.GetOutputPort("torque"), plant.get_actuation_input_port())
    loggers = {"state": LogVectorOutput(plant.get_state_output_port(), builder, log_period)}
    diagram = builder.Build()
    diagram.set_name("cpfl_step")
    return Built(diagram, plant, {"controller": c, "motor": motor}, loggers, params)
