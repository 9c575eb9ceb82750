"""The terminal laws of plan tracking (issue 17, ``systems/plan_tracker.py``):
the last centimetres of a planned swing as a feedback task on the gripper's
distance to the line.  The apex landing (``Landing``, on by default) aims
the gripper at the line for the moment link 1 stops; the reach (``Reach``,
off by default) lands on the back swing, short of the planned grip."""
import dataclasses as dc
import math
from pathlib import Path

import numpy as np
import pytest

from bplir_drake.planning.solve import tracking_plan
from bplir_drake.params import preset
from bplir_drake.systems.plan_tracker import Landing, PlanTracker, Reach
from bplir_drake.systems.plant import forward_dynamics


def _height_and_rates(x, p, alpha):
    """(h, h', h'' given q'') of the gripper on a line inclined by alpha, by
    finite differences of its position (independent of the Reach code)."""
    def h(q):
        s = q[0] - alpha
        return -p.l1 * math.cos(s) - p.l2 * math.cos(s + q[1])

    q, v, e = np.asarray(x[:2]), np.asarray(x[2:]), 1e-4
    grad = np.array([(h(q + e * d) - h(q - e * d)) / (2 * e) for d in np.eye(2)])
    hess = np.array([[(h(q + e * a + e * b) - h(q + e * a - e * b) - h(q - e * a + e * b)
                       + h(q - e * a - e * b)) / (4 * e * e) for b in np.eye(2)]
                     for a in np.eye(2)])
    return h(q), grad @ v, lambda qdd: grad @ qdd + v @ hess @ v


@pytest.mark.parametrize("alpha", [0.0, math.radians(20.0), math.radians(-20.0)])
def test_reach_linearises_the_distance_to_the_line(alpha):
    """On the nominal model without friction the reach's torque gives
    h'' = rate_gain (h'_cmd - h') exactly (partial feedback linearisation
    with link 1 passive), with h'_cmd = sqrt(speed^2 + 2 brake (aim - h))
    toward an aim above the gripper, -sqrt(2 brake (h - aim)) below it."""
    p = preset().plant
    reach = Reach.from_params(p, alpha, dc.replace(preset().landing, reach_speed=0.2,
                                                    landing_law="reach"))
    rng = np.random.default_rng(7)
    for _ in range(20):
        x = np.r_[alpha + rng.uniform(0.1, 0.4), rng.uniform(1.6, 2.2), rng.normal(0, 1, 2)]
        h, hd, hdd_of = _height_and_rates(x, p, alpha)
        s, th = x[0] - alpha, x[0] - alpha + x[1]
        along = (p.l1 * math.cos(s) + p.l2 * math.cos(th)) * x[2] + p.l2 * math.cos(th) * x[3]
        aim = reach.hold if abs(along) > reach.tangent else reach.lift
        cmd = (math.sqrt(reach.speed ** 2 + 2 * reach.brake * (aim - h)) if aim > h
               else -math.sqrt(2 * reach.brake * (h - aim)))
        tau = reach.torque(x)
        qdd = forward_dynamics(x[:2], x[2:], tau, np.zeros(2), p)
        assert hdd_of(qdd) == pytest.approx(reach.rate_gain * (cmd - hd), rel=1e-6, abs=1e-6)
        assert reach.height(x) == pytest.approx(h, abs=1e-12)


def test_reach_takes_over_near_the_line_in_the_second_half_and_latches():
    """At the start the free gripper is on the line (h = 0) but the plan
    runs; in the plan's second half the reach takes over once the gripper is
    within ``depth`` of the line, or when the plan has ended, and keeps it."""
    p = preset()
    p = p.with_(path=dc.replace(p.path, mode="plan"),
                landing=dc.replace(p.landing, reach_speed=0.2, landing_law="reach"),
                scenario=dc.replace(p.scenario, incline_deg=20.0))
    plan, gains = tracking_plan(p)
    reach = Reach.from_params(p.plant, math.radians(20.0), p.landing)
    tracker = PlanTracker(gains, 20.0, 0.01, reach=reach)
    T = plan.times[-1]
    assert reach.height(plan.states[0]) == pytest.approx(0.0, abs=1e-9)
    assert not tracker.reaching(0.0, plan.states[0], 0.0)
    late = [i for i, t in enumerate(plan.times) if t > 0.5 * T
            and reach.height(plan.states[i]) > -reach.depth]
    first = late[0]
    assert not tracker.reaching(plan.times[first - 1], plan.states[first - 1], 0.0)
    assert tracker.reaching(plan.times[first], plan.states[first], 0.0)
    assert tracker.reaching(0.6 * T, plan.states[0], 1.0)          # latched
    assert tracker.reaching(T, plan.states[0], 0.0)                # the plan has ended
    # the reach's command replaces the LQR's, clipped to the torque limit
    x = plan.states[first]
    assert tracker.law(plan.times[first], x, True)[0] == pytest.approx(
        float(np.clip(reach.torque(x), -20.0, 20.0)))


