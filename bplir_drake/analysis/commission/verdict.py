"""The verdict on a commissioned robot: a verification study at each
incline with uncertainty scaled to the robot, and, where a manoeuvre has no
plan, the physical limit that stops it with the number that shows it.

The study draws what a real robot gets wrong, in the robot's own units:
masses and inertias +/-10 %, centres of mass +/-0.5 % of the reach, link
lengths +/-0.1 % of it, friction +/-20 %, its IMUs' noise x0.5 to x2, gyro
biases +/-0.03 rad/s, accelerometer misalignment +/-2.5 deg, actuation delay
0-20 ms, steady wind (sigma 0.2 % and 0.1 % of m g L on the joints) and
gusts of up to 2 % of m g L once a second, the grip spacing over the
commissioned grid's; the capture must land within 0.1 D of the planned grip.  (The
default robot's instance of these rules is its realistic study.)
"""
from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from ..montecarlo.study import Distribution, Study
from ..montecarlo.statistics import samples_to_show, wilson_interval
from ...params.derive import free_link_tilt, UPRIGHT_FREE_LINK
from .margins import motor_figures
from .rows import StudyVerdict
from .similarity import Scales

#: the verification study's uncertainty: (name, kind, size); kind "rel" is
#: relative to the nominal value, "reach" a share of the reach L, "torque" a
#: share of m g L, "abs" in the parameter's own unit
STUDY_RULES = (
    ("true_plant.m1", "rel", 0.1), ("true_plant.m2", "rel", 0.1),
    ("true_plant.I1", "rel", 0.1), ("true_plant.I2", "rel", 0.1),
    ("true_plant.lc1", "reach", 0.0046), ("true_plant.lc2", "reach", 0.0046),
    ("true_plant.l1", "reach", 0.00093), ("true_plant.l2", "reach", 0.00093),
    ("true_friction.fv1", "rel", 0.2), ("true_friction.fv2", "rel", 0.2),
    ("true_friction.fc1", "rel", 0.2), ("true_friction.fc2", "rel", 0.2),
    ("imu.gyro_bias1", "abs", 0.03), ("imu.gyro_bias2", "abs", 0.03),
    ("imu.misalign1", "abs", 0.0436), ("imu.misalign2", "abs", 0.0436),
)
#: steady wind on each joint (normal, sigma) and the gusts' peak (uniform
#: 0 to it), as shares of m g L
WIND_SHARES, GUST_SHARE = (0.002, 0.001), 0.02
#: the capture must land within this share of D of the planned grip (2 D)
LANDING_SHARE = 0.1
#: a verification study passes when the lower end of its capture rate's
#: Wilson 95 % interval is at or above this
READY_RATE = 0.97
#: the share a robot is taken to capture when choosing how many swings a
#: verification study runs by default: at it the study can show READY_RATE
SIZING_RATE = 0.99
#: the verification study's default size (swings): the fewest at which a
#: robot capturing SIZING_RATE shows READY_RATE (280)
DEFAULT_SAMPLES = samples_to_show(SIZING_RATE, READY_RATE)


