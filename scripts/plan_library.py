"""Solve the shipped plan libraries: for each nominal robot the package
plans for by default (the single swing, the traversal's swings holding
with either gripper and its swings tried again from hanging), the swing
plans and their tracking gains on a grid of
line inclines and grip spacings, stored in ``bplir_drake/data/plans`` (a
maintainer's tool: run it after a change to the planner, the nominal model,
the motor's envelope or the tracker's weights).

    python scripts/plan_library.py                 # all libraries
    python scripts/plan_library.py --only swing    # one of them
    python scripts/plan_library.py --check         # list, solve nothing
    python scripts/plan_library.py --hardware 48v --only traverse-2
                                                   # a hardware option's robot

The grid is solved by continuation: the plan at 0 deg and 1.2 m first
(the planner's own guesses, :func:`~bplir_drake.diagrams.plan.scenario_plan`),
then outwards along the spacings at 0 deg, then outwards along the
inclines for each spacing, every plan started from its solved neighbour,
so that neighbouring plans are mostly the same manoeuvre (the same number
of link-1 reversals) and can be interpolated; where the planner finds no
plan the grid has a hole.  A plan costing far more than its neighbours
(continuation stalled in a poor optimum) is then re-solved from the
planner's own guesses (:func:`repair`), a plan of another manoeuvre than
most of its neighbours' from the cheapest of them (:func:`harmonise`), and
a pump from hanging that heats the driver too much from its coolest
neighbour (:func:`cool`).  Plans are kept in a solve
cache (``--cache``), so a run that stops can be resumed.
"""
from __future__ import annotations

import argparse
import dataclasses as dc
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def libraries(hardware=()):
    """{name: parameters of the robot and scenario the library is for}:
    the single swing of the default robot (with the ``hardware`` options),
    the traversal's swings holding with either gripper, and those swings
    tried again from hanging (:func:`retry_params`)."""
    from bplir_drake.analysis.traverse.recovery import retry_params
    from bplir_drake.analysis.traverse.swing_setup import swing_params
    from bplir_drake.params import preset

    base = preset().with_hardware(*hardware)
    base = base.with_(plan=dc.replace(base.plan, library=False))   # solve, never read
    single = base.with_(path=dc.replace(base.path, mode="plan"))
    line = {g: swing_params(base, g, 1.2, 0.0) for g in (1, 2)}
    return {"swing": single, "traverse-1": line[1], "traverse-2": line[2],
            "hanging-1": retry_params(line[1]),
            "hanging-2": retry_params(line[2])}


def _at(params, incline: float, spacing: float):
    return params.with_(scenario=dc.replace(params.scenario, incline_deg=float(incline),
                                            grip_spacing=float(spacing)))


def _order(values, centre):
    """``values`` from the one nearest ``centre`` outwards, each with the
    neighbour it continues from (None for the first)."""
    values = sorted(values)
    i0 = min(range(len(values)), key=lambda i: abs(values[i] - centre))
    out = [(values[i0], None)]
    for i in range(i0 + 1, len(values)):
        out.append((values[i], values[i - 1]))
    for i in range(i0 - 1, -1, -1):
        out.append((values[i], values[i + 1]))
    return out


def solve_grid(params, inclines, spacings, log=print, only=None) -> dict:
    """{(incline, spacing): plan} by continuation (module docstring);
    ``only``: continue along the inclines for these spacings alone (a
    share of the work for one process; the plans meet in the cache)."""
    from bplir_drake.diagrams import plan as P
    from bplir_drake.params import ParameterError

    depth = params.plan.end_depth
    plans = {}

    def continued(incline, spacing, ref):
        q = _at(params, incline, spacing)
        t0 = time.perf_counter()
        plan = _from(q, ref, depth) if ref is not None else None
        if plan is None or not plan.feasible:
            try:
                plan = P.scenario_plan(q.with_(plan=dc.replace(q.plan, spacing_step=0.0)))
            except ParameterError as exc:   # a hole in the grid: blends around it solve
                log(f"  {incline:+5.1f} deg {spacing:.2f} m: no plan ({exc})", flush=True)
                return None
        log(f"  {incline:+5.1f} deg {spacing:.2f} m: {plan.status or 'solved'}, "
            f"{plan.duration:.2f} s, {plan.link1_reversals} reversals, "
            f"objective {plan.objective():.2f}, {time.perf_counter() - t0:.1f} s", flush=True)
        return plan

    for spacing, prev in _order(spacings, 1.2):
        plans[0.0, spacing] = continued(0.0, spacing, None if prev is None else plans[0.0, prev])
    for spacing in sorted(spacings) if only is None else only:
        last = {}
        for incline, prev in _order(inclines, 0.0)[1:]:
            side = incline > 0   # continue from the last plan found on this side
            ref = plans[prev, spacing] or last.get(side)
            plans[incline, spacing] = continued(incline, spacing, ref)
            last[side] = plans[incline, spacing] or ref
    return plans