STUDY = Path(__file__).resolve().parents[1] / "examples" / "study_realistic.toml"


def test_the_reach_captures_on_the_back_swing_short_of_the_grip():
    """Why the reach is not the default law (``landing.landing_law = "reach"``): with it
    (0.2 m/s) swings count as captured by the 0.8 D criterion although the
    gripper fell back and grabbed the line at the next slow moment, 0.6-0.9 m
    short of the planned grip.  Sample 0 of root seed 2 at +20 deg (1.2 m),
    on both criteria."""
    from bplir_drake.analysis.montecarlo import load_study, sample_params
    from bplir_drake.analysis.swing.swing_runner import SwingRunner

    study = load_study(STUDY)
    assert study.params.scenario.min_travel_fraction == 1.9
    study = study.with_(
        seed=2, params=study.params.with_(
            landing=dc.replace(study.params.landing, reach_speed=0.2, landing_law="reach"),
            scenario=dc.replace(study.params.scenario, incline_deg=20.0)),
        distributions=tuple(d for d in study.distributions
                            if d.name != "scenario.grip_spacing"))
    params, seed, _ = sample_params(study, 0)
    runner = SwingRunner()
    strict = runner.run(params, seed=seed).summary
    spec = runner.run(params.with_(scenario=dc.replace(params.scenario, min_travel_fraction=0.8)),
                      seed=seed).summary
    assert spec["path_mode"] == "plan" and spec["outcome"] == "captured"
    assert spec["landing_error_m"] < -0.5          # the back swing, far short of the grip
    assert spec["swing_time_s"] > 1.6               # the plan ends at ~1.2 s
    assert strict["outcome"] != "captured"


@pytest.mark.parametrize("incline", [20.0, -20.0])
def test_10_and_20_ms_of_delay_are_captured_on_the_grip_on_20_degree_lines(incline):
    """The default controller on the +-20 deg lines (plan tracking assuming the
    lab firmware's 10 ms of actuation delay, ``plan.delay_compensation``),
    EKF in the loop, with 10 and 20 ms of actuation delay, seeds 0 and 1:
    every case captured near the planned grip."""
    from bplir_drake.analysis.swing.swing_runner import SwingRunner

    runner = SwingRunner()
    p = preset()
    p = p.with_(scenario=dc.replace(p.scenario, incline_deg=incline))
    runs = [runner.run(p.with_(scenario=dc.replace(p.scenario, actuation_delay=d)),
                       seed=k).summary for d in (0.01, 0.02) for k in (0, 1)]
    assert [r["outcome"] for r in runs] == ["captured"] * 4
    assert all(abs(r["landing_error_m"]) < 0.02 and r["swing_time_s"] < 1.35 for r in runs)
    assert all(r["peak_motor_power_W"] < 220.0 and r["peak_torque_Nm"] <= 20.0 + 1e-9
               for r in runs)


@pytest.mark.parametrize("alpha", [0.0, math.radians(20.0), math.radians(-20.0)])
def test_landing_linearises_the_distance_to_the_line(alpha):
    """On the nominal model without friction the landing's torque gives
    h'' = rate_gain (h'_cmd - h') exactly, with h'_cmd = lead max(a, 0) +
    gain (h* - h), h* = min(0, -margin - lead q1'), a = b1 / M11."""
    from bplir_drake.systems.plant import bias_term, gravity_vector, mass_matrix

    p = preset().plant
    land = Landing.from_params(p, alpha, preset().landing)
    assert land.lead == 0.025 and land.margin == 0.01   # the defaults
    rng = np.random.default_rng(11)
    for _ in range(20):
        x = np.r_[alpha + rng.uniform(0.1, 0.4), rng.uniform(1.6, 2.2), rng.normal(0, 1, 2)]
        h, hd, hdd_of = _height_and_rates(x, p, alpha)
        q, v = x[:2], x[2:]
        a = (bias_term(q, v, p) + gravity_vector(q, p))[0] / mass_matrix(q, p)[0, 0]
        aim = min(0.0, -land.margin - land.lead * x[2])
        cmd = (land.lead * max(a, 0.0) if aim < 0 else 0.0) + land.gain * (aim - h)
        qdd = forward_dynamics(q, v, land.torque(x), np.zeros(2), p)
        assert hdd_of(qdd) == pytest.approx(land.rate_gain * (cmd - hd), rel=1e-6, abs=1e-6)
        assert land.deceleration(x) == pytest.approx(a, rel=1e-12)


