"""A solved grid of plans made fit to blend: a plan costing far more than
its neighbours (a poor local optimum) is re-solved from the planner's own
guesses (:func:`repair`), a plan of another manoeuvre than most of its
neighbours' from the cheapest of them (:func:`harmonise`), and a pump from
hanging that heats the driver too much from its coolest neighbour
(:func:`cool`).  A blend needs plans of one manoeuvre and shape around it.

Grids are ``{(incline, spacing): SwingPlan or None}``; every function
returns a new grid and the points it replaced.
"""
from __future__ import annotations

import dataclasses as dc
from collections import Counter

from ...planning import solve as P
from ...params import BplirParams, ParameterError, on_line
from ...systems.motor import interlock_budget

#: a plan costing more than this times the cheaper of its incline neighbours
#: is re-solved from the planner's own guesses (continuation and scaled
#: guesses can stall in a poor local optimum)
REPAIR_RATIO = 1.5

#: the share of the driver's i^2 t budget a library plan from hanging may use
#: by itself (assumed: the tracker's feedback heats the driver about as much
#: again, and the two together keep a margin below the budget)
COOL_SHARE = 0.35


def solve_from(q: BplirParams, initial=None, guess_duration: float | None = None):
    """One solve of the plan of ``q``, started from ``initial`` (a plan) or
    the straight line over ``guess_duration``: as the planner makes it (a
    plan from hanging with its own knots, iteration limit and envelope, and
    not feasible where it heats the driver beyond ``hanging.i2t_share``; a
    pump on its own knots, not feasible where it does not keep the robot's
    energy)."""
    start = {"initial": initial} if initial is not None else {
        "guess_duration": guess_duration or 1.5}
    if q.scenario.manoeuvre_of() == "pump":
        return P.pump_solve(q, **start)
    if q.scenario.start != "hanging":
        return P.plan_swing(q, end_depth=q.plan.end_depth, **start)
    made = P.planned_from_hanging(q)
    plan = P.hanging_solve(made, **start)
    if plan.feasible and P.planned_i2t(plan, made.motor) > P.i2t_allowance(made):
        return dc.replace(plan, feasible=False)
    return plan


def own_plan(q: BplirParams):
    """The planner's own plan of ``q`` (its guesses in turn), or None."""
    try:
        return P.scenario_plan(q.with_(plan=dc.replace(q.plan, spacing_step=0.0,
                                                       library=False)))
    except ParameterError:
        return None


def _neighbours(plans: dict, a: float, d: float) -> list:
    """The plans at the grid points next to ``(a, d)`` along either axis
    (holes left out)."""
    inclines, spacings = sorted({x for x, _ in plans}), sorted({y for _, y in plans})
    i, j = inclines.index(a), spacings.index(d)
    near = [plans.get((inclines[k], d)) for k in (i - 1, i + 1) if 0 <= k < len(inclines)]
    near += [plans.get((a, spacings[k])) for k in (j - 1, j + 1) if 0 <= k < len(spacings)]
    return [p for p in near if p is not None]


def repair(params: BplirParams, plans: dict) -> tuple[dict, set]:
    """``plans`` with every outlier (:data:`REPAIR_RATIO` times the cost of
    the cheaper incline neighbour) replaced by the planner's own plan there
    when that is feasible, cheaper and the manoeuvre (link-1 reversals) of
    the outlier's neighbours."""
    out, changed = dict(plans), set()
    inclines = sorted({a for a, _ in plans})
    w = P.plan_time_weight(params.plant)
    for (a, d), plan in plans.items():
        i = inclines.index(a)
        near = [plans.get((inclines[k], d)) for k in (i - 1, i + 1) if 0 <= k < len(inclines)]
        near = [p for p in near if p is not None]
        if plan is None or not near or plan.objective(w) <= REPAIR_RATIO * min(
                p.objective(w) for p in near):
            continue
        own = own_plan(on_line(params, a, d))
        if own is not None and own.objective(w) < plan.objective(w) \
                and own.link1_reversals in {p.link1_reversals for p in near}:
            out[a, d] = own
            changed.add((a, d))
    return out, changed


def _common(plans: list):
    """The manoeuvre (link-1 reversals) that at least two of ``plans`` share
    and more than share any other (None: no such)."""
    count = Counter(p.link1_reversals for p in plans).most_common()
    if not count or count[0][1] < 2 or (len(count) > 1 and count[1][1] == count[0][1]):
        return None
    return count[0][0]


def harmonise(params: BplirParams, plans: dict) -> tuple[dict, set]:
    """``plans`` with every plan whose manoeuvre differs from the one most
    of its grid neighbours share (at least two, more than any other; at the
    end of a row of one incline or spacing, with one neighbour, the one most
    of the grid's plans share, when that neighbour's is it), or
    that is that manoeuvre at more than :data:`REPAIR_RATIO` times the cost
    of the cheapest of them, re-solved from that cheapest neighbour; kept
    when the new plan is feasible, their manoeuvre and costs at most
    :data:`REPAIR_RATIO` times the one it replaces (less, for a poorer plan
    of the same manoeuvre)."""
    out, changed = dict(plans), set()
    w = P.plan_time_weight(params.plant)
    for a, d in plans:
        plan = out[a, d]
        near = _neighbours(out, a, d)
        kind = _common(near) if len(near) > 1 else _common(
            [p for p in out.values() if p is not None])
        if plan is None or kind is None or (len(near) == 1 and
                                            near[0].link1_reversals != kind):
            continue
        ref = min((p for p in near if p.link1_reversals == kind), key=lambda p: p.objective(w))
        outlier = plan.objective(w) > REPAIR_RATIO * ref.objective(w)
        if plan.link1_reversals == kind and not outlier:
            continue
        new = solve_from(on_line(params, a, d), ref)
        limit = plan.objective(w) * (1.0 if plan.link1_reversals == kind else REPAIR_RATIO)
        if new.feasible and new.link1_reversals == kind and new.objective(w) <= limit:
            out[a, d] = new
            changed.add((a, d))
    return out, changed


def cool(params: BplirParams, plans: dict) -> tuple[dict, set]:
    """``plans`` from hanging with every plan whose torque alone uses more
    than :data:`COOL_SHARE` of the driver's i^2 t budget re-solved from the
    coolest of its grid neighbours that keeps to it; kept when the new plan
    is feasible and keeps to it.  A hot pump ends at the torque limit, and a
    robot heavier than the model trips the driver on it or crashes."""
    if params.scenario.start != "hanging":
        return dict(plans), set()
    motor = P.planned_from_hanging(params).motor

    def share(plan):   # of the driver's i^2 t budget the plan's torque alone uses
        return P.planned_i2t(plan, motor) / interlock_budget(motor)

    out, changed = dict(plans), set()
    for a, d in plans:
        plan = out[a, d]
        if plan is None or share(plan) <= COOL_SHARE:
            continue
        near = [p for p in _neighbours(out, a, d) if share(p) <= COOL_SHARE]
        if not near:
            continue
        new = solve_from(on_line(params, a, d), min(near, key=share))
        if new.feasible and share(new) <= COOL_SHARE:
            out[a, d] = new
            changed.add((a, d))
    return out, changed


def refined(params: BplirParams, plans: dict) -> tuple[dict, set]:
    """``plans`` repaired, harmonised and cooled, with every point replaced."""
    changed = set()
    for step in (repair, harmonise, cool):
        plans, more = step(params, plans)
        changed |= more
    return plans, changed
