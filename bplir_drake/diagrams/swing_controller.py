"""The swing's controller in the diagram: a user's plug-in, the plan tracker with its landing law, or the dissertation's path generator and CPFL controller, behind the delay predictor and identifier when they are asked for."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any
from ..params import BplirParams
from ..systems.controller import CpflController
from ..systems.disturbance import delay_steps
from ..systems.delay_id import planned_probe
from .plugin import make_plugin
from ..systems.plan_tracker import ApexShot, Landing, PlanTracker, Reach
from ..systems.landing import resolved_landing
from ..systems.path_generator import PathGenerator
from ..systems.delay_id import DelayIdentifier
from ..systems.predictor import DelayPredictor


def add_swing_controller(builder, params: BplirParams, state_port, robot: Robot, path_geometry,
                         plan_gains=None, controller=None, imu_port=None,
                         q0=None) -> dict[str, Any]:
    """The swing controller, reading ``state_port`` (the estimate or the
    sampled true state): a user's (``controller``, a factory, or
    ``controller.plugin``: :mod:`.plugin`) as ``{"controller": system}``;
    by ``path.mode``,
    ``{"controller": PlanTracker}`` for
    ``"plan"`` (Drake's finite-horizon LQR along a planned swing,
    ``plan_gains``), else ``{"path": PathGenerator, "controller":
    CpflController}``, both reading the state predicted over
    ``controller.delay_compensation`` (a :class:`DelayPredictor`, also
    returned) when that is set; the plan tracker over
    ``plan.delay_compensation`` when it is not (the lab firmware's
    10 ms by default), indexing the plan as much later.  With
    ``plan.delay_probe`` (and ``imu_port``, the IMU samples, and
    ``q0``, the start pose the robot believes, :func:`believed_start`) the
    plan tracker probes the delay and a
    :class:`~bplir_drake.systems.delay_id.DelayIdentifier` (also returned,
    ``"delay_id"``) identifies it; the tracker and the predictor then
    compensate the identified delay.  Every system uses the nominal
    model."""
    if controller is not None or params.controller.plugin:
        return _add_plugin(builder, params, state_port, robot, controller, imu_port)
    comp = _add_delay_compensation(builder, params, state_port, imu_port, q0)
    if params.path.mode == "plan":
        out = _add_plan_tracker(builder, params, comp, path_geometry, plan_gains)
    else:
        out = _add_cpfl(builder, params, comp, robot, path_geometry)
    command = out["controller"].GetOutputPort("torque")
    if comp.identifier is not None and params.path.mode == "plan":
        builder.Connect(comp.identifier.GetOutputPort("delay_steps"), out["controller"].steps_port)
        builder.Connect(command, comp.identifier.command_port)
        out["delay_id"] = comp.identifier
    if comp.predictor is not None:
        builder.Connect(command, comp.predictor.command_port)
        out["predictor"] = comp.predictor
    return out


def _add_plugin(builder, params, state_port, robot, controller, imu_port) -> dict[str, Any]:
    """A user's controller (:mod:`.plugin`) reading the state, and the torque
    the motor can give and the IMU sample when it asks for them."""

    ctrl = builder.AddNamedSystem("controller", make_plugin(params, "controller", controller))
    builder.Connect(state_port, ctrl.GetInputPort("state"))
    if ctrl.HasInputPort("imu"):
        builder.Connect(imu_port, ctrl.GetInputPort("imu"))
    if ctrl.HasInputPort("torque_available"):
        builder.Connect(robot.motor.GetOutputPort("available"),
                        ctrl.GetInputPort("torque_available"))
    return {"controller": ctrl}


@dataclass
class DelayCompensation:
    """What the controller reads and how it allows for the loop's delay: the
    state port (predicted when a predictor runs), the assumed delay in ticks,
    the delay probe and the predictor and identifier (None when unused)."""
    state_port: Any
    steps: int
    probe: tuple
    predictor: Any = None
    identifier: Any = None


def _add_delay_compensation(builder, params, state_port, imu_port, q0) -> DelayCompensation:
    """The delay predictor (``controller.delay_compensation``, or for the plan
    tracker ``plan.delay_compensation``) and, with ``plan.delay_probe``
    and the IMU samples, the delay identifier feeding it."""
    comp = delay_compensation(params, state_port, imu_port is not None, q0)
    if comp.identifier is not None:
        builder.AddNamedSystem("delay_id", comp.identifier)
        builder.Connect(imu_port, comp.identifier.imu_port)
    if comp.predictor is not None:
        builder.AddNamedSystem("predictor", comp.predictor)
        if comp.identifier is not None:
            builder.Connect(comp.identifier.GetOutputPort("delay_steps"),
                            comp.predictor.steps_port)
        builder.Connect(state_port, comp.predictor.estimate_port)
        comp.state_port = comp.predictor.predicted_port
    return comp


def delay_compensation(params, state_port, with_imu: bool, q0) -> DelayCompensation:
    """The parts of :func:`_add_delay_compensation`, not yet in a diagram
    (``with_imu``: the IMU samples are there to identify the delay from)."""
    T, pp = params.controller.period, params.path
    assumed = params.controller.delay_compensation
    if pp.mode == "plan" and not assumed:
        assumed = params.plan.delay_compensation
    steps = delay_steps(assumed, T)
    probe = planned_probe(pp, params.plan, params.controller) if with_imu else ()
    comp = DelayCompensation(state_port, steps, probe)
    size = steps   # the predictor's ticks (with identification: the most it may need)
    if probe:
        size = max(delay_steps(params.plan.delay_max, T), 1)
        comp.identifier = DelayIdentifier(
            q0, params.plant, params.friction, params.motor, T,
            params.controller.compute_latency, size, min(steps, size),
            params.plan.delay_window, params.plan.delay_min_ratio)
    if size:
        comp.predictor = DelayPredictor(params.plant, params.friction, T, size,
                                        adaptive=bool(probe))
    return comp


def _add_plan_tracker(builder, params, comp: DelayCompensation, path_geometry,
                      plan_gains) -> dict[str, Any]:
    """The plan tracker (Drake's finite-horizon LQR along the planned swing)
    with its terminal law: the apex shot, the aim landing, the reach or none."""
    tracker = builder.AddNamedSystem("plan_tracker", plan_tracker(params, comp, path_geometry,
                                                                  plan_gains))
    builder.Connect(comp.state_port, tracker.GetInputPort("state"))
    return {"controller": tracker}


def plan_tracker(params, comp: DelayCompensation, path_geometry, plan_gains) -> PlanTracker:
    """The plan tracker of :func:`_add_plan_tracker`, not yet in a diagram."""
    if plan_gains is None:
        raise ValueError("path.mode = 'plan' needs the tracking gains of a planned swing: "
                         "plan_gains=tracking_plan(params)[1] (bplir_drake.planning.solve)")
    pp = params.landing
    law = pp.landing_law
    if law == "auto":   # resolved on the plan's own samples (the breaks of x0), as
        # the traversal's current budget resolves it: the two cannot disagree
        law, pp = resolved_landing(params.plant, path_geometry.alpha,
                                   plan_gains.x0.vector_values(
                                       plan_gains.x0.get_segment_times()).T, pp)
    reach = None
    if law == "shoot":
        reach = ApexShot.from_params(params.plant, params.friction, path_geometry.alpha, pp)
    elif law == "aim":
        reach = Landing.from_params(params.plant, path_geometry.alpha, pp)
    elif law == "reach":
        reach = Reach.from_params(params.plant, path_geometry.alpha, pp)
    T = params.controller.period
    return PlanTracker(plan_gains, params.controller.torque_limit, T,
                       indexing=params.plan.indexing, reach=reach, lead=comp.steps * T,
                       probe=comp.probe, adaptive_lead=comp.identifier is not None,
                       motor=params.motor)


def _add_cpfl(builder, params, comp: DelayCompensation, robot, path_geometry) -> dict[str, Any]:
    """The dissertation's loop: the path generator (chapter 7) and the CPFL +
    QFT controller (chapter 6), both reading the (predicted) state."""

    T = params.controller.period
    fv1 = params.friction.fv1 if params.path.predict_friction else 0.0
    path = builder.AddNamedSystem("path", PathGenerator(params.plant, params.path, path_geometry,
                                                        T, fv1))
    builder.Connect(comp.state_port, path.GetInputPort("state"))
    ctrl = builder.AddNamedSystem("controller", CpflController(
        params.plant, params.controller, params.friction, use_prefilter=False,
        motor=params.motor))
    builder.Connect(comp.state_port, ctrl.GetInputPort("state"))
    builder.Connect(path.GetOutputPort("reference"), ctrl.GetInputPort("reference"))
    builder.Connect(path.GetOutputPort("feedforward"), ctrl.GetInputPort("feedforward"))
    builder.Connect(robot.motor.GetOutputPort("available"), ctrl.GetInputPort("torque_available"))
    return {"path": path, "controller": ctrl}