def _from(q, ref, depth):
    """The plan of ``q`` started from its neighbour's ``ref``: as the
    planner solves it (a plan from hanging with its own knots, iteration
    limit, elbow-rate bound and envelope, and no plan that heats the
    driver beyond ``hanging.i2t_share``: that one is not feasible)."""
    from bplir_drake.diagrams import plan as P

    if q.scenario.start != "hanging":
        return P.plan_swing(q, end_depth=depth, initial=ref)
    made = P.hanging_planned(q)
    plan = P.hanging_solve(made, initial=ref)
    if plan.feasible and P.planned_i2t(plan, made.motor) > P.i2t_allowance(made):
        return dc.replace(plan, feasible=False)
    return plan


#: a plan costing more than this times the cheaper of its incline
#: neighbours is re-solved from the planner's own guesses (continuation can
#: stall in a poor local optimum)
REPAIR_RATIO = 1.5


def repair(params, plans: dict, log=print) -> dict:
    """``plans`` with every outlier (:data:`REPAIR_RATIO`) replaced by the
    planner's own plan there when that is feasible, cheaper and the same
    manoeuvre (link-1 reversals) as the outlier's neighbours."""
    from bplir_drake.diagrams import plan as P
    from bplir_drake.params import ParameterError

    out = dict(plans)
    inclines = sorted({a for a, _ in plans})
    for (a, d), plan in plans.items():
        i = inclines.index(a)
        near = [plans.get((inclines[k], d)) for k in (i - 1, i + 1) if 0 <= k < len(inclines)]
        near = [p for p in near if p is not None]
        if plan is None or not near or plan.objective() <= REPAIR_RATIO * min(
                p.objective() for p in near):
            continue
        q = _at(params, a, d)
        try:
            own = P.scenario_plan(q.with_(plan=dc.replace(q.plan, spacing_step=0.0)))
        except ParameterError:
            continue
        kinds = {p.link1_reversals for p in near}
        better = own.objective() < plan.objective() and own.link1_reversals in kinds
        _settle(out, (a, d), own if better else None, log,
                f"  repair {a:+5.1f} deg {d:.2f} m: objective {plan.objective():.1f}, the "
                f"planner's own {own.objective():.1f} ({own.link1_reversals} reversals)")
    return out


def _settle(out: dict, key, new, log, line: str) -> None:
    """Log ``line`` with the choice; put ``new`` (None: keep) at ``key``."""
    log(f"{line}: {'kept' if new is None else 'replaced'}", flush=True)
    if new is not None:
        out[key] = new


def _neighbours(plans: dict, inclines, spacings, a, d) -> list:
    """The plans at the grid points next to ``(a, d)`` along either axis
    (holes left out)."""
    i, j = inclines.index(a), spacings.index(d)
    near = [plans.get((inclines[k], d)) for k in (i - 1, i + 1) if 0 <= k < len(inclines)]
    near += [plans.get((a, spacings[k])) for k in (j - 1, j + 1) if 0 <= k < len(spacings)]
    return [p for p in near if p is not None]


def harmonise(params, plans: dict, log=print) -> dict:
    """``plans`` with every plan whose manoeuvre (link-1 reversals) differs
    from the one most of its grid neighbours share (at least two, more
    than any other), or that is that manoeuvre at more than
    :data:`REPAIR_RATIO` times the cost of the cheapest of them, re-solved
    from that cheapest neighbour; kept when the new plan is feasible,
    their manoeuvre and costs at most :data:`REPAIR_RATIO` times the one
    it replaces (less, for a poorer plan of the same manoeuvre).  A blend
    needs plans of one manoeuvre and shape around it; continuation along
    the inclines can switch manoeuvre a whole column at a time, and the
    planner's own guesses can end in a poor optimum of the same one."""
    from collections import Counter

    out = dict(plans)
    inclines, spacings = sorted({a for a, _ in plans}), sorted({d for _, d in plans})
    for a, d in plans:
        plan = out[a, d]
        near = _neighbours(out, inclines, spacings, a, d)
        count = Counter(p.link1_reversals for p in near).most_common()
        if plan is None or not count or count[0][1] < 2 or (
                len(count) > 1 and count[1][1] == count[0][1]):
            continue
        kind = count[0][0]
        ref = min((p for p in near if p.link1_reversals == kind), key=lambda p: p.objective())
        outlier = plan.objective() > REPAIR_RATIO * ref.objective()   # same manoeuvre, poorer
        if plan.link1_reversals == kind and not outlier:
            continue
        new = _from(_at(params, a, d), ref, params.plan.end_depth)
        limit = plan.objective() * (1.0 if plan.link1_reversals == kind else REPAIR_RATIO)
        better = new.feasible and new.link1_reversals == kind and new.objective() <= limit
        _settle(out, (a, d), new if better else None, log,
                f"  harmonise {a:+5.1f} deg {d:.2f} m: {plan.link1_reversals} reversals, "
                f"objective {plan.objective():.1f}; from its neighbour {new.link1_reversals}, "
                f"{new.objective():.1f}")
    return out


