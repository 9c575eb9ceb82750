"""The terminal reach of plan tracking (issue 17, ``systems/plan_tracker.py``):
the last centimetres of a planned swing as a feedback task on the gripper's
distance to the line, so that persistent torque errors (wind, inertia) that
change the swing's energy no longer decide the landing."""
import dataclasses as dc
import math
from pathlib import Path

import numpy as np
import pytest

from bplir_drake.analysis.swing.plan import tracking_plan
from bplir_drake.params import preset
from bplir_drake.systems.plan_tracker import PlanTracker, Reach
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
    reach = Reach.from_params(p, alpha, preset().path)
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
                scenario=dc.replace(p.scenario, incline_deg=20.0))
    plan, gains = tracking_plan(p)
    reach = Reach.from_params(p.plant, math.radians(20.0), p.path)
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


@pytest.mark.parametrize("incline", [20.0, -20.0])
def test_reach_holds_the_realistic_study_on_20_degree_lines(incline):
    """The realistic study (friction, inertial parameters, link lengths, IMU
    noise, bias and misalignment, 0-20 ms actuation delay, wind, gusts) on
    the +-20 deg lines as ``bplir montecarlo --incline`` runs it by default
    (plan tracking with the reach), grip spacing held at 1.2 m (the shipped
    plans; every other spacing needs its own plan).  The reach's parameters
    were chosen on root seed 0; this is root seed 2, samples 0-9, held out.
    Measured: 10 of 10 captured at +20 and at -20 deg; 9 of 10 with the
    reach but without the delay compensation (+20: sample 5 crashes; -20:
    sample 3); 2 of 10 with neither (3 crashes and 5 timeouts each)."""
    from bplir_drake.analysis.montecarlo import load_study, sample_params
    from bplir_drake.analysis.swing.run import SwingRunner

    study = load_study(STUDY)
    study = study.with_(
        seed=2, params=study.params.with_(scenario=dc.replace(study.params.scenario,
                                                              incline_deg=incline)),
        distributions=tuple(d for d in study.distributions
                            if d.name != "scenario.grip_spacing"))
    runner = SwingRunner()
    rows = []
    for k in range(10):
        params, seed, _ = sample_params(study, k)
        rows.append(runner.run(params, seed=seed).summary)
    assert all(r["path_mode"] == "plan" for r in rows)
    captured = [r for r in rows if r["outcome"] == "captured"]
    assert len(captured) == 10
    for r in rows:
        assert r["peak_motor_power_W"] < 220.0 and r["peak_torque_Nm"] <= 20.0 + 1e-9
    assert max(r["capture_speed_mps"] for r in captured) <= 0.5


@pytest.mark.parametrize("incline", [20.0, -20.0])
def test_delay_and_link2_errors_are_captured_on_20_degree_lines(incline):
    """The default controller on the +-20 deg lines (plan tracking with the
    reach, assuming the lab firmware's 10 ms of actuation delay:
    ``path.plan_delay_compensation``), EKF in the loop.  Measured: every
    case captured; at +20 deg 10 ms 0.24 / 0.26 m/s and 20 ms 0.26 / 0.29
    m/s (seeds 0 / 1), m2, I2, lc2 of the real robot at -10 % / +10 %:
    0.22 / 0.22, 0.25 / 0.20, 0.25 / 0.19 m/s; at -20 deg 0.29-0.32 m/s."""
    from bplir_drake.analysis.swing.run import SwingRunner

    runner = SwingRunner()
    p = preset()
    p = p.with_(scenario=dc.replace(p.scenario, incline_deg=incline))
    cases = [p.with_(scenario=dc.replace(p.scenario, actuation_delay=d))
             for d in (0.01, 0.02)]
    runs = [runner.run(q, seed=k).summary for q in cases for k in (0, 1)]
    tp = p.simulated_plant
    for name in ("m2", "I2", "lc2"):
        for r in (0.9, 1.1):
            q = p.with_(true_plant=dc.replace(tp, **{name: getattr(tp, name) * r}))
            runs.append(runner.run(q, seed=0).summary)
    assert [r["outcome"] for r in runs] == ["captured"] * 10
    assert max(r["capture_speed_mps"] for r in runs) < 0.33
    assert all(r["peak_motor_power_W"] < 220.0 and r["peak_torque_Nm"] <= 20.0 + 1e-9
               for r in runs)
