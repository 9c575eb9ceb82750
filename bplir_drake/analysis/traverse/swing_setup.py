"""How each swing of a traversal is set up: its parameters (incline, spacing, orientation, landing), what earlier swings taught the landing, the driver's current budget and the catch's impulse."""
from __future__ import annotations

import dataclasses as dc
import math
import numpy as np
from ...params import BplirParams, swapped
from ...params.plan import MAX_LANDING_BIAS
from ...systems.delay_id import planned_probe
from ...systems.motor import max_torque
from ...systems.plan_tracker import height_rates, landing_law
from ...systems.plant import gripper_velocity, mass_matrix


def swing_chord(line, start: float, hold: float, reach: float) -> tuple[float, float]:
    """(grip spacing m, incline rad) of the swing on ``line`` from the rear
    grip at ``start`` past the holding gripper at ``hold`` to land about
    ``reach`` ahead of it: the chord between its two grips, and the incline
    of the chord from ``start`` to where it lands (the line's end at most)."""
    spacing, _ = line.chord(start, hold)
    _, incline = line.chord(start, min(hold + reach, line.length))
    return spacing, incline


def swing_params(params: BplirParams, holding: int, spacing: float,
                 incline: float) -> BplirParams:
    """The parameters of a traversal swing holding with gripper ``holding``
    (1: the robot as given, 2: :func:`~bplir_drake.params.swapped`) on a line
    inclined by ``incline`` (rad) with the grips ``spacing`` apart.  The
    incline is rounded to 0.1 deg and the spacing to 1 mm (the planned swings
    of a line are then a few, cached; 0.05 deg is 1 mm over a grip spacing).
    With ``traverse.landing`` (the default) the swing lands as a single
    swing does (the apex landing, the delay probe and its compensation), by
    the same landing settings holding with either gripper (the swapped robot
    is another robot, landed by the same rules, and reads the line sensor of
    its jaw as the robot does); the landing shot
    brakes at ``traverse.shoot_brake_ratio`` where that is set."""
    p = params if holding == 1 else swapped(params)
    sc = dc.replace(p.scenario, grip_spacing=round(float(spacing), 3),
                    incline_deg=round(math.degrees(incline), 1))
    p = p.with_(scenario=sc)
    tp = params.traverse
    if tp.swing_mode == "plan":
        # plan tracking without the terminal reach (it lands wherever the
        # gripper first moves slowly, sliding along the line if it must, where
        # a traversal has to land on the planned grip between obstacles: with
        # it, seed 0 of examples/line_span.toml landed on a spacer)
        path = dc.replace(p.path, mode="plan")
        plan = dc.replace(p.plan, end_depth=tp.plan_end_depth)
        landing = dc.replace(p.landing, reach_speed=0.0)
        if tp.shoot_brake_ratio > 0.0:
            landing = dc.replace(landing, shoot_brake_ratio=tp.shoot_brake_ratio)
        if not tp.landing:   # plan tracking alone, as traversals were first built
            landing = dc.replace(landing, landing_lead=0.0)
            plan = dc.replace(plan, delay_compensation=0.0, delay_probe=0.0)
        p = p.with_(path=path, plan=plan, landing=landing)
    return p


def learnt_landing(p: BplirParams, errors) -> BplirParams:
    """``p`` with ``path.landing_bias`` set to ``traverse.landing_learning``
    times the mean of ``errors``: the landing height errors (m, swing summary
    ``landing_height_error_m``) of the earlier captures of the robot
    holding with the same gripper, which the robot measured itself at each
    arrival.  Unchanged without earlier captures, with learning off or
    without the terminal landing."""
    tp = p.traverse
    errors = [e for e in errors if math.isfinite(e)]
    if tp.landing_learning <= 0.0 or not errors or tp.swing_mode != "plan" or not tp.landing:
        return p
    bias = min(MAX_LANDING_BIAS, max(-MAX_LANDING_BIAS,
                                     tp.landing_learning * float(np.mean(errors))))
    return p.with_(landing=dc.replace(p.landing, landing_bias=bias))


def budgeted_currents(plan, p: BplirParams) -> np.ndarray:
    """The currents (A, one per driver period) the rest planner budgets for
    the planned swing ``plan`` of ``p``: the plan's, and from the moment the
    planned gripper comes within the terminal law's take-over depth of the
    line (in the plan's second half) to its end, the current of the torque
    limit.  The terminal law's feedback is not planned, and the swapped
    robot's runs at the limit there (README, "Traversal Monte Carlo").  The
    delay probe (``plan.delay_probe``) adds its torques to the first
    ticks."""

    motor, landing = p.motor, p.landing
    t, tq = plan.torque_on_ticks(motor.driver_period)
    probe = planned_probe(p.path, p.plan, p.controller)   # on the plan tracker's first ticks
    ticks = np.floor(t / p.controller.period + 1e-9).astype(int)
    tq = tq + np.array([probe[k] if k < len(probe) else 0.0 for k in ticks])
    tq = np.abs(tq)
    if landing.landing_lead > 0:
        alpha = math.radians(p.scenario.incline_deg)
        law = landing_law(p.plant, alpha, plan.states, landing)
        depth = landing.shoot_depth if law == "shoot" else landing.landing_depth
        h = np.array([height_rates(p.plant, alpha, x)[0] for x in plan.states])
        near = (plan.times >= 0.5 * plan.duration) & (h > -depth)
        if near.any():
            tq[t >= plan.times[np.argmax(near)]] = min(max_torque(motor),
                                                       p.controller.torque_limit)
    return tq / motor.torque_per_amp


def capture_impulse(q, v, p) -> tuple[float, float]:
    """(impulse N s, effective mass kg) the arriving gripper and the line take
    to stop the gripper moving at joint rates ``v`` in pose ``q``: with
    both grippers pinned the robot stops, so the impulse is ``Lambda v_g``,
    ``Lambda = J^-T M J^-1`` the robot's inertia seen at the gripper."""

    # the gripper's Jacobian, column by column from its velocity
    J = np.column_stack([gripper_velocity(q, e, p.l1, p.l2) for e in ((1.0, 0.0), (0.0, 1.0))])
    M = np.array(mass_matrix(q, p), dtype=float)
    vg = J @ np.asarray(v, dtype=float)
    Jinv = np.linalg.inv(J)
    Lam = Jinv.T @ M @ Jinv
    P = Lam @ vg
    speed = float(np.linalg.norm(vg))
    impulse = float(np.linalg.norm(P))
    return impulse, (impulse / speed if speed > 0 else math.nan)
