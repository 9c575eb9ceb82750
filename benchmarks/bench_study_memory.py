"""Benchmark: the resident memory of a study's workers over a long study,
in one run: a 500-sample and a 5000-sample run of the realistic study
(``examples/study_realistic.toml``, whose samples differ in structure, so
that a worker builds a diagram for nearly every swing), each in a fresh
process with 2 workers.  Goal (issue 69): the 5000-swing study's peak
within 20 % of the 500-swing one's.

Run: python benchmarks/bench_study_memory.py [SMALL LARGE]   (default 500
5000; prints figures, not a test).
"""
import json
import subprocess
import sys

CHILD = r"""
import json, resource, sys, tempfile, time
from bplir_drake.analysis import montecarlo as mc

n = int(sys.argv[1])
study = mc.load_study(sys.argv[2]).with_(samples=n, seed=900)
t0 = time.perf_counter()
with tempfile.TemporaryDirectory() as d:
    summary = mc.run_study(study, d, workers=2)
print(json.dumps({"samples": n, "wall_s": time.perf_counter() - t0,
                  "outcomes": summary["outcomes"],
                  "parent_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "worker_MB": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024}))
"""


def peak(n: int) -> dict:
    """The figures of a fresh process running an ``n``-sample study."""
    out = subprocess.run([sys.executable, "-c", CHILD, str(n), "examples/study_realistic.toml"],
                         capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main():
    small, large = (int(a) for a in sys.argv[1:3]) if len(sys.argv) > 2 else (500, 5000)
    runs = [peak(n) for n in (small, large)]
    for r in runs:
        print(f"{r['samples']} swings: {r['wall_s']:.0f} s, peak worker {r['worker_MB']:.0f} MB, "
              f"parent {r['parent_MB']:.0f} MB ({r['outcomes']})")
    ratio = runs[1]["worker_MB"] / runs[0]["worker_MB"]
    print(f"peak worker memory {large} / {small} swings: {ratio:.2f} (goal <= 1.20)")


if __name__ == "__main__":
    main()
