"""asv benchmarks of the package: the default swing's real-time factor
against a same-run reference loop, the 100 Hz chain's wall time per tick, a
200-swing study and the commission of a robot whose plans are shipped.
Ratios and per-tick costs are ``track_*`` figures (asv records the number
returned); whole jobs are ``time_*``."""
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))


def _swing_rate(seeds: int = 3) -> tuple[float, float]:
    """(simulated s per wall s of the default closed-loop swing, wall s per
    100 Hz tick), a built diagram reused as a study reuses it."""
    from bplir_drake.analysis.swing.swing_runner import SwingRunner
    from bplir_drake.params import BplirParams

    runner, p = SwingRunner(), BplirParams()
    runner.run(p, seed=0)   # build and warm
    wall = simulated = 0.0
    for seed in range(1, seeds + 1):
        t0 = time.perf_counter()
        res = runner.run(p, seed=seed)
        wall += time.perf_counter() - t0
        simulated += float(res.logs["state"].t[-1])
    return simulated / wall, wall / (simulated / p.controller.period)


class Swing:
    """The default swing."""

    timeout = 300

    def track_rate_over_reference(self):
        """The closed loop's simulated seconds per wall second over a
        same-run reference loop's (the DFKI simulator's kind)."""
        from peer_loop import reference_loop_rate

        return _swing_rate()[0] / reference_loop_rate()
    track_rate_over_reference.unit = "ratio"

    def track_tick_us(self):
        """Wall microseconds per 100 Hz tick of the whole closed loop."""
        return 1e6 * _swing_rate()[1]
    track_tick_us.unit = "us"


class Study:
    """A 200-swing study on the machine's cores."""

    timeout = 600

    def time_study_200(self):
        from bplir_drake.analysis.montecarlo import Study as MC, run_study

        with tempfile.TemporaryDirectory() as d:
            run_study(MC(samples=200, seed=0), Path(d) / "mc")


class Commission:
    """The commission of the 0.7-scaled BPLIR on one grid point (its plans
    are shipped: what is timed is the library, the gains and two studies)."""

    timeout = 600

    def time_commission_scaled(self):
        import os

        from bplir_drake.analysis.commission import commission
        from bplir_drake.params import load_toml

        with tempfile.TemporaryDirectory() as d:
            os.environ["BPLIR_CACHE_DIR"] = d
            commission(load_toml(ROOT / "examples" / "scaled_bplir.toml"), spacings=[0.84],
                       samples=20, seed=2)
