"""The full closed loop of one swing, composed from named builders.

:func:`build_swing` wires, in this order:

1. :func:`add_robot` -- the simulated plant with friction, the external
   forces (wind, gusts, torque noise) and the motor/driver;
2. :func:`add_sensing` -- two IMUs and the kinematic EKF (nominal geometry),
   or a user's estimator (:mod:`.plugin`);
3. :func:`add_swing_controller` -- by ``path.mode``: the path generator and
   CPFL controller, or the plan tracker;
4. :func:`add_actuation` -- actuation delay and compute latency between the
   command and the driver;
5. :func:`add_interlock` -- the gripper interlock (true contact sensing);
6. :func:`add_swing_loggers`.

Every sampled system runs on the one tick of
:mod:`~bplir_drake.systems.schedule` (period ``controller.period``).

**Samples in the context.**  What a Monte Carlo sample draws for the
simulated robot and its world -- the links' inertial parameters, the
friction coefficients, the IMUs' error model, wind and gusts, and the seed
of every random draw -- is held in the context (:data:`SAMPLE_FIELDS`), so
one built diagram runs many samples: :func:`set_swing_sample` writes a
sample into a context.  The rest (link lengths, the friction's smoothing
and drag, whether there are disturbances at all, incline, grip spacing,
actuation delay, the nominal model and controller) is the diagram's
*structure* (:func:`swing_structure`); a sample with another structure
needs its own build.
"""
from __future__ import annotations

import json
from dataclasses import replace
from typing import Any

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, ZeroOrderHold

from ..params import BplirParams, ParameterError, ScenarioParams, checked_seed, to_dict
from ..systems.disturbance import (CommandDelay, DisturbanceSource, add_pulses, delay_steps,
                                   disturbance_schedule, has_disturbance)
from ..systems.action import ActionTorque
from ..systems.ekf import KinematicEkf
from ..systems.friction import FRICTION_PARAMETERS, set_friction
from ..systems.motor import MotorDriver
from ..systems.plant import INERTIAL_FIELDS, set_inertial_parameters
from ..systems.schedule import TickColumns, TickLogger
from .parts import Built, Robot, add_plant_with_friction, sampled, torque_limit
from .swing_controller import (
    add_swing_controller)
from ..systems.gripper import GripperInterlock
from .swing_ports import add_action_input, add_external_torque, export_swing_ports
from ..planning.solve import tracking_plan
from .onboard_chain import add_onboard, fuses
from .sensors import add_sensing
from ..systems.onboard import OnboardComputer
from .swing_setup import standstill_calibration, swing_setup

#: the parameter fields a context carries (:func:`set_swing_sample`), by
#: block (the disturbance fields only when the built swing has disturbances)
SAMPLE_FIELDS: dict[str, tuple[str, ...]] = {
    "true_plant": INERTIAL_FIELDS,
    "true_friction": FRICTION_PARAMETERS,
    "imu": ("accel_sigma", "gyro_sigma", "gyro_bias1", "gyro_bias2", "gyro_drift", "misalign1",
            "misalign2", "accel_scale1", "accel_scale2", "gyro_scale1", "gyro_scale2", "noise"),
    "line_sensor": ("sigma", "offset"),
    "scenario": ("seed", "friction_uncertainty", "wind_torque1", "wind_torque2", "gust_torque",
                 "gust_rate", "gust_duration", "torque_noise"),
}


def swing_structure(params: BplirParams, use_estimator: bool, forces: bool = False) -> str:
    """What a context cannot change on a swing built from ``params``: a
    canonical JSON text of every parameter outside :data:`SAMPLE_FIELDS`
    (and whether the estimator is in the loop), with ``path.mode``
    resolved; ``forces``: a disturbance source whatever the scenario's
    (knocks are added to its schedule).  Two parameter sets with the same
    structure run through one built diagram."""
    return json.dumps(_structure(params, use_estimator, forces), sort_keys=True)


