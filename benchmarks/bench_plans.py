"""Benchmark: how long a swing, a study and a traversal of the default robot
wait for their plans, from an empty cache (issue 44, "plans without
waiting"), in one run.

Run: python benchmarks/bench_plans.py [--solve] [--study N]
(prints figures, not a test).

- every robot the package plans for by default (the single swing, the
  traversal holding with either gripper, a traversal's swing tried again
  from hanging holding with either gripper): plan and tracking gains for
  random inclines in [-20, 20] deg and grip spacings in [0.9, 1.5] m,
  cold cache, one core: how many the library blends and how long they
  wait; goal: <= 5 s each;
- ``--solve``: the same for one scenario solved instead (``plan.library =
  false``), the wait the library saves;
- ``--tower``: ``bplir traverse examples/line_tower.toml`` (a 60 m span,
  ten obstacles) in a fresh process with an empty cache, its wall time in
  total; goal: <= 3 min;
- ``--hardware 48v``: the robots with a hardware option (as ``bplir
  --hardware``), for all of the above;
- ``--study N``: the realistic study (examples/study_realistic.toml, grip
  spacing drawn in 1.1-1.3 m) at +13 deg, N samples in this process, and
  the share of its wall time spent getting plans; goal: <= 10 %.
"""
import argparse
import dataclasses as dc
import os
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def robots(hardware=()):
    from bplir_drake.planning.retry import retry
    from bplir_drake.params import Manoeuvre, derive, preset, with_hardware

    base = with_hardware(preset(), *hardware)
    step = {g: Manoeuvre(gripper=g, spacing=1.2, incline_deg=0.0, context="traverse")
            for g in (1, 2)}
    return {"single swing": base, "traversal, gripper 1 holding": derive(base, step[1]),
            "traversal, gripper 2 holding": derive(base, step[2]),
            "try from hanging, gripper 1 holding": retry(base, step[1]),
            "try from hanging, gripper 2 holding": retry(base, step[2])}


def waits(params, n: int, rng) -> list[tuple[float, bool]]:
    """(wall s, blended from the library) of ``tracking_plan`` at ``n``
    random scenarios of the envelope whose plans the library blends (the
    others are counted, not solved: a solve takes 15 s to minutes)."""
    from bplir_drake.planning.solve import tracking_plan
    from bplir_drake.planning.library import library_path, load_library, same_manoeuvre

    lib = load_library(library_path(params))
    out = []
    for _ in range(n):
        a, d = float(rng.uniform(-20, 20)), float(rng.uniform(0.9, 1.5))
        if lib is None or not same_manoeuvre(lib, a, d):
            out.append((float("nan"), False))
            continue
        sc = dc.replace(params.scenario, incline_deg=a, grip_spacing=d)
        t0 = time.perf_counter()
        plan, _ = tracking_plan(params.with_(scenario=sc))
        out.append((time.perf_counter() - t0, plan.status == "interpolated"))
    return out


def solve_wait(params) -> float:
    """Wall s of one plan and its gains solved at +13 deg, 1.23 m."""
    from bplir_drake.planning.solve import tracking_plan

    p = params.with_(scenario=dc.replace(params.scenario, incline_deg=13.0, grip_spacing=1.23),
                     plan=dc.replace(params.plan, library=False))
    t0 = time.perf_counter()
    tracking_plan(p)
    return time.perf_counter() - t0


def study_share(samples: int) -> tuple[float, float, dict]:
    """(wall s, s spent getting plans, outcomes) of the realistic study at +13 deg."""
    import bplir_drake.analysis.swing.swing_runner as run
    from bplir_drake.analysis import montecarlo as mc

    spent = [0.0]
    inner = run.tracking_plan

    def timed(p):
        t0 = time.perf_counter()
        try:
            return inner(p)
        finally:
            spent[0] += time.perf_counter() - t0

    run.tracking_plan = timed
    study = mc.load_study(ROOT / "examples" / "study_realistic.toml")
    sc = dc.replace(study.params.scenario, incline_deg=13.0)
    study = dc.replace(study, params=study.params.with_(scenario=sc), samples=samples, seed=1)
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        summary = mc.run_study(study, Path(out) / "study", workers=1)
        wall = time.perf_counter() - t0
    return wall, spent[0], summary["outcomes"]


def tower(hardware=()) -> tuple[float, str]:
    """(wall s, last line printed) of the tower-to-tower example, cold."""
    import subprocess
    import sys

    with tempfile.TemporaryDirectory() as d:
        env = dict(os.environ, BPLIR_CACHE_DIR=str(Path(d) / "cache"))
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, "-m", "bplir_drake.cli", "traverse",
                              str(ROOT / "examples" / "line_tower.toml"), "--no-animation",
                              "--out", str(Path(d) / "tower")]
                             + (["--hardware", ",".join(hardware)] if hardware else []),
                             env=env, capture_output=True,
                             text=True)
        wall = time.perf_counter() - t0
    lines = [x for x in out.stdout.splitlines() if x.startswith("outcome") or "passed" in x]
    return wall, (lines[0] if lines else out.stderr.strip()[-200:])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--solve", action="store_true")
    ap.add_argument("--study", type=int, default=0)
    ap.add_argument("--tower", action="store_true")
    ap.add_argument("-n", type=int, default=20, help="scenarios per robot")
    ap.add_argument("--hardware", default="", help="hardware options, comma-separated")
    args = ap.parse_args()
    hardware = [h for h in args.hardware.split(",") if h]
    os.environ["BPLIR_CACHE_DIR"] = tempfile.mkdtemp(prefix="bplir-cold-")
    rng = np.random.default_rng(0)
    for name, p in robots(hardware).items() if args.n > 0 else ():
        w = waits(p, args.n, rng)
        t = [x for x, ok in w if ok]
        wait = (f", plan + gains in median {np.median(t)*1e3:.1f} ms, max {max(t)*1e3:.1f} ms"
                if t else "")
        print(f"{name}: {len(t)} of {args.n} random scenarios blended from the library{wait} "
              f"(goal <= 5 s); the other {args.n - len(t)} are solved (15 s to minutes)",
              flush=True)
    if args.solve:
        s = solve_wait(robots(hardware)["single swing"])
        print(f"solved instead (+13 deg, 1.23 m, library off): {s:.1f} s", flush=True)
    if args.tower:
        wall, what = tower(hardware)
        print(f"examples/line_tower.toml{' at ' + args.hardware if hardware else ''}, cold "
              f"cache, one process: {wall:.0f} s wall "
              f"(goal <= 180 s); {what}", flush=True)
    if args.study:
        wall, plans, outcomes = study_share(args.study)
        print(f"realistic study at +13 deg, {args.study} samples, one process: {wall:.1f} s wall, "
              f"{plans:.2f} s getting plans = {100 * plans / wall:.1f} % (goal <= 10 %); "
              f"{outcomes}")


if __name__ == "__main__":
    main()
