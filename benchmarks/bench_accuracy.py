"""Benchmark: what a cheaper integrator setting changes in what a study
concludes (the yardstick of the speed issue), measured in one run.

The same realistic swings (a study's draws, every sample's seed) run at a
baseline setting (default: RK3 at 1e-4, the swing's setting before 1e-3)
and at a candidate (default: the swing's setting); printed per line: the share of
samples that keep their outcome, both success rates with their Wilson
intervals, both capture-speed p50 and p95, the median per-swing change of
the capture speed, and the wall time per swing of each.  With
``--reference K`` the first K swings also run against an accurate reference
(RK5 at 1e-10): the median per-swing capture-speed error of each setting.
Last, how many of the default swing's seeds 0-19 keep their outcome.

Run: python benchmarks/bench_accuracy.py [-n N] [--baseline 1e-4]
     [--accuracy 1e-3] [--integrator runge_kutta3]
     [--study examples/study_realistic.toml|default] [--inclines 0,20,-20]
     [--seed ROOT] [--reference K] [--json PATH]
(prints figures, not a test; 2 worker processes).  ``--json`` also writes
them for the results pages (``results/accuracy``).
"""
import argparse
import json
import math
import multiprocessing
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
_RUNNER = None


def _one(job):
    """(outcome, capture speed, wall s) of sample ``index`` at one setting."""
    global _RUNNER
    from bplir_drake.analysis.montecarlo.sampling import sample_params
    from bplir_drake.analysis.swing.swing_runner import SwingRunner

    study, index, integrator, accuracy = job
    if _RUNNER is None:
        _RUNNER = SwingRunner()
    if study is None:   # the default swing of seed ``index``
        from bplir_drake.params import preset
        p, seed = preset(), index
    else:
        p, seed, _ = sample_params(study, index)
    t0 = time.perf_counter()
    s = _RUNNER.run(p, seed=seed, integrator=integrator, accuracy=accuracy).summary
    return s["outcome"], s["capture_speed_mps"], time.perf_counter() - t0


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """The Wilson score interval of ``k`` successes in ``n``."""
    if n == 0:
        return math.nan, math.nan
    p = k / n
    d = 1 + z * z / n
    c = p + z * z / (2 * n)
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return (c - h) / d, (c + h) / d


def _rates(rows):
    ok = [r for r in rows if r[0] == "captured"]
    speeds = np.array([r[1] for r in ok]) if ok else np.array([math.nan])
    return len(ok), np.percentile(speeds, 50), np.percentile(speeds, 95)


def compare(pool, study, n, settings):
    """Rows of each setting for samples 0..n-1 of ``study``."""
    return {name: pool.map(_one, [(study, k, integ, acc) for k in range(n)], chunksize=4)
            for name, (integ, acc) in settings.items()}


def main(argv=None) -> int:
    from dataclasses import replace

    from bplir_drake.analysis.montecarlo.study import load_study
    from bplir_drake.analysis.swing.swing_runner import SWING_ACCURACY, SWING_INTEGRATOR

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-n", type=int, default=100)
    ap.add_argument("--baseline", type=float, default=1e-4, help="the baseline's accuracy")
    ap.add_argument("--accuracy", type=float, default=SWING_ACCURACY)
    ap.add_argument("--integrator", default=SWING_INTEGRATOR)
    ap.add_argument("--study", default=str(ROOT / "examples" / "study_realistic.toml"))
    ap.add_argument("--inclines", default="0,20,-20")
    ap.add_argument("--seed", type=int, default=300, help="root seed of the draws")
    ap.add_argument("--reference", type=int, default=0, help="swings also run at RK5 1e-10")
    ap.add_argument("--json", help="write the figures to this file")
    args = ap.parse_args(argv)
    from bplir_drake.analysis.montecarlo.study import Study

    base = Study() if args.study == "default" else load_study(args.study)
    settings = {"baseline": (SWING_INTEGRATOR, args.baseline),
                "candidate": (args.integrator, args.accuracy)}
    print(f"{args.n} swings per line of {Path(args.study).name} study, root seed {args.seed}: "
          f"{SWING_INTEGRATOR} {args.baseline:g} against {args.integrator} {args.accuracy:g}")
    record = {"study": Path(args.study).name, "seed": args.seed, "samples": args.n,
              "reference_swings": args.reference,
              "settings": {k: [i, a] for k, (i, a) in settings.items()}, "lines": []}
    with multiprocessing.get_context("fork").Pool(2) as pool:
        for incline in (float(v) for v in args.inclines.split(",")):
            sc = replace(base.params.scenario, incline_deg=incline)
            study = replace(base, params=base.params.with_(scenario=sc), seed=args.seed)
            rows = compare(pool, study, args.n, settings)
            a, b = rows["baseline"], rows["candidate"]
            same = np.mean([x[0] == y[0] for x, y in zip(a, b)])
            both = [(x[1], y[1]) for x, y in zip(a, b) if "captured" == x[0] == y[0]]
            dv = np.median([abs(x - y) for x, y in both]) if both else math.nan
            line = [f"{incline:+.0f} deg: same outcome {100 * same:.1f} %, "
                    f"median |change| of capture speed {dv:.4f} m/s"]
            entry = {"incline_deg": incline, "same_outcome": float(same),
                     "median_change_mps": float(dv), "settings": {}}
            record["lines"].append(entry)
            for name, r in rows.items():
                k, p50, p95 = _rates(r)
                entry["settings"][name] = {"captured": k, "samples": len(r), "p50_mps": float(p50),
                                           "p95_mps": float(p95)}
                lo, hi = wilson(k, len(r))
                line.append(f"  {name}: {k}/{len(r)} captured ({100 * lo:.1f}-{100 * hi:.1f} %), "
                            f"p50 {p50:.3f} p95 {p95:.3f} m/s, "
                            f"{1000 * np.mean([x[2] for x in r]):.0f} ms/swing")
            walls = [np.mean([x[2] for x in r]) for r in rows.values()]
            line.append(f"  wall time candidate / swing: {walls[1] / walls[0]:.2f}")
            if args.reference:
                ref = compare(pool, study, args.reference,
                              {"reference": ("runge_kutta5", 1e-10)})["reference"]
                for name, r in rows.items():
                    err = [abs(x[1] - y[1]) for x, y in zip(r, ref)
                           if "captured" == x[0] == y[0]]
                    entry["settings"][name]["rk5_median_error_mps"] = (
                        float(np.median(err)) if err else None)
                    line.append(f"  {name} against RK5 1e-10 on {args.reference}: median "
                                f"|error| {np.median(err) if err else math.nan:.5f} m/s")
            print("\n".join(line), flush=True)
        default = compare(pool, None, 20, settings)
    kept = sum(x[0] == y[0] for x, y in zip(default["baseline"], default["candidate"]))
    print(f"the default swing (bplir swing --seed K), seeds 0-19: {kept} of 20 keep their "
          "outcome", flush=True)
    if args.json:
        record["default_seeds_kept"] = int(kept)
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(record, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