def _structure(params: BplirParams, use_estimator: bool, forces: bool = False) -> dict:
    params = params.resolved()
    d = to_dict(params.with_(true_plant=params.simulated_plant,
                             true_friction=params.simulated_friction))
    for block, fields in SAMPLE_FIELDS.items():
        for name in fields:
            d[block].pop(name, None)
    return {"params": d, "use_estimator": bool(use_estimator),
            "disturbance": bool(forces or has_disturbance(params.scenario))}


def _built_flags(built: Built) -> tuple[bool, bool]:
    """(use_estimator, forced disturbance source) of a built swing."""
    d = json.loads(built.structure)
    return d["use_estimator"], d["disturbance"]


def _changed(built: Built, params: BplirParams, use_estimator: bool) -> list[str]:
    """The fields (``block.field``) in which ``params`` differ from the ones
    ``built`` was built from, outside :data:`SAMPLE_FIELDS`."""
    ours = _structure(params, use_estimator, _built_flags(built)[1])
    theirs = json.loads(built.structure)
    out = [k for k in ("use_estimator", "disturbance") if ours[k] != theirs[k]]
    a, b = json.loads(json.dumps(ours["params"])), theirs["params"]
    for block in sorted(set(a) | set(b)):
        fa, fb = a.get(block, {}), b.get(block, {})
        if not isinstance(fa, dict) or not isinstance(fb, dict):
            out += [block] if fa != fb else []
            continue
        out += [f"{block}.{f}" for f in sorted(set(fa) | set(fb)) if fa.get(f) != fb.get(f)]
    return out


def set_swing_sample(built: Built, context, params: BplirParams, seed: int,
                     structure: str | None = None, pulses=()) -> None:
    """Write the sample ``(params, seed)`` into ``context``, a root context
    of ``built.diagram`` (a :func:`build_swing` diagram): the simulated
    links' inertial parameters, its friction, the IMUs' error model and noise
    seed, and the disturbance schedule.  Raises ``ValueError`` when
    ``params`` differ from the built ones outside :data:`SAMPLE_FIELDS`
    (``structure``: their :func:`swing_structure`, when the caller has it),
    and ``ParameterError`` unless ``seed`` is a whole number in [0, 2^32).
    ``pulses``: torque pulses added to the disturbance (:func:`set_pulses`)."""
    seed = checked_seed(seed)
    if structure is None:
        structure = swing_structure(params, *_built_flags(built))
    if structure != built.structure:
        changed = _changed(built, params, _built_flags(built)[0])
        raise ValueError(f"this sample changes {', '.join(changed[:4]) or 'the structure'}, "
                         "more than the context carries (its fields of "
                         f"{', '.join(SAMPLE_FIELDS)}); build its own swing diagram")
    set_inertial_parameters(built.plant, context, params.simulated_plant)
    set_friction(built.systems["friction"], context, params.simulated_friction)
    built.systems["imu"].set_sensor(context, params.imu, seed)
    if "line_sensor" in built.systems:
        built.systems["line_sensor"].set_sensor(context, params.line_sensor, seed)
    if "ekf" in built.systems:  # a user's estimator calibrates itself, or not
        built.systems["ekf"].set_calibration(context,
                                             standstill_calibration(params, built.q0, seed))
    if "disturbance" in built.systems:
        set_pulses(built, context, params, seed, pulses)


def set_pulses(built: Built, context, params: BplirParams, seed: int, pulses) -> None:
    """The disturbance of the sample ``(params, seed)`` with the torque
    ``pulses`` ``[(start s, (tau1, tau2) N m, duration s)]`` added (knocks,
    :func:`~bplir_drake.systems.disturbance.add_pulses`) in ``context`` of a
    swing built with a disturbance source (``disturbance=True``)."""
    if "disturbance" not in built.systems:
        raise ValueError("this swing has no disturbance source; build it with disturbance=True")
    period = params.controller.period
    torques = add_pulses(_disturbance_torques(params.scenario, seed, period), period, pulses)
    built.systems["disturbance"].set_schedule(context, torques)