def verification_study(params, incline: float, samples: int, seed: int,
                       spacings=None) -> Study:
    """The verification study of the robot ``params`` on a line of
    ``incline`` degrees (module docstring), the grip spacing drawn uniformly
    between the least and the largest of ``spacings`` (m; default the
    robot's own spacing, fixed)."""
    s = Scales.of(params.plant)
    lo, hi = (min(spacings), max(spacings)) if spacings else (params.scenario.grip_spacing,) * 2
    sc = dc.replace(params.scenario, incline_deg=float(incline), gust_rate=1.0,
                    gust_duration=0.1, min_travel_fraction=2.0 - LANDING_SHARE,
                    grip_spacing=(lo + hi) / 2)
    est = dc.replace(params.estimator, standstill_samples=500)
    base = params.with_(scenario=sc, estimator=est)
    dists = []
    for name, kind, size in STUDY_RULES:
        if kind == "rel":
            dists.append(Distribution(name, "uniform", rel=size))
        else:
            dists.append(Distribution(name, "uniform", abs=size * (s.length if kind == "reach"
                                                                   else 1.0)))
    imu = params.imu
    for name, sigma in (("imu.gyro_sigma", imu.gyro_sigma), ("imu.accel_sigma", imu.accel_sigma)):
        if sigma > 0:   # x0.5 to x2 of the robot's own noise
            dists.append(Distribution(name, "uniform", center=1.25 * sigma, abs=0.75 * sigma))
    if hi > lo:
        dists.append(Distribution("scenario.grip_spacing", "uniform", abs=(hi - lo) / 2))
    dists.append(Distribution("scenario.actuation_delay", "uniform", center=0.01, abs=0.01))
    for k, share in enumerate(WIND_SHARES, 1):
        dists.append(Distribution(f"scenario.wind_torque{k}", "normal", abs=share * s.torque))
    g = GUST_SHARE * s.torque
    dists.append(Distribution("scenario.gust_torque", "uniform", center=g / 2, abs=g / 2))
    return Study(base, tuple(dists), samples, seed)


def study_verdict(incline: float, summary: dict) -> StudyVerdict:
    """One incline's line of the verdict from its study's summary:
    ``verdict`` is "ready" (the Wilson 95 % interval's lower end at or above
    :data:`READY_RATE`), "not shown" (the rate above it, the interval not:
    ``samples_to_show`` swings at this rate would show it) or "below"."""
    n, k = summary["samples"], summary["successes"]
    lo, hi = wilson_interval(k, n)
    rate = k / n if n else math.nan
    verdict = "ready" if lo >= READY_RATE else "not shown" if rate > READY_RATE else "below"
    pct = summary["percentiles"]
    speed = pct.get("capture_speed_mps", {})
    return StudyVerdict(incline_deg=float(incline), captured=k, samples=n,
                        rate=rate, wilson95=[lo, hi], verdict=verdict,
                        samples_to_show=samples_to_show(rate, READY_RATE) if n else None,
                        capture_speed_p50_mps=speed.get("p50", math.nan),
                        capture_speed_p95_mps=speed.get("p95", math.nan),
                        peak_voltage_V=pct.get("peak_voltage_V", {}).get("max", math.nan),
                        peak_torque_Nm=pct.get("peak_torque_Nm", {}).get("max", math.nan),
                        outcomes=summary["outcomes"])


def no_plan_reason(params, incline: float, spacing: float, guess, tried=()) -> str:
    """Why the robot has no plan at this grid point: a bound with its
    numbers where one shows none can exist (the grip beyond the reach, the
    elbow's effective peak torque within its dead-band), else "no plan
    found" with the solves ``tried`` and, as a hint and not a bound, what
    the scaled swing of a similar robot (``guess``) asks of the motor."""
    p, m = params.plant, params.motor
    reach = p.l1 + p.l2
    where = f"{incline:+g} deg, {spacing:g} m"
    if spacing >= reach:
        return (f"no plan at {where}, a bound: the grip spacing is beyond the reach l1 + l2 = "
                f"{reach:.3f} m; a spacing below it would")
    peak = motor_figures(params)["peak_torque_Nm"]
    if peak <= m.deadband:
        return (f"no plan at {where}, a bound: the elbow's effective peak torque {peak:.3g} N m "
                f"is within the motor's {m.deadband:.3g} N m dead-band, so the elbow never turns")
    line = f"no plan found at {where} (not a bound: a plan may exist)"
    if tried:
        line += f"; tried {len(tried)} solves: " + ", ".join(tried)
    if guess is not None:
        tau = float(np.max(np.abs(guess.torque)))
        rate = float(np.max(np.abs(guess.states[:, 3])))
        line += (f"; the nearest similar robot's {_kind(params)} scaled to this one asks "
                 f"{tau:.2f} N m (effective peak torque: {peak:.3g} N m)")
        if m.envelope:
            free = m.max_voltage / (m.back_emf_constant * m.gear_ratio)
            line += (f" and {rate:.1f} rad/s at the elbow (no-load rate at "
                     f"{m.supply_voltage:g} V: {free:.1f} rad/s)")
    return line