#: the share of the driver's i^2 t budget a library plan from hanging may
#: use by itself (assumed: the tracker's feedback heats the driver about as
#: much again, and on the example lines' chords the swapped robot's pumps use
#: 13-33 % or 36-72 %, so any share between 0.33 and 0.36 separates them)
COOL_SHARE = 0.35


def cool(params, plans: dict, log=print) -> dict:
    """``plans`` (from hanging) with every plan whose torque alone uses more
    than :data:`COOL_SHARE` of the driver's i^2 t budget re-solved from the
    coolest of its grid neighbours that keeps to it (whatever its
    manoeuvre); kept when the new plan is feasible and keeps to it.  A hot
    pump ends at the torque limit, and a robot heavier than the model trips
    the driver on it or crashes."""
    from bplir_drake.diagrams import plan as P
    from bplir_drake.systems.motor import interlock_budget

    if params.scenario.start != "hanging":
        return dict(plans)
    motor = P.hanging_planned(params).motor

    def share(plan):   # of the driver's i^2 t budget the plan's torque alone uses
        return P.planned_i2t(plan, motor) / interlock_budget(motor)

    out = dict(plans)
    inclines, spacings = sorted({a for a, _ in plans}), sorted({d for _, d in plans})
    for a, d in plans:
        plan = out[a, d]
        if plan is None or share(plan) <= COOL_SHARE:
            continue
        near = [p for p in _neighbours(out, inclines, spacings, a, d) if share(p) <= COOL_SHARE]
        if not near:
            continue
        new = _from(_at(params, a, d), min(near, key=share), params.plan.end_depth)
        heat = share(new) if new.feasible else float("inf")
        _settle(out, (a, d), new if heat <= COOL_SHARE else None, log,
                f"  cool {a:+5.1f} deg {d:.2f} m: {plan.link1_reversals} reversals, "
                f"{share(plan):.0%} of the budget; from its neighbour "
                f"{new.link1_reversals}, {heat:.0%}")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="list, solve nothing")
    ap.add_argument("--only", default=None,
                    help="one library: swing, traverse-1, traverse-2, hanging-1, hanging-2")
    ap.add_argument("--hardware", default="",
                    help="hardware options of the robot (comma-separated, as bplir --hardware)")
    ap.add_argument("--spacings", default=None,
                    help="solve only these spacings' inclines (comma-separated; no library is "
                         "written: run again without it to gather them)")
    ap.add_argument("--cache", default=str(ROOT / ".plan-library-cache"),
                    help="the solve cache (resumable)")
    args = ap.parse_args(argv)
    os.environ["BPLIR_CACHE_DIR"] = args.cache
    from bplir_drake.diagrams.plan_library import (LIBRARY_INCLINES, LIBRARY_SPACINGS,
                                                   build_library, describe, library_path,
                                                   save_library)

    libs = libraries([h for h in args.hardware.split(",") if h])
    names = [args.only] if args.only else list(libs)
    for name in names:
        params = libs[name]
        print(f"{name}: {len(LIBRARY_INCLINES)} inclines x {len(LIBRARY_SPACINGS)} spacings "
              f"-> {library_path(params).name}", flush=True)
        if args.check:
            continue
        only = None if args.spacings is None else [float(x) for x in args.spacings.split(",")]
        plans = solve_grid(params, LIBRARY_INCLINES, LIBRARY_SPACINGS, only=only)
        if only is not None:
            continue
        plans = cool(params, harmonise(params, repair(params, plans)))
        from bplir_drake.diagrams.plan import plan_model

        lib = build_library(params, plans, plan_model(params)[0])
        save_library(lib, library_path(params))
        print(f"{name}: stored {library_path(params)} "
              f"({library_path(params).stat().st_size / 1e3:.0f} kB): {describe(lib)}",
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
