"""Solve the plans and tracking gains the package ships and put them in
``bplir_drake/data/plans`` (a maintainer's tool: run it after a change to
the planner, the nominal model or the motor's envelope).

    python scripts/ship_plans.py            # solve what is not shipped yet into a fresh
                                            # cache, then copy the files the set used
    python scripts/ship_plans.py --check    # list what would ship, solve nothing

The shipped set is what the quick start, the examples and the tests use:
the +-20 deg and 0 deg swings, the 20 deg swing resting on the line, the
quick benchmark's +-10 deg and 1.1 / 1.15 / 1.3 m swings (with their warm
starts from 1.2 m), the 1.27 m warm start, every swing of the example
lines (both robots), the default swing of a robot whose nominal link 2
weighs 1.6 kg (the documented ``--set plant.m2=1.6``), the swing of
``examples/acromonk.toml``, the flat-line swings tried again from hanging
(both robots; the hanging libraries' grid point, which tests compare with
them, and the original robot's at +2.6 deg and 1.05 m, between grid
points) and the 48 V robots' planned by guesses within 85 % of the
torque limit and 35 % of the driver's i^2 t budget (the original robot's
on a level line; the swapped robot's on the span's +2.6 deg chord, ending
at the line, as its free link's pose decides, and 13 mm below it, the
plans its guesses gave before one heated the driver little enough), and
docs/commission.md's 0.7-scaled robot at 0 deg and 0.84 m (either gripper,
from the line and from hanging, solved from similar robots' plans); gains
for the swings the tests track that the plan libraries
(``scripts/plan_library.py``) do not cover.
"""
from __future__ import annotations

import argparse
import dataclasses as dc
import math
import os
import shutil
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def scenarios():
    """(plans to solve, plans whose gains ship) as callables returning a plan."""
    from bplir_drake.planning import solve as P
    from bplir_drake.analysis.traverse.line import load_line
    from bplir_drake.analysis.traverse.route import plan_route
    from bplir_drake.params import with_hardware
    from bplir_drake.params import from_dict, load_toml, preset

    base = preset()
    up = load_toml(ROOT / "examples" / "uphill_plan.toml")

    def at(p, **sc):
        return p.with_(scenario=dc.replace(p.scenario, **sc))

    plans = [lambda: P.plan_swing(at(up, incline_deg=20.0), end_depth=0.0)]
    tracked = [at(up, incline_deg=20.0), at(up, incline_deg=-20.0),
               base.with_(path=dc.replace(base.path, mode="plan"))]
    quick = ([at(base, incline_deg=a) for a in (-10.0, 10.0)]
             + [at(base, grip_spacing=d) for d in (1.1, 1.15, 1.3)])
    tracked += quick + [traverse_swing(base, g, base.traverse.grip_spacing, 0.0) for g in (1, 2)]
    tracked.append(from_dict({"plant": {"m2": 1.6}}, base=base))   # as --set plant.m2=1.6
    acromonk = load_toml(ROOT / "examples" / "acromonk.toml")   # another robot: its swing
    tracked.append(acromonk)                                     # and its `bplir plan`
    plans.append(lambda: P.plan_swing(acromonk, power_limit=None, knots=41))
    # the flat-line swings tried again from hanging (the traversal's recovery),
    # and the 48 V swapped robot's try on the span's +2.6 deg chord planned by
    # guesses within 85 % of the torque limit and 35 % of the driver's i^2 t
    # budget (test_traverse_recovery's: the first guess heats the driver too much)
    tracked += [tried(base, g, base.traverse.grip_spacing, 0.0)
                for g in (1, 2)]
    b48 = with_hardware(base, "48v")
    b48 = b48.with_(hanging=dc.replace(b48.hanging, torque_share=0.85, i2t_share=0.35))
    chord = tried(b48, 2, b48.traverse.grip_spacing, math.radians(2.6))
    tracked += [chord, tried(b48, 2, b48.traverse.grip_spacing,
                                                 math.radians(2.6), end_at_line=False)]
    # the 48 V original robot's try on a level line so paced (the apex shot's test)
    tracked.append(tried(b48, 1, b48.traverse.grip_spacing, 0.0))
    solved = base.with_(plan=dc.replace(base.plan, library=False))   # the libraries' own
    plans += [lambda g=g: P.scenario_plan(tried(                 # plans at 0 deg, 1.2 m
        solved, g, solved.traverse.grip_spacing, 0.0)) for g in (1, 2)]
    plans.append(lambda: P.scenario_plan(tried(   # and between grid points (+2.6 deg,
        solved, 1, 1.05, math.radians(2.6))))   # 1.05 m)
    q127 = at(base, grip_spacing=1.27)   # the warm start's test: its cold solve too
    plans += [lambda: P.scenario_plan(q127),
              lambda: P.plan_swing(q127, end_depth=q127.plan.end_depth, guess_duration=1.0)]
    for name in ("line_flat.toml", "line_span.toml"):
        line = load_line(ROOT / "examples" / name)
        for r in plan_route(line, base):
            for g, (a, b) in ((1, (r.rear, r.landing1)), (2, (r.hold, r.landing2))):
                sp = traverse_swing(base, g, base.traverse.grip_spacing, line.chord(a, b)[1])
                plans.append(lambda sp=sp: P.scenario_plan(sp))
    # docs/commission.md's robot (the 0.7-scaled BPLIR): its points at 0 deg and
    # 0.84 m holding with either gripper, from the line and from hanging, each
    # solved from similar robots' plans (the worked example's test reads them)
    from bplir_drake.analysis.commission.grid import solve_point
    from bplir_drake.params import swapped
    scaled = load_toml(ROOT / "examples" / "scaled_bplir.toml")
    robots = [scaled, swapped(scaled)] + [tried(scaled, g, 0.84, 0.0)
                                          for g in (1, 2)]
    plans += [lambda r=r: solve_point(r, 0.0, 0.84).plan for r in robots]
    return plans, tracked


