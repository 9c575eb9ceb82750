"""How each swing of a traversal is set up: its chord on the line (its parameters are ``params.derive``'s), the driver's current budget and the catch's impulse."""
from __future__ import annotations

import math
import numpy as np
from dataclasses import replace

from ...params import BplirParams, Manoeuvre, derive
from ...planning.library import library_covers
from ...systems.delay_id import planned_probe
from ...systems.motor import max_torque
from ...systems.landing import height_rates, landing_law
from ...systems.plant import gripper_velocity, mass_matrix


def swing_chord(line, start: float, hold: float, reach: float) -> tuple[float, float]:
    """(grip spacing m, incline rad) of the swing on ``line`` from the rear
    grip at ``start`` past the holding gripper at ``hold`` to land about
    ``reach`` ahead of it: the chord between its two grips, and the incline
    of the chord from ``start`` to where it lands (the line's end at most)."""
    spacing, _ = line.chord(start, hold)
    _, incline = line.chord(start, min(hold + reach, line.length))
    return spacing, incline


def step_manoeuvre(robot: BplirParams, m: Manoeuvre) -> tuple[Manoeuvre, BplirParams]:
    """The traversal step ``m`` of ``robot`` and what it runs with: held by
    a gripper the robot pumps with (``scenario.manoeuvre``) a pump where
    the robot's pump library covers the step's incline and spacing (where
    commissioning verified it), else one swing."""
    p = derive(robot, m)
    if p.scenario.manoeuvre == "pump" and not library_covers(p):
        m = replace(m, reach="swing")
        p = derive(robot, m)
    return m, p


def budgeted_currents(plan, p: BplirParams) -> np.ndarray:
    """The currents (A, one per driver period) the rest planner budgets for
    the planned swing ``plan`` of ``p``: the plan's, and from the moment the
    planned gripper comes within the terminal law's take-over depth of the
    line (in the plan's second half) to its end, the current of the torque
    limit.  The terminal law's feedback is not planned, and may run at the
    limit there.  The
    delay probe (``plan.delay_probe``) adds its torques to the first
    ticks."""

    motor, landing = p.motor, p.landing
    t, tq = plan.torque_on_ticks(motor.driver_period)
    probe = planned_probe(p.path, p.plan, p.controller)   # on the plan tracker's first ticks
    ticks = np.floor(t / p.controller.period + 1e-9).astype(int)
    tq = tq + np.array([probe[k] if k < len(probe) else 0.0 for k in ticks])
    tq = np.abs(tq)
    alpha = math.radians(p.scenario.incline_deg)
    law = landing_law(p.plant, alpha, plan.states, landing)
    if law != "none":
        depth = {"shoot": landing.shoot_depth, "aim": landing.landing_depth,
                 "reach": landing.reach_depth}[law]
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
