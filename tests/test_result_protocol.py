"""One result protocol: every result -- a swing, a study, a traversal, a
benchmark, an estimate, a calibration, an observability study -- has
``summary()`` (a dict), ``to_dict()``, ``to_json()`` (strict JSON that
reads back as the dict), ``plot()`` (a Figure) and ``to_pandas()`` (its
rows or time series, with the columns the package's files use)."""
import json
from pathlib import Path

import numpy as np
import pytest

from bplir_drake.io import dumps_strict

ROOT = Path(__file__).resolve().parents[1]


def _swing(tmp):
    from bplir_drake.analysis.swing import run_swing
    from bplir_drake.analysis.swing.logs import LOG_COLUMNS
    from bplir_drake.params import BplirParams

    res = run_swing(BplirParams())
    return res, list(LOG_COLUMNS), len(res.logs["state"].t)


def _study(tmp):
    from bplir_drake.analysis.montecarlo import Study, run_study
    from bplir_drake.analysis.montecarlo.store import columns

    study = Study(samples=2, seed=4)
    return run_study(study, tmp / "mc", workers=1), columns(study), 2


def _traversal(tmp):
    from bplir_drake.analysis.traverse.line import load_line
    from bplir_drake.analysis.traverse.traversal import ROW_FIELDS, run_traverse
    from bplir_drake.params import BplirParams

    res = run_traverse(load_line(ROOT / "examples" / "line_flat.toml"), BplirParams())
    return res, list(ROW_FIELDS), len(res.rows)


def _benchmark(tmp):
    from bplir_drake.analysis.montecarlo.benchmark import run_benchmark
    from bplir_drake.params import BplirParams

    res = run_benchmark(BplirParams(), ("plan",), quick=True, categories=("delay",), workers=1)
    return res, list(res["rows"][0]), 2


def _estimate(tmp):
    from bplir_drake.analysis.estimation.filter_study import simulate_estimation
    from bplir_drake.estimation import estimate
    from bplir_drake.params import BplirParams

    p = BplirParams()
    r = simulate_estimation(p, duration=1.0)
    res = estimate(r.t, r.imu, p.estimator.chapter5())
    return res, ["t", "theta1", "theta2", "omega1", "omega2", "gyro_bias1", "gyro_bias2"], len(r.t)


def _calibration(tmp):
    from bplir_drake.analysis.identification.calibration import synthetic_log
    from bplir_drake.analysis.identification.fit import calibrate
    from bplir_drake.params import BplirParams

    p = BplirParams()
    res = calibrate(p, synthetic_log(p, free_time=1.5, torque_time=1.5), ("fv1",))
    return res, None, 1


def _observability(tmp):
    from bplir_drake.analysis.estimation.observability import observability_along
    from bplir_drake.analysis.estimation.filter_study import simulate_estimation
    from bplir_drake.params import BplirParams

    p = BplirParams()
    r = simulate_estimation(p, duration=1.0)
    res = observability_along(r.t, r.truth, r.imu[:, [2, 4]], p.estimator)
    return res, ["t", "rank_gyro", "rank_full", "smin_gyro", "smin_full", "a31", "a42"], len(r.t)


#: the time-series columns of a plan, a free swing and a replay
PLAN_COLUMNS = ["t_s", "q1_rad", "q2_rad", "q1d_radps", "q2d_radps", "tau_Nm", "friction1_Nm",
                "friction2_Nm", "power_W", "voltage_V"]
FREE_SWING_COLUMNS = ["t_s", "q1_rad", "q2_rad", "q1d_radps", "q2d_radps", "tau_Nm",
                      "friction1_Nm", "friction2_Nm", "kinetic_J", "potential_J", "total_J",
                      "energy_rate_W"]
REPLAY_COLUMNS = ["t_s", "q1_logged_rad", "q2_logged_rad", "q1_simulated_rad",
                  "q2_simulated_rad"]


def _plan(tmp):
    from bplir_drake.params import BplirParams
    from bplir_drake.planning.solve import tracking_plan

    plan, _ = tracking_plan(BplirParams())
    return plan, PLAN_COLUMNS, len(plan.times)


def _free_swing(tmp):
    from bplir_drake.analysis.model.freeswing import simulate_free_swing
    from bplir_drake.params import BplirParams

    res = simulate_free_swing(BplirParams(), (0.5, 0.2), 0.5)
    return res, FREE_SWING_COLUMNS, len(res.t)


def _replay(tmp):
    from bplir_drake.analysis.identification.calibration import synthetic_log
    from bplir_drake.analysis.identification.torque_replay import replay_torque
    from bplir_drake.params import BplirParams

    p = BplirParams()
    log = synthetic_log(p, free_time=1.0, torque_time=1.0)
    res = replay_torque(p, log)
    return res, REPLAY_COLUMNS, len(log.t)


MAKERS = {"swing": _swing, "study": _study, "traversal": _traversal, "benchmark": _benchmark,
          "estimate": _estimate, "calibration": _calibration, "observability": _observability,
          "plan": _plan, "free swing": _free_swing, "replay": _replay}


@pytest.mark.slow
@pytest.mark.parametrize("kind", list(MAKERS))
def test_every_result_speaks_one_protocol(kind, tmp_path):
    from matplotlib.figure import Figure

    from bplir_drake.io import Result

    res, columns, rows = MAKERS[kind](tmp_path)
    assert isinstance(res, Result)
    summary = res.summary()
    assert isinstance(summary, dict) and summary
    assert json.loads(res.to_json()) == json.loads(dumps_strict(res.to_dict()))
    drawn = {"params": __import__("bplir_drake.params").params.BplirParams()} \
        if kind == "plan" else {}   # a plan is drawn with the robot it is for
    assert isinstance(res.plot(**drawn), Figure)
    frame = res.to_pandas()
    assert len(frame) == rows
    if columns is not None:
        assert list(frame.columns) == columns
    else:   # one row of the summary's plain figures
        assert {"rmse_before_rad", "rmse_after_rad", "simulations"} <= set(frame.columns)
    numbers = frame.select_dtypes("number")
    assert numbers.shape[1] > 0 and np.isfinite(numbers.to_numpy(dtype=float)).any()


def test_a_swings_summary_reads_as_fields_as_a_mapping_and_called():
    from bplir_drake.analysis.swing import run_swing
    from bplir_drake.params import BplirParams

    s = run_swing(BplirParams()).summary
    assert s.outcome == s["outcome"] == s()["outcome"] == "captured"
    assert s() == dict(s)