def _step(gripper, spacing, incline, **kw):
    from bplir_drake.params import Manoeuvre

    return Manoeuvre(gripper=gripper, spacing=spacing, incline_deg=math.degrees(incline),
                     context="traverse", **kw)


def traverse_swing(robot, gripper, spacing, incline):
    """A traversal's swing of ``robot`` (``incline`` in rad)."""
    from bplir_drake.params import derive

    return derive(robot, _step(gripper, spacing, incline))


def tried(robot, gripper, spacing, incline, **kw):
    """That swing tried again from hanging."""
    from bplir_drake.planning.retry import retry

    return retry(robot, _step(gripper, spacing, incline, **kw))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="count, solve nothing")
    ap.add_argument("--cache", default=None,
                    help="solve into this (empty, or an earlier run's) directory")
    args = ap.parse_args(argv)
    cache = Path(args.cache) if args.cache else Path(tempfile.mkdtemp(prefix="bplir-plans-"))
    cache.mkdir(parents=True, exist_ok=True)
    os.environ["BPLIR_CACHE_DIR"] = str(cache)
    from bplir_drake.planning import solve as P
    from bplir_drake.planning import cache as plan_cache
    from bplir_drake.planning.cache import PACKAGED

    plans, tracked = scenarios()
    plan_cache.USED = set()   # every file the set reads or solves
    if args.check:
        print(f"{len(plans)} plans, {len(tracked)} tracked swings")
        return 0
    for make in plans:
        plan = make()
        print(f"plan {plan.incline_deg:+.1f} deg: feasible {plan.feasible}, "
              f"{plan.duration:.2f} s, peak {plan.peak_voltage:.1f} V", flush=True)
    for p in tracked:
        plan, _ = P.tracking_plan(p)
        print(f"gains {plan.incline_deg:+.1f} deg, {p.scenario.grip_spacing:g} m", flush=True)
    used = {f.name: f for f in plan_cache.USED}
    for name, f in sorted(used.items()):
        if f.parent != PACKAGED:
            shutil.copy2(f, PACKAGED / name)
    # a shipped file the set reads only where no library covers it is not
    # seen here, so nothing is removed: list the candidates for a maintainer
    idle = sorted(f.name for f in [*PACKAGED.glob("plan-*.npz"), *PACKAGED.glob("gains-*.npz")]
                  if f.name not in used)
    print(f"not read by the set (where a library covered it, or no longer used): {len(idle)}")
    print(f"shipped {len(list(PACKAGED.glob('plan-*.npz')))} plans and "
          f"{len(list(PACKAGED.glob('gains-*.npz')))} gains in {PACKAGED}")
    if not args.cache:
        shutil.rmtree(cache, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