def test_landing_takes_over_in_the_last_forward_swing_and_aims_at_the_band():
    """The horizontal plan swings link 1 back while the elbow flips
    (q1' < 0 at 0.6-0.85 s): the landing may not take over before that has
    ended, though link 1 is slow and the nominal model decelerates it there.
    In the last forward swing it takes over once link 1 has slowed below
    ``take_rate`` or the gripper is ``depth`` from the line; it aims the
    gripper ``margin`` below the line (inside the 2 cm band) when link 1
    stops, ``margin + lead q1'`` before."""
    p = preset()
    p = p.with_(path=dc.replace(p.path, mode="plan"))
    plan, gains = tracking_plan(p)
    land = Landing.from_params(p.plant, 0.0, p.landing)
    tracker = PlanTracker(gains, 20.0, 0.01, reach=land)
    t, X = plan.times, plan.states
    back = t[X[:, 2] < -0.05]
    assert 0.55 < back[0] < back[-1] < 0.9 and tracker.t_final == pytest.approx(
        back[-1], abs=t[-1] / 400)   # on a grid of 400 steps
    assert not any(tracker.reaching(ti, xi, 0.0) for ti, xi in zip(t, X) if ti <= back[-1])
    first = next(i for i, ti in enumerate(t) if tracker.reaching(ti, X[i], 0.0))
    assert X[first, 2] < land.take_rate or land.height(X[first]) > -land.depth
    assert 1.1 < t[first] < t[-1]
    assert land.aim(np.r_[X[-1, :2], 0.0, 0.0])[0] == pytest.approx(-0.01)
    assert land.aim(np.r_[X[-1, :2], 0.4, 0.0])[0] == pytest.approx(-0.02)
    assert land.aim(np.r_[X[-1, :2], -1.0, 0.0]) == (0.0, 0.0)   # never above the line


@pytest.mark.slow
@pytest.mark.parametrize("incline", [0.0, 20.0, -20.0])
def test_held_out_samples_of_the_realistic_study_land_on_the_grip(incline):
    """The default robot and controller on samples 0-15 of root seed 2 of
    ``examples/study_realistic.toml`` (held out: the landing was chosen on
    root seeds 0 and 100), every draw but the grip spacing (1.2 m, the
    shipped plans).  Measured: 16 of 16 on every line, within 3.9, 4.5 and
    7.6 cm of the grip, the fastest at 0.371, 0.380 and 0.405 m/s."""
    from bplir_drake.analysis.montecarlo import load_study, sample_params
    from bplir_drake.analysis.swing.swing_runner import SwingRunner

    study = load_study(STUDY)
    study = study.with_(
        seed=2, params=study.params.with_(
            scenario=dc.replace(study.params.scenario, incline_deg=incline)),
        distributions=tuple(d for d in study.distributions
                            if d.name != "scenario.grip_spacing"))
    runner = SwingRunner()
    runs = []
    for k in range(16):
        params, seed, _ = sample_params(study, k)
        runs.append(runner.run(params, seed=seed).summary)
    missed = [k for k, r in enumerate(runs) if not r["success"]]
    assert missed == []
    landed = [r for r in runs if r["success"]]
    assert all(abs(r["landing_error_m"]) < 0.08 for r in landed)
    assert all(r["capture_speed_mps"] < {0.0: 0.38, 20.0: 0.39, -20.0: 0.41}[incline]
               for r in landed)
    assert all(r["peak_motor_power_W"] < 220.0 for r in runs)


@pytest.mark.parametrize("incline", [0.0, 20.0, -20.0])
def test_link_2_parameters_off_by_10_percent(incline):
    """m2, I2 or lc2 of the simulated robot 10 % off the nominal model the
    controller uses (seed 0, EKF in the loop, the default landing).  Every
    case lands within 6.5 cm of the grip (measured 5.9 cm at most); the
    hardest, lc2 -10 % at -20 deg under the aim law (a 5.5 cm shift of
    link 2's centre of mass, five times the realistic study's draw),
    arrives at 0.48 m/s, just inside the 0.5 m/s limit."""
    from bplir_drake.analysis.swing.swing_runner import SwingRunner

    runner = SwingRunner()
    p = preset()
    p = p.with_(path=dc.replace(p.path, mode="plan"),
                scenario=dc.replace(p.scenario, incline_deg=incline))
    missed = []
    for field in ("m2", "I2", "lc2"):
        for scale, name in ((0.9, "-10%"), (1.1, "+10%")):
            true = dc.replace(p.plant, **{field: getattr(p.plant, field) * scale})
            r = runner.run(p.with_(true_plant=true), seed=0).summary
            if r["outcome"] != "captured":
                missed.append(f"{field} {name}")
            else:
                assert abs(r["landing_error_m"]) < 0.065
    assert missed == []