def _disturbance_torques(sc: ScenarioParams, seed: int, period: float) -> np.ndarray:
    return disturbance_schedule(sc, seed, period)[1]


def _swing_inputs(params, controller, estimator, plan_gains, action_input):
    """(parameters, controller, estimator, plan gains) a swing is built
    from: plug-in specs moved into the parameters, ``path.mode`` made
    concrete (a user's controller: "adaptive"), a start off the line
    refused without plan tracking, the plan's gains where it tracks one."""
    if action_input:
        controller = _no_controller(params, controller)
    if isinstance(controller, str):  # a spec travels in the parameters
        params, controller = params.with_controller(controller), None
    if isinstance(estimator, str):
        params, estimator = params.with_estimator(estimator), None
    if controller is not None and params.path.mode == "auto":   # a user's controller
        params = params.with_(path=replace(params.path, mode="adaptive"))
    params = params.resolved()   # path.mode "auto" made concrete
    if params.scenario.start != "line" and (controller is not None or params.path.mode != "plan"):
        raise ParameterError(f"scenario.start = '{params.scenario.start}' needs plan tracking "
                             "(path.mode = 'plan'): the other controllers start on the line")
    if plan_gains is None and controller is None and params.path.mode == "plan":
        plan_gains = tracking_plan(params)[1]   # the nominal model and the scenario only
    return params, controller, estimator, plan_gains


def _no_controller(params: BplirParams, controller):
    """What stands for the controller of a diagram with an ``action``
    input (never built: it takes a user's controller's place), or
    ``ParameterError`` where a controller is given too."""
    if controller is not None or params.controller.plugin:
        raise ParameterError("action_input replaces the controller; give no controller "
                             "plug-in with it")
    return ActionTorque


def add_robot(builder, params: BplirParams, seed: int, external_torque: bool = False,
              disturbance: bool = False) -> Robot:
    """The simulated (true) plant with friction, the external forces of the
    scenario (a :class:`DisturbanceSource`, when it has wind, gusts or torque
    noise, or with ``disturbance``) and, with ``external_torque``, of the diagram's ``external_torque``
    input (:mod:`.swing_ports`), and the motor and driver (its limit the
    smaller of the motor's and the controller's) driving the elbow."""
    period = params.controller.period
    dist = None
    if disturbance or has_disturbance(params.scenario):
        dist = builder.AddNamedSystem("disturbance", DisturbanceSource(
            _disturbance_torques(params.scenario, seed, period), period))
    forces = dist.force_port if dist else None
    if external_torque:
        forces = add_external_torque(builder, forces)
    plant, friction = add_plant_with_friction(builder, params.simulated_plant,
                                              params.simulated_friction, disturbance=forces,
                                              friction_in_context=True)
    limit = torque_limit(params)
    motor = builder.AddNamedSystem("motor", MotorDriver(replace(params.motor, torque_limit=limit)))
    builder.Connect(plant.get_state_output_port(), motor.GetInputPort("state"))
    builder.Connect(motor.GetOutputPort("torque"), plant.get_actuation_input_port())
    return Robot(plant, friction, dist, motor)


def add_actuation(builder, params: BplirParams, command, motor) -> None:
    """The command's way to the driver: the scenario's actuation delay (whole
    ticks, :class:`CommandDelay`) and the controller's compute latency (a C++
    zero-order hold ``compute_latency`` after each tick)."""
    T = params.controller.period
    steps = delay_steps(params.scenario.actuation_delay, T)
    if steps:
        delay = builder.AddNamedSystem("actuation_delay", CommandDelay(1, T, steps))
        builder.Connect(command, delay.get_input_port(0))
        command = delay.get_output_port(0)
    latency = params.controller.compute_latency
    if latency > 0:
        hold = builder.AddNamedSystem("compute_latency", ZeroOrderHold(T, 1, latency))
        builder.Connect(command, hold.get_input_port(0))
        command = hold.get_output_port(0)
    builder.Connect(command, motor.GetInputPort("torque_command"))


