"""After a swing that did not arrive (a timeout, a driver trip): the robot hangs from its
holding gripper, drains the swing with the elbow until it hangs at rest,
and swings again from there.

:func:`damp` simulates the hanging robot (the true plant and friction)
under the elbow's damping law of :func:`~bplir_drake.diagrams.open_loop.
build_damping` (``traverse.recover_kp``, ``recover_kd``, ``recover_lean``)
from the state the timed-out swing ended in, in steps of a second, until
the energy above hanging at rest falls below ``traverse.recover_energy``
(damped) or ``traverse.recover_limit`` has passed, or the energy grows
beyond where it began (the law pumping instead of draining: given up).
:func:`retry_params` is the swing tried again: from hanging
(``scenario.start``), with ``traverse.retry_max_time``.
"""
from __future__ import annotations

import dataclasses as dc
import math
from dataclasses import dataclass

import numpy as np

from ...params import BplirParams, ParameterError
from ...params.plan import MAX_LANDING_BIAS
from ...diagrams.plan import hanging_planned, i2t_allowance, planned_i2t, scenario_plan
from ...simulate import make_simulator, run
from ...systems.plant import initial_configuration, kinetic_energy, potential_energy
from ...diagrams.open_loop import build_damping


@dataclass
class Damping:
    """The damping after a timeout or a driver trip: ``damped`` (came to rest within the
    limit), its duration (s), the energy above hanging at rest at its start
    and end (J), the state it ended in (its angles wrapped to [-pi, pi): the
    same pose, as the IMUs read it) and its logs (times, states, torque)."""

    damped: bool
    duration: float
    energy_start: float
    energy_end: float
    state: np.ndarray
    t: np.ndarray
    states: np.ndarray
    torque: np.ndarray


def swing_energy(x, p) -> float:
    """Energy (J) of the state ``x`` above hanging at rest, robot ``p``."""
    q, v = np.asarray(x[:2], float), np.asarray(x[2:4], float)
    return float(kinetic_energy(q, v, p) + potential_energy(q, p)
                 - potential_energy(np.zeros(2), p))


def damp(params: BplirParams, x0) -> Damping:
    """Drain the swing of the robot of ``params`` (its simulated plant),
    hanging from the holding gripper in state ``x0``, with the elbow's
    damping law (:mod:`module docs <.recovery>`)."""
    tp = params.traverse
    built = build_damping(params, tp.recover_kp, tp.recover_kd, tp.recover_lean)
    x0 = np.asarray(x0, dtype=float)
    sim = make_simulator(built, x0[:2], x0[2:], accuracy=1e-6)
    plant = built.plant
    pctx = plant.GetMyContextFromRoot(sim.get_context())
    true_p = params.simulated_plant
    e0 = energy = swing_energy(x0, true_p)
    t = 0.0
    while energy > tp.recover_energy and t < tp.recover_limit and energy <= 1.1 * e0 + 0.1:
        run(sim, min(1.0, tp.recover_limit - t))
        t = sim.get_context().get_time()
        energy = swing_energy(plant.GetPositionsAndVelocities(pctx), true_p)
    ctx = sim.get_context()
    st = built.loggers["state"].FindLog(ctx)
    tq = built.loggers["torque"].FindLog(ctx)
    end = plant.GetPositionsAndVelocities(pctx).copy()
    end[:2] = (end[:2] + np.pi) % (2.0 * np.pi) - np.pi
    return Damping(energy <= tp.recover_energy, t, e0, energy, end,
                   st.sample_times(), st.data().T, tq.data()[0])


#: a try from hanging ends at the line when, in the robot's end pose on a
#: level line at its own grip spacing, its free link stands within this
#: angle of upright: turning it there lifts the gripper at less than half the
#: speed it moves it (sin 30 deg), so the landing shot cannot make up a pump
#: that falls short of a plan ending below the line
UPRIGHT_FREE_LINK = math.radians(30.0)


def free_link_tilt(p: BplirParams, spacing: float | None = None) -> float:
    """How far (rad) the free link of the robot ``p`` describes stands from
    upright in its end pose on a level line at ``spacing`` (default
    ``traverse.grip_spacing``; the nominal model's)."""
    d = p.traverse.grip_spacing if spacing is None else spacing
    q = initial_configuration(d, p.plant, 0.0)
    free = (q[0] + q[1] + math.pi) % (2.0 * math.pi) - math.pi   # 0: hanging down
    return math.pi - abs(free)


