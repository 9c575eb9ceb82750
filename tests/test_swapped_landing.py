"""The swapped robot's landing shot: its elbow's rate capped near the line."""
import dataclasses as dc
import math
from pathlib import Path

import numpy as np
import pytest

from bplir_drake.params import preset, swapped
from bplir_drake.systems.landing import ApexShot

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _shot(cap: float) -> ApexShot:
    p = swapped(preset("dissertation"))
    landing = dc.replace(p.landing, shoot_rate_cap=cap)
    return ApexShot.from_params(p.plant, p.friction, 0.0, landing)


def test_the_cap_brakes_an_elbow_turning_faster_near_the_line_only():
    """Near the aimed height an elbow at 0.6 rad/s is braked back towards
    0.3 rad/s (``landing_rate_gain`` x 0.3 rad/s of deceleration, computed
    torque), unless the shot already slows it; far below the line, or with
    the cap off, the shot's torque stands."""
    shot, free = _shot(0.3), _shot(0.0)
    near = next(np.array([q1, 2.37, 0.3, 0.6]) for q1 in np.linspace(0.5, 1.0, 501)
                if shot.height - 0.01 < shot.landing.height([q1, 2.37, 0.3, 0.6]) < shot.height)
    brake = shot._computed(near, -shot.landing.rate_gain * 0.3)
    assert shot._capped(near, brake + 5.0) == pytest.approx(brake)
    assert shot._capped(near, brake - 5.0) == brake - 5.0
    assert free._capped(near, brake + 5.0) == brake + 5.0
    turning_back = near * np.array([1, 1, 1, -1])
    assert shot._capped(turning_back, -50.0) == pytest.approx(
        shot._computed(turning_back, shot.landing.rate_gain * 0.3))
    low = np.array([0.0, 2.37, 0.3, 0.6])
    assert shot.landing.height(low) < shot.height - shot.hold_depth
    assert shot._capped(low, 19.0) == 19.0


def test_the_swapped_robots_short_swing_lands_with_its_elbow_capped():
    """Draw 4 of the realistic traversal study (tuning root seed 777), 48 V,
    the swapped robot's 0.9 m swing on a flat line (the dense stretch's): a
    1.4 N m gust slows link 1 just before the apex, the uncapped shot flings
    the elbow in at the torque limit and crashes (0.62 m/s); with
    ``traverse.swapped_shoot_rate_cap`` it lands (measured 0.23 m/s)."""
    from bplir_drake.analysis.montecarlo.sampling import sample_params
    from bplir_drake.analysis.montecarlo.study import load_study
    from bplir_drake.analysis.swing.run import SwingRunner
    from bplir_drake.analysis.traverse.run import swing_params

    study = load_study(EXAMPLES / "study_traverse.toml").with_(seed=777)
    study = dc.replace(study, params=study.params.with_hardware("48v"))
    p, seed, _ = sample_params(study, 4)
    q = swing_params(p, 2, 0.9, 0.0)
    assert q.landing.shoot_rate_cap == p.traverse.swapped_shoot_rate_cap > 0.0
    assert swing_params(p, 1, 0.9, 0.0).landing.shoot_rate_cap == 0.0
    runner = SwingRunner()
    free = runner.run(q.with_(landing=dc.replace(q.landing, shoot_rate_cap=0.0)), seed=seed)
    assert free.summary["outcome"] == "crash" and free.summary["capture_speed_mps"] > 0.55
    s = runner.run(q, seed=seed).summary
    assert s["outcome"] == "captured" and s["capture_speed_mps"] < 0.3
    assert abs(s["landing_error_m"]) < p.traverse.landing_tolerance
    assert not math.isnan(s["landing_height_error_m"])