def add_interlock(builder, params: BplirParams, robot: Robot, estimate_port, line_geometry):
    """The gripper interlock: judges the true state at the controller rate
    and ends the run on an outcome (``estimate_port``: what the robot
    believes, for its record)."""

    lock = builder.AddNamedSystem("interlock", GripperInterlock(
        line_geometry, params.scenario, params.controller.period, params.gripper))
    builder.Connect(robot.plant.get_state_output_port(), lock.GetInputPort("state"))
    builder.Connect(robot.motor.GetOutputPort("tripped"), lock.GetInputPort("tripped"))
    builder.Connect(estimate_port, lock.GetInputPort("estimate"))
    builder.Connect(robot.motor.GetOutputPort("torque"), lock.GetInputPort("torque"))
    return lock


def add_swing_loggers(builder, params: BplirParams, robot: Robot, sampler, estimate_port,
                      control: dict[str, Any], log_period: float) -> dict[str, Any]:
    """Continuous signals every ``log_period``; sampled ones at their ticks."""
    T = params.controller.period
    motor, ctrl = robot.motor, control["controller"]
    source = control.get("path", ctrl)
    reference = source.GetOutputPort("reference") if source.HasOutputPort("reference") else None
    loggers = {
        "state": LogVectorOutput(robot.plant.get_state_output_port(), builder, log_period),
        "torque": LogVectorOutput(motor.GetOutputPort("torque"), builder, log_period),
        "power": LogVectorOutput(motor.GetOutputPort("power"), builder, log_period),
        "current": LogVectorOutput(motor.GetOutputPort("current"), builder, log_period),
        "voltage": LogVectorOutput(motor.GetOutputPort("voltage"), builder, log_period),
        "electrical_power": LogVectorOutput(motor.GetOutputPort("electrical_power"), builder,
                                            log_period),
        "tripped": LogVectorOutput(motor.GetOutputPort("tripped"), builder, log_period),
        "friction": LogVectorOutput(robot.friction.get_output_port(0), builder, log_period),
    }
    if isinstance(ctrl, OnboardComputer):   # its tick's signals in one logger
        record = TickLogger(builder, ctrl.GetOutputPort("record"), T)
        loggers.update({name: TickColumns(record, columns)
                        for name, columns in ctrl.record_columns().items()})
        return loggers
    loggers.update({
        "estimate": TickLogger(builder, estimate_port, T),
        "command": TickLogger(builder, ctrl.GetOutputPort("torque"), T),
        "imu": TickLogger(builder, sampler.GetOutputPort("imu"), params.imu.period)})
    if reference is not None:
        loggers["reference"] = TickLogger(builder, reference, T)
    if "delay_id" in control:
        loggers["delay_fit"] = TickLogger(builder, control["delay_id"].GetOutputPort("fit"), T)
    if "path" in control:
        loggers["v"] = TickLogger(builder, ctrl.GetOutputPort("v"), T)
        loggers["blend_end"] = TickLogger(builder, control["path"].GetOutputPort("blend_end"), T)
    return loggers