def _kind(params) -> str:
    """The manoeuvre of ``params`` as a verdict names it."""
    if params.scenario.start == "hanging":
        return "swing from hanging"
    return "pump" if params.scenario.manoeuvre_of() == "pump" else "single swing"


def _short_of_the_grip(params, rows, misses) -> list[str]:
    """The timeouts whose gripper came within twice the capture distance of
    the line and stopped there (most of the misses), and the grip spacing
    they drew against the study's: a swing that falls just short; where the
    robot's free link ends within :data:`UPRIGHT_FREE_LINK` of upright at
    those spacings, why the landing cannot make that up."""
    band = params.gripper.capture_distance
    short = [r for r in misses if r.outcome == "timeout"
             and r.closest_distance_m < 2.0 * band]
    if len(short) * 2 <= len(misses):
        return []
    gap = 1e3 * float(np.median([r.closest_distance_m for r in short]))
    own = params.scenario.grip_spacing   # a study on one spacing draws none

    def spacing(r):
        return r.get("scenario.grip_spacing", own)

    d_short = float(np.mean([spacing(r) for r in short]))
    d_all = float(np.mean([spacing(r) for r in rows]))
    line = (f"{len(short)} of {len(misses)} misses stop short: the gripper's closest approach "
            f"{gap:.1f} mm (median) against the {1e3 * band:g} mm capture distance, at grip "
            f"spacings {d_short:.3f} m on average (the study's {d_all:.3f} m)")
    tilt = free_link_tilt(params, d_short)
    if tilt < UPRIGHT_FREE_LINK:
        line += (f"; there the free link ends {math.degrees(tilt):.0f} deg from upright, where "
                 f"turning it lifts the gripper at {math.sin(tilt):.2f} of the speed it moves "
                 "it: the landing cannot make up a swing that falls short"
                 + (", a shorter grip spacing would" if d_short > d_all else ""))
    return [line]


def miss_reasons(params, rows, plans) -> list[str]:
    """What the misses of a verification study (its ``rows``) show, with
    the numbers: the estimate lost (what follows from it is not listed), the
    elbow held at its torque limit (a weak motor when the plans already use
    most of it, else the feedback's fight), the swing stopping just short
    of the grip, or the gripper arriving faster than the gripper's capture
    speed."""
    misses = [r for r in rows if r.outcome not in ("captured", "error")]
    if not misses:
        return []
    n = len(misses)
    far = [r for r in misses if r.max_estimation_error_rad > 0.1]
    if len(far) * 2 > n:
        err = float(np.median([r.max_estimation_error_rad for r in far]))
        return [f"the estimate is lost: {len(far)} of {n} misses had it more than 0.1 rad from "
                f"the truth (median {err:.2f} rad)"]
    out, limit = [], params.controller.torque_limit
    saturated = [r for r in misses if r["peak_torque_Nm"] >= 0.99 * limit]
    if len(saturated) * 2 > n:
        used = max((p.peak_torque for p in plans if p is not None and p.feasible), default=0.0)
        share = used / limit
        out.append(f"{len(saturated)} of {n} misses hold the elbow at its {limit:g} N m limit "
                   f"(the plans use up to {used:.2f} N m, {100 * share:.0f} % of it)"
                   + (": more elbow torque would help" if share >= 0.8 else ""))
    out += _short_of_the_grip(params, rows, misses)
    crashes = [r.capture_speed_mps for r in misses if r.outcome == "crash"]
    speed = params.gripper.capture_speed
    if crashes and len(crashes) * 2 > n:
        out.append(f"{len(crashes)} of {n} misses reach the line faster than the gripper's "
                   f"{speed:g} m/s (median {float(np.median(crashes)):.2f} m/s)")
    return out
