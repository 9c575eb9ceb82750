"""Statistics of a study's rows: success rate with its Wilson interval,
outcome classes, percentiles, and which quantity drives the result."""
from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np

from ...io import package_version
from .study import KNOCK_FIELDS, Study, study_rows

# ------------------------------------------------------------ statistics

def wilson_interval(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (no continuity
    correction; the normal quantile from the standard library, so a study's
    summary does not import scipy.stats)."""
    if n == 0:
        return (math.nan, math.nan)
    z = NormalDist().inv_cdf(0.5 + confidence / 2)
    p, z2 = successes / n, z * z
    centre = (p + z2 / (2 * n)) / (1 + z2 / n)
    half = z * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / (1 + z2 / n)
    lo = 0.0 if successes == 0 else max(0.0, centre - half)   # exact at the ends
    hi = 1.0 if successes == n else min(1.0, centre + half)
    return (lo, hi)


def samples_to_show(rate: float, bar: float, confidence: float = 0.95) -> int | None:
    """The fewest samples at which a study succeeding at ``rate`` has the
    lower end of its Wilson interval at or above ``bar`` (None: a rate at
    or below the bar is never shown above it, however many samples)."""
    if not rate > bar:
        return None
    z2 = NormalDist().inv_cdf(0.5 + confidence / 2) ** 2

    def lower(n: float) -> float:   # the interval's lower end at rate ``rate``, n samples
        centre = (rate + z2 / (2 * n)) / (1 + z2 / n)
        return centre - math.sqrt(z2 * rate * (1 - rate) / n + z2 * z2 / (4 * n * n)) / (1 + z2 / n)

    lo, hi = 1, 2
    while lower(hi) < bar:   # it rises with n towards ``rate``
        lo, hi = hi, 2 * hi
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if lower(mid) < bar else (lo, mid)
    return hi


PERCENTILE_FIELDS = ("capture_speed_mps", "swing_time_s", "peak_torque_Nm", "peak_motor_power_W",
                     "peak_voltage_V", "on_envelope_s", "energy_in_J",
                     "max_estimation_error_rad")


def percentiles(rows: list[dict], fields) -> dict:
    """p5, p50, p95 and max of each field over the rows where it is finite
    (an empty table for a field with no finite value)."""
    pct = {}
    for f in fields:
        v = np.array([r[f] for r in rows if r.get(f) is not None and np.isfinite(r[f])],
                     dtype=float)
        pct[f] = ({q: float(np.percentile(v, int(q[1:]))) for q in ("p5", "p50", "p95")}
                  | {"max": float(v.max())}) if v.size else {}
    return pct


def summarize(study: Study, rows: list[dict]) -> dict:
    """The statistics of a study's rows: success rate over the samples that ran with its 95 %
    Wilson interval, outcome counts, failed and unsuccessful samples, percentiles of the
    result fields."""
    rows = study_rows(rows)
    ran = [r for r in rows if r.outcome != "error"]
    errors = [r for r in rows if r.outcome == "error"]
    k = sum(bool(r.success) for r in ran)
    n = len(ran)
    lo, hi = wilson_interval(k, n)
    outcomes: dict[str, int] = {}
    for r in rows:
        outcomes[r.outcome] = outcomes.get(r.outcome, 0) + 1
    pct = percentiles(ran, PERCENTILE_FIELDS)
    return {
        "samples": len(rows),
        "samples_requested": study.samples,
        "seed": study.seed,
        "successes": k,
        "success_rate": k / n if n else math.nan,
        "success_rate_ci95": [lo, hi],
        "ci_method": "Wilson score, 95 %, over samples that ran (errors excluded)",
        "outcomes": outcomes,
        "failed_samples": [{"index": r.index, "seed": r.seed, "error": r.error}
                           for r in errors],
        "unsuccessful_samples": [{"index": r.index, "outcome": r.outcome,
                                  "capture_speed_mps": r.capture_speed_mps}
                                 for r in ran if not r.success],
        "fixed_gripper_opened_early": sum(bool(r.fixed_gripper_open) and not r.success
                                          for r in rows),
        "percentiles": pct,
        "uncertain": {d.name: d.as_dict() for d in study.distributions},
        "incline_deg": study.params.scenario.incline_deg,
        "controller": study.params.controller.preset,
        "hardware": {"supply_voltage_V": study.params.motor.supply_voltage,
                     "voltage_envelope": study.params.motor.envelope,
                     "line_sensor_range_m": study.params.line_sensor.range
                     if study.params.line_sensor.fitted else 0.0},
        "package_version": package_version(),
    } | (_traverse_summary(study, ran) if study.line is not None else {})


def _traverse_summary(study: Study, ran: list[dict]) -> dict:
    """A traversal study's extras: the line, the miss classes (outcome by
    swing that failed) and percentiles of the traversal figures."""
    misses: dict[str, int] = {}
    for r in ran:
        if not r.success:
            swing = r.failed_swing
            where = f" (swing {int(swing) + 1})" if np.isfinite(swing) else ""
            key = f"{r['outcome']}{where}"
            misses[key] = misses.get(key, 0) + 1
    pct = percentiles(ran, ("time_s", "energy_per_m_J", "speed_m_per_min",
                            "peak_capture_impulse_Ns", "peak_i2t_A2s", "obstacles_passed"))
    return {"traverse": {"line": study.line.get("name", "line"), "miss_classes": misses,
                         "percentiles": pct}} | (
        {"knockdown": knockdown_summary(study, ran)} if study.knocks is not None else {})


def knockdown_summary(study: Study, ran: list[dict]) -> dict:
    """A knocked traversal study's score: the knocks, the mean uptime, runs
    without a fall with the 95 % Wilson interval, falls by cause and those
    the interlock caused, knocks met by phase."""
    n = len(ran)
    clean = sum(not r.fall for r in ran)
    causes: dict[str, int] = {}
    for r in ran:
        if r.fall:
            causes[r.fall_cause] = causes.get(r.fall_cause, 0) + 1
    phases = [f for f in KNOCK_FIELDS if f.startswith("knocks_")]
    return {"knocks": study.knocks, "runs": n,
            "mean_uptime": float(np.mean([r.uptime for r in ran])) if n else math.nan,
            "no_fall": clean, "no_fall_rate": clean / n if n else math.nan,
            "no_fall_ci95": list(wilson_interval(clean, n)),
            "falls_by_cause": causes,
            "interlock_falls": sum(bool(r.interlock_fall) for r in ran),
            "knocks_met": sum(int(r.knocks) for r in ran),
            "knocks_by_phase": {f[len("knocks_"):]: sum(int(r[f]) for r in ran) for f in phases}}


#: the fewest samples that rank the drawn quantities by their correlation
#: with the result (below it, |r| of unrelated quantities reaches 0.4 by chance)
MIN_INFLUENCE_SAMPLES = 20


def influence(study: Study, rows: list[dict]) -> dict[str, float]:
    """How strongly each uncertain quantity drives the result: |correlation|
    with success when both outcomes occur, else with the capture speed;
    empty with fewer than :data:`MIN_INFLUENCE_SAMPLES` samples run, and
    without the quantities of hardware the robot does not have (a line
    sensor's errors on a robot with the IMUs alone)."""
    rows = study_rows(rows)
    ran = [r for r in rows if r.outcome != "error"]
    if len(ran) < MIN_INFLUENCE_SAMPLES:
        return {}
    succ = np.array([float(r.success) for r in ran])
    if 0 < succ.sum() < len(succ):
        target = succ
    else:
        target = np.array([r.capture_speed_mps for r in ran], dtype=float)
    out = {}
    fitted = study.params.line_sensor.fitted
    for name in study.names:
        if name.startswith("line_sensor.") and not fitted:
            continue
        x = np.array([r[name] for r in ran], dtype=float)
        ok = np.isfinite(x) & np.isfinite(target)
        if ok.sum() > 2 and np.std(x[ok]) > 0 and np.std(target[ok]) > 0:
            out[name] = float(abs(np.corrcoef(x[ok], target[ok])[0, 1]))
        else:
            out[name] = 0.0
    return out