def build_swing(params: BplirParams, *, seed: int | None = None, use_estimator: bool | None = None,
                log_period: float = 0.005, plan_gains=None, controller=None,
                estimator=None, external_torque: bool = False,
                estimate_input: bool = False, onboard: bool = True,
                action_input: bool = False, disturbance: bool = False) -> Built:
    """The full closed loop of one swing (see the module docstring).

    ``seed`` (default ``scenario.seed``) seeds the IMU noise and the
    disturbances; with ``use_estimator=False`` the controller reads the true
    state sampled at its tick instead of the estimate; ``plan_gains`` are
    the tracking gains of a planned swing for ``path.mode = "plan"``
    (default: those of :func:`bplir_drake.planning.solve.tracking_plan`,
    from the nominal model and the scenario).
    ``controller`` / ``estimator``: your own (:mod:`.plugin`), a factory
    ``factory(nominal params) -> System`` or a ``"module:factory"`` spec,
    instead of the parameters' ones.  ``external_torque`` and
    ``estimate_input`` give the diagram those input ports (:mod:`.swing_ports`:
    a disturbance added to the joints, the estimate the controller reads);
    its outputs are always :data:`~.swing_ports.SWING_SIGNALS`.
    ``action_input``: no controller but the diagram's ``action`` input, the
    elbow command as a share of the torque limit
    (:class:`~bplir_drake.systems.action.ActionTorque`: a learning
    environment's action).  ``disturbance``: a disturbance source even
    where the scenario has none (knocks: :func:`set_pulses`).  With
    ``onboard`` (the default) the EKF-and-plan-tracker chain runs as one
    system (:mod:`~bplir_drake.diagrams.onboard_chain`: the same numbers as its
    parts wired one by one, ``onboard=False``, in less time).  The
    returned record carries the start configuration ``q0`` and the
    ``structure`` a context cannot change (:func:`set_swing_sample`).
    """
    params, controller, estimator, plan_gains = _swing_inputs(
        params, controller, estimator, plan_gains, action_input)
    sc = params.scenario
    seed = sc.seed if seed is None else seed
    use_est = sc.use_estimator if use_estimator is None else use_estimator
    setup = swing_setup(params)   # poses, geometry: computed once for every builder
    q0 = setup.q0
    builder = DiagramBuilder()
    robot = add_robot(builder, params, seed, external_torque, disturbance)
    custom = (controller is not None or estimator is not None or estimate_input
              or bool(params.controller.plugin or params.estimator.plugin))
    if onboard and fuses(params, use_est, custom):
        sampler, control = add_onboard(builder, params, robot, setup, seed, plan_gains)
        est, estimate_port = sampler, sampler.GetOutputPort("estimate_relative")
    else:
        sampler, est, estimate_port = add_sensing(builder, params, robot, setup, seed,
                                                  estimator, estimate_input)
        state_port = (estimate_port if use_est
                      else sampled(builder, robot.plant.get_state_output_port(),
                                   params.controller.period))
        control = (add_action_input(builder, params, state_port) if action_input else
                   add_swing_controller(builder, params, state_port, robot, setup.path,
                                        plan_gains, controller,
                                        imu_port=sampler.GetOutputPort("imu"),
                                        q0=setup.believed[:2]))
    add_actuation(builder, params, control["controller"].GetOutputPort("torque"), robot.motor)
    lock = add_interlock(builder, params, robot, estimate_port, setup.line)
    loggers = add_swing_loggers(builder, params, robot, sampler, estimate_port, control,
                                log_period)
    export_swing_ports(builder, robot, estimate_port, control["controller"],
                       sampler.GetOutputPort("imu"))
    # the default context starts the swing: the plant at the start pose (the
    # sample's friction, sensors, calibration and gusts are the built defaults)
    robot.plant.SetDefaultPositions(np.asarray(q0, dtype=float))
    diagram = builder.Build()
    diagram.set_name("brachiation_swing")
    systems = {"friction": robot.friction, "motor": robot.motor, "imu": sampler,
               "ekf" if isinstance(est, (KinematicEkf, OnboardComputer)) else "estimator": est,
               **control, "interlock": lock}
    if robot.disturbance is not None:
        systems["disturbance"] = robot.disturbance
    if diagram.HasSubsystemNamed("line_sensor"):
        systems["line_sensor"] = diagram.GetSubsystemByName("line_sensor")
    return Built(diagram, robot.plant, systems, loggers, params, q0,
                 swing_structure(params, use_est, disturbance))
