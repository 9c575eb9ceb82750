"""Benchmark: peak resident memory of a long traversal (issue 44, "bounded
memory"), and how it grows with the number of obstacles, in one run.

Run: python benchmarks/bench_traverse_memory.py [N ...]   (default 20 1000;
prints figures, not a test).  Each N runs in a fresh process: a flat line
with N obstacles (0.3 m spacer dampers every 6 m), the default robot with
noise-free IMUs and nominal friction (every swing alike, so that the
traversal lasts all N obstacles), seed 0, the motion log written to a file as it goes (as ``bplir traverse``
does; a line of more than 20 obstacles runs its swings in a worker process
replaced every 50 swings).  Goal: <= 500 MB peak for 1000 obstacles, the
process and its worker together.
"""
import json
import subprocess
import sys
import tempfile

CHILD = r"""
import dataclasses as dc, json, resource, sys, tempfile, time
from pathlib import Path
from bplir_drake.analysis.traverse.line import line_from_dict
from bplir_drake.analysis.traverse.traversal import run_traverse
from bplir_drake.params import preset

n = int(sys.argv[1])
line = line_from_dict({"length": 6.0 * n + 4.0, "start": 1.2, "obstacles": [
    {"position": 3.0 + 6.0 * k, "width": 0.3, "name": "spacer damper"} for k in range(n)]})
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.perf_counter()
with tempfile.TemporaryDirectory() as d:
    p = preset()   # every swing the nominal one, so that the traversal lasts
    p = p.with_(imu=dc.replace(p.imu, noise=False),
                scenario=dc.replace(p.scenario, friction_uncertainty=0.0))
    res = run_traverse(line, p, seed=0, motion=Path(d) / "motion.f64")
    samples = res.motion.samples
wall = time.perf_counter() - t0
print(json.dumps({"obstacles": n, "outcome": res.totals["outcome"],
                  "passed": res.totals["obstacles_passed"], "swings": res.totals["swings"],
                  "peak_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "worker_MB": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024,
                  "start_MB": base / 1024, "wall_s": wall, "motion_samples": samples}))
"""


def main():
    sizes = [int(a) for a in sys.argv[1:]] or [20, 1000]
    rows = []
    for n in sizes:
        out = subprocess.run([sys.executable, "-c", CHILD, str(n)], capture_output=True,
                             text=True, cwd=tempfile.gettempdir())
        if out.returncode:
            print(out.stderr.strip().splitlines()[-1])
            continue
        r = json.loads(out.stdout.strip().splitlines()[-1])
        rows.append(r)
        print(f"{n} obstacles: {r['outcome']} ({r['passed']} passed, {r['swings']} swings) in "
              f"{r['wall_s']:.0f} s; peak resident {r['peak_MB']:.0f} MB "
              f"(after import {r['start_MB']:.0f} MB), its swings' worker process at most "
              f"{r['worker_MB']:.0f} MB (0: none), together at most "
              f"{r['peak_MB'] + r['worker_MB']:.0f} MB; {r['motion_samples']} motion samples "
              "written as they went", flush=True)
    if len(rows) >= 2:
        a, b = rows[0], rows[-1]
        per = ((b["peak_MB"] + b["worker_MB"] - a["peak_MB"] - a["worker_MB"])
               / max(b["swings"] - a["swings"], 1))
        print(f"growth {per * 1e3:.0f} kB per swing; goal <= 500 MB for 1000 obstacles")


if __name__ == "__main__":
    main()
