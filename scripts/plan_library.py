"""Solve the shipped plan libraries: for each nominal robot the package
plans for by default (the single swing, the traversal's swings holding
with either gripper and its swings tried again from hanging), the swing
plans and their tracking gains on a grid of line inclines and grip
spacings, stored in ``bplir_drake/data/plans`` (a maintainer's tool: run it
after a change to the planner, the nominal model, the motor's envelope or
the tracker's weights).

    python scripts/plan_library.py                 # all libraries
    python scripts/plan_library.py --only swing    # one of them
    python scripts/plan_library.py --check         # list, solve nothing
    python scripts/plan_library.py --hardware 48v --only traverse-2
                                                   # a hardware option's robot

Each library is commissioned as any robot's is
(:func:`bplir_drake.analysis.commission.grid.solve_library`): every grid
point from the plans of the most similar robots already solved, scaled to
it, then the holes from their solved neighbours, then the grid made fit to
blend (:mod:`bplir_drake.analysis.commission.refine`).  Plans are kept in
a solve cache (``--cache``), so a run that stops can be resumed.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="list, solve nothing")
    ap.add_argument("--only", default=None,
                    help="one library: swing, traverse-1, traverse-2, hanging-1, hanging-2")
    ap.add_argument("--hardware", default="",
                    help="hardware options of the robot (comma-separated, as bplir --hardware)")
    ap.add_argument("--workers", type=int, default=0, help="processes (0: one per core)")
    ap.add_argument("--cache", default=str(ROOT / ".plan-library-cache"),
                    help="the solve cache (resumable)")
    args = ap.parse_args(argv)
    os.environ["BPLIR_CACHE_DIR"] = args.cache
    from bplir_drake.analysis.commission.grid import solve_library
    from bplir_drake.analysis.commission.similarity import shipped_robots
    from bplir_drake.planning.cache import plan_key
    from bplir_drake.planning.library import (LIBRARY_INCLINES, LIBRARY_SPACINGS, describe,
                                                   library_path, load_library, model_inputs)

    libs = shipped_robots([h for h in args.hardware.split(",") if h])
    names = [args.only] if args.only else list(libs)
    for name in names:
        params, path = libs[name], library_path(libs[name])
        print(f"{name}: {len(LIBRARY_INCLINES)} inclines x {len(LIBRARY_SPACINGS)} spacings "
              f"-> {path.name}", flush=True)
        if args.check:
            continue
        t0 = time.perf_counter()
        solved = solve_library(params, LIBRARY_INCLINES, LIBRARY_SPACINGS, workers=args.workers,
                               progress=True, path=path, key=plan_key(model_inputs(params)))
        how = Counter(r.how for r in solved.values())
        print(f"{name}: stored {path} ({path.stat().st_size / 1e3:.0f} kB) in "
              f"{time.perf_counter() - t0:.0f} s, {dict(how)}: {describe(load_library(path))}",
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