def free_link_upright(p: BplirParams) -> bool:
    """Whether the free link of the robot ``p`` stands within
    :data:`UPRIGHT_FREE_LINK` of upright in its end pose on a level line at
    ``traverse.grip_spacing`` (:func:`free_link_tilt`)."""
    return free_link_tilt(p) < UPRIGHT_FREE_LINK


def retry_params(p: BplirParams, summary: dict | None = None, *,
                 end_at_line: bool | None = None) -> BplirParams:
    """The swing of ``p`` tried again: from hanging at rest below the
    holding gripper, with ``traverse.retry_max_time`` to arrive.  Its plan
    ends at the line where the robot's free link ends upright
    (:func:`free_link_upright`; ``end_at_line`` says so instead: the swapped
    BPLIR's, whose try starts from where the damping left it, tilted by a
    steady wind) unless that plan by itself uses more of the driver's i^2 t
    budget than ``hanging.i2t_share`` (no guess kept to it: a hot pump ends
    at the torque limit and crashes), where it keeps ``plan.end_depth``; where its
    plan lifts the gripper with the elbow (the original robot's pump), the
    apex shot held from ``traverse.retry_lift_min_time`` lands it instead of
    the aim law (which chases the line as link 1 falls back).  When the
    try that timed out (its swing ``summary``) was itself from hanging and
    had the robot's estimate put the gripper within the capture band, the
    estimate ran above the truth there (the jaw would have sensed the
    line), and it runs so again on the same manoeuvre: the new try aims
    ``traverse.retry_aim_raise`` higher (``landing.landing_bias``, at most
    2 cm; the aim itself never above the line).  A swing from the line
    ends its pump-less reach differently and teaches nothing here."""
    tp, missed = p.traverse, summary or {}
    from_hanging = p.scenario.start == "hanging"
    sc = dc.replace(p.scenario, start="hanging", max_time=tp.retry_max_time)
    p = p.with_(scenario=sc)
    at_line = free_link_upright(p) if end_at_line is None else end_at_line
    if at_line and p.plan.end_depth != 0.0:
        ended = p.with_(plan=dc.replace(p.plan, end_depth=0.0))
        p = p if _too_hot(ended) else ended
    if tp.retry_lift_min_time > 0.0:
        p = p.with_(landing=dc.replace(p.landing, shoot_lift_min_time=tp.retry_lift_min_time))
    peak = missed.get("estimated_peak_height_m", math.nan)
    if tp.retry_aim_raise > 0.0 and from_hanging and missed.get("outcome") == "timeout" \
            and peak >= -p.gripper.capture_distance:
        bias = min(MAX_LANDING_BIAS, p.landing.landing_bias + tp.retry_aim_raise)
        p = p.with_(landing=dc.replace(p.landing, landing_bias=bias))
    return p


def _too_hot(p: BplirParams) -> bool:
    """Whether the plan from hanging of ``p`` by itself uses more of the
    driver's i^2 t than :func:`~bplir_drake.diagrams.plan.i2t_allowance`
    (never with ``hanging.i2t_share`` 0, or without a plan)."""
    made = hanging_planned(p)
    allowance = i2t_allowance(made)
    if math.isinf(allowance):
        return False
    try:
        plan = scenario_plan(p.resolved())
    except ParameterError:
        return False
    return planned_i2t(plan, made.motor) > allowance


def damping_drive(d: Damping, motor):
    """(current A, electrical energy J) along the damping ``d``: the
    current of the torque and the positive mechanical work through the
    gear's and the motor's efficiencies."""
    work = float(np.trapezoid(np.maximum(d.torque * d.states[:, 3], 0.0), d.t))
    return d.torque / motor.torque_per_amp, work / (motor.eta_g * motor.eta_m)


def can_retry(p: BplirParams) -> bool:
    """Whether the planner finds a swing from hanging for ``p`` (a
    :func:`retry_params`) on the nominal model."""
    try:
        scenario_plan(p.resolved())
    except ParameterError:
        return False
    return True
