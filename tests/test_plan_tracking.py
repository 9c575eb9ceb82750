"""Plan tracking: a trajectory-optimised swing ending at rest inside the
capture band, tracked by Drake's finite-horizon LQR on the estimated
state, with its landing laws (the shot, the aim law) and their choice
(``landing.landing_law``).  The terminal reach is off
(``tests/test_reach.py``: it landed on the back swing)."""
import dataclasses as dc
import math
from pathlib import Path

import numpy as np
import pytest

from bplir_drake.analysis.swing.swing_runner import run_swing
from bplir_drake.planning.solve import planned_target, tracking_plan
from bplir_drake.params import ParameterError, preset
from bplir_drake.systems.plan_tracker import PlanTracker
from bplir_drake.systems.plant import gripper_position
from bplir_drake.params import with_hardware


@pytest.fixture(scope="module")
def uphill():
    p = preset()
    return p.with_(path=dc.replace(p.path, mode="plan"),
                   scenario=dc.replace(p.scenario, incline_deg=20.0))


def test_planned_target_rests_inside_the_band(uphill):
    q = planned_target(uphill, 0.017)
    x, y = gripper_position(q, uphill.plant.l1, uphill.plant.l2)
    a = math.radians(20.0)
    along, normal = x * math.cos(a) + y * math.sin(a), -x * math.sin(a) + y * math.cos(a)
    assert along == pytest.approx(1.2, abs=1e-9) and normal == pytest.approx(-0.017, abs=1e-9)
    with pytest.raises(ParameterError, match="plan.end_depth = 0.03 m lies below the capture"):
        tracking_plan(
            uphill.with_(plan=dc.replace(uphill.plan, end_depth=0.03)))


@pytest.mark.slow
def test_uphill_swing_with_ekf_tracking_a_plan(uphill):
    """The +20 deg line, seeds 0-19 (friction +/-20 %, IMU noise, EKF; the
    default robot and landing): all 20 captured at 0.19-0.40 m/s (median
    0.30) after 1.243-1.265 s, within 1.3 cm of the planned grip; peak
    motor power 99-104 W (rating 220 W), winding voltage at most 28.7 V
    (the driver gives 29.4 V), peak torque 11.8-18.4 N m."""
    plan, gains = tracking_plan(uphill)
    tracker = PlanTracker(gains, 20.0, 0.002)
    for i in np.searchsorted(plan.times, [0.1, 0.5, 1.0]):
        assert tracker.law(plan.times[i], plan.states[i])[1] == plan.states[i, 1]
    # held at the plan's end afterwards, and clipped to the torque limit
    assert tracker.law(9.0, plan.states[-1])[1] == plan.states[-1, 1]
    assert abs(tracker.law(0.5, plan.states[i] + [1.0, 0, 0, 0])[0]) == 20.0
    rows = [run_swing(uphill, seed=k).summary for k in range(20)]
    assert rows[0]["outcome"] == "captured" and rows[0]["estimator_in_loop"]
    assert [k for k, s in enumerate(rows) if s["outcome"] != "captured"] == []
    for s in rows:
        assert s["fixed_gripper_open"]
        assert s["peak_motor_power_W"] < 220.0 and s["peak_torque_Nm"] <= 20.0 + 1e-9
        assert abs(s["landing_error_m"]) < 0.014 and 1.24 < s["swing_time_s"] < 1.27
        assert 0.18 < s["capture_speed_mps"] < 0.41 and s["peak_voltage_V"] <= 29.4 + 1e-9


@pytest.mark.slow
def test_downhill_swing_with_ekf_tracking_a_plan(uphill):
    """The -20 deg line, seeds 0-19 (friction +/-20 %, IMU noise, EKF; the
    default robot, whose auto landing law aims here): all 20 captured at
    0.21-0.28 m/s (median 0.25) after 1.276-1.304 s, within 1.1 cm of the
    planned grip, peak torque 16.3-17.0 N m (the delay probe on the plan's
    start torque), peak power 32-42 W."""
    down = uphill.with_(scenario=dc.replace(uphill.scenario, incline_deg=-20.0))
    rows = [run_swing(down, seed=k).summary for k in range(20)]
    assert [k for k, s in enumerate(rows) if s["outcome"] != "captured"] == []
    for s in rows:
        assert s["peak_motor_power_W"] < 45.0 and s["peak_torque_Nm"] <= 20.0 + 1e-9
        assert abs(s["landing_error_m"]) < 0.012 and 1.27 < s["swing_time_s"] < 1.31
        assert 0.20 < s["capture_speed_mps"] < 0.29
    assert np.median([s["capture_speed_mps"] for s in rows]) < 0.26


def test_the_tracker_commands_only_what_the_motor_can_deliver(uphill):
    """With the nominal motor the command is clipped to the voltage
    envelope at the estimated elbow rate: at 12 rad/s the 30 V driver drives
    (29.4 V - 24.6 V of back-EMF) / 0.39 ohm = 12.5 A forwards, and the full
    current backwards; at rest the torque limit alone applies."""
    from bplir_drake.params import MotorParams

    plan, gains = tracking_plan(uphill)
    m = MotorParams()
    free = PlanTracker(gains, 20.0, 0.01)
    capped = PlanTracker(gains, 20.0, 0.01, motor=m)
    x = plan.states[int(np.searchsorted(plan.times, 0.5))]
    hi = m.torque_per_amp * (m.max_voltage - m.km * m.gear_ratio * 12.0) / m.resistance
    assert hi == pytest.approx(16.6, abs=0.1)
    push = np.r_[x[:3], 12.0] + [-2.0, 0.0, 0.0, 0.0]
    pull = np.r_[x[:3], 12.0] + [2.0, 0.0, 0.0, 0.0]
    assert free.law(0.5, push)[0] == 20.0 and capped.law(0.5, push)[0] == pytest.approx(hi)
    assert free.law(0.5, pull)[0] == -20.0
    assert capped.law(0.5, pull)[0] == pytest.approx(-m.torque_per_amp * 15.0)
    rest = np.r_[x[:3], 0.0]
    i_max = m.torque_per_amp * 15.0
    assert capped.law(0.5, rest)[0] == pytest.approx(np.clip(free.law(0.5, rest)[0], -i_max,
                                                             i_max))


def test_state_indexed_tracker_reads_no_clock(uphill):
    """indexing = "state": the plan's phase comes from the estimate alone.  It
    finds the plan time of a plan state, never goes back, and the same state
    and phase give the same command at any clock time."""
    plan, gains = tracking_plan(uphill)
    tracker = PlanTracker(gains, 20.0, 0.01, indexing="state")
    i = int(np.searchsorted(plan.times, 0.4))
    t_i, x_i = plan.times[i], plan.states[i]
    assert tracker.phase(t_i - 0.02, x_i) == pytest.approx(t_i, abs=0.0025)
    assert tracker.phase(t_i + 0.1, x_i) == pytest.approx(t_i + 0.1)   # never back
    with pytest.raises(ValueError, match="indexing"):
        PlanTracker(gains, 20.0, 0.01, indexing="clock")
    out = []
    for clock in (0.05, 0.9):
        ctx = tracker.CreateDefaultContext()
        ctx.SetTime(clock)
        ctx.get_mutable_discrete_state_vector().SetFromVector([t_i - 0.02, 0.0, 0.0])
        tracker.get_input_port(0).FixValue(ctx, x_i + [0.01, -0.02, 0.1, 0.0])
        stored = tracker.EvalUniquePeriodicDiscreteUpdate(ctx).get_vector().CopyToVector()
        out.append([tracker.GetOutputPort("torque").Eval(ctx)[0],
                    tracker.GetOutputPort("reference").Eval(ctx)[0], *stored])
    np.testing.assert_array_equal(out[0], out[1])
    assert out[0][2] == pytest.approx(t_i, abs=0.01)


@pytest.mark.slow
def test_clock_free_uphill_swing(uphill):
    """The same 20 degree swing with the plan indexed by the estimated state
    (no clock), with the default landing: every one of seeds 0-19 captured
    within the capture limits and near the grip."""
    p = uphill.with_(plan=dc.replace(uphill.plan, indexing="state"))
    rows = [run_swing(p, seed=k).summary for k in range(20)]
    assert [k for k, s in enumerate(rows) if s["outcome"] != "captured"] == []
    for s in rows:
        assert s["fixed_gripper_open"] and s["peak_motor_power_W"] < 220.0
        assert abs(s["landing_error_m"]) < 0.018 and 1.2 < s["swing_time_s"] < 1.27
        assert 0.18 < s["capture_speed_mps"] < 0.40


@pytest.mark.parametrize("incline", [20.0, -20.0])
def test_quick_start_captures_on_a_20_degree_line_without_a_config(tmp_path, capsys, incline):
    """``bplir swing --incline +-20`` as a user types it: the default path
    mode ("auto") tracks the shipped plan; captured on the planned grip,
    within the motor's ratings.  The
    dissertation's controller keeps its path generator, which times out
    uphill and crashes downhill."""
    import json

    from bplir_drake.cli import main

    argv = ["swing", "--incline", f"{incline:g}", "--no-animation", "--no-plots", "--json"]
    assert main(argv + ["--out", str(tmp_path / "a")]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["outcome"] == "captured" and s["path_mode"] == "plan"
    assert abs(s["landing_error_m"]) < 0.02
    assert s["capture_speed_mps"] <= 0.5 and s["peak_motor_power_W"] < 220.0
    main(argv + ["--controller", "cpfl-qft", "--out", str(tmp_path / "b")])
    d = json.loads(capsys.readouterr().out)
    assert d["path_mode"] == "adaptive" and d["outcome"] == ("timeout" if incline > 0 else "crash")


def test_a_measured_grip_spacing_uses_the_plan_of_its_grid_step(uphill):
    """A study drawing the grip spacing solves one plan per
    ``plan.spacing_step`` (1 cm), not one per swing: 1.204 m tracks
    the 1.20 m plan (shipped: nothing is solved here).  With the plan
    library off: the library blends the exact spacing instead."""
    solved = uphill.with_(plan=dc.replace(uphill.plan, library=False))
    near = solved.with_(scenario=dc.replace(uphill.scenario, grip_spacing=1.204))
    plan, gains = tracking_plan(near)
    plan0, gains0 = tracking_plan(solved)
    assert np.array_equal(plan.states, plan0.states) and gains is gains0


def test_a_plan_off_1_2_m_is_also_started_from_the_1_2_m_plan():
    """At 1.27 m (horizontal) a straight-line guess of 1.0 s ends in another
    local optimum: link 1 reverses four times and the plan costs 23.6
    (``int tau^2 dt + T``) against 10.0-10.2 at 1.26 and 1.28 m.  Started
    from the 1.2 m plan the solve finds its neighbours' kind of swing (two
    reversals, link 1's share of the rise 0.86, so the auto law shoots), and
    :func:`scenario_plan` keeps the cheapest plan it found."""
    from bplir_drake.planning.solve import plan_swing, scenario_plan
    from bplir_drake.systems.landing import landing_law, link1_share

    p = preset()   # the planner's own choice (the library holds a blend here)
    q = p.with_(scenario=dc.replace(p.scenario, grip_spacing=1.27),
                plan=dc.replace(p.plan, library=False))
    cold = plan_swing(q, end_depth=q.plan.end_depth, guess_duration=1.0)
    assert cold.feasible and cold.link1_reversals == 4
    assert cold.objective() == pytest.approx(23.61, abs=0.01)
    assert link1_share(q.plant, 0.0, cold.states, 0.3) == pytest.approx(0.26, abs=0.01)
    plan = scenario_plan(q)
    assert plan.link1_reversals == 2 and plan.objective() == pytest.approx(10.10, abs=0.01)
    assert link1_share(q.plant, 0.0, plan.states, 0.3) == pytest.approx(0.86, abs=0.01)
    assert landing_law(q.plant, 0.0, plan.states, q.landing) == "shoot"
    warm_off = scenario_plan(q.with_(plan=dc.replace(q.plan, warm_spacing=0.0)))
    first = plan_swing(q, end_depth=q.plan.end_depth, guess_duration=1.5)
    assert np.array_equal(warm_off.states, first.states)
    assert plan.objective() <= first.objective()


def test_the_shooting_landing_holds_no_shot_far_below_its_aim():
    """The state of a -20 deg realistic swing (tuning root seed 0, sample 2,
    shooting landing) when the law took over: link 1 almost still, the
    gripper 25 cm below the line and rising on the elbow alone.  No shot
    exists (link 1 is not carrying the gripper); holding the stop time at
    ``shoot_min_time`` there asked for 935 N m and crashed the swing at
    4.65 m/s.  Beyond ``shoot_hold_depth`` of the aim the aim law steers.
    (With ``shoot_min_rate`` 0.1 rad/s, as then; with 0.02, since
    a free shot is solved here: link 1 stops in 194 ms.)"""
    from bplir_drake.systems.plan_tracker import ApexShot

    p = preset()
    path = dc.replace(p.landing, landing_law="shoot", shoot_min_time=0.04, shoot_height=-0.018,
                      shoot_rate_cap=0.0)   # the shot itself, its elbow uncapped as then
    x = [-0.010, 1.737, 0.06, 2.59]
    acc, T = ApexShot.from_params(p.plant, p.friction, math.radians(-20), path).solve(x)
    assert T == pytest.approx(0.194, abs=1e-3) and acc == pytest.approx(-19.6, abs=0.1)
    path = dc.replace(path, shoot_min_rate=0.1)
    held = ApexShot.from_params(p.plant, p.friction, math.radians(-20),
                                dc.replace(path, shoot_hold_depth=1.0))
    law = ApexShot.from_params(p.plant, p.friction, math.radians(-20), path)
    assert law.landing.height(x) == pytest.approx(-0.2547, abs=1e-4)
    assert held.torque(x) > 900.0   # measured 935 N m: an elbow acceleration of 1783 rad/s^2
    assert law.solve(x) is None
    assert law.torque(x) == law.landing.torque(x) == pytest.approx(2.02, abs=0.01)
    # near its aim the held shot still steers (a horizontal swing's last
    # moments: link 1 almost stopped, the gripper 7 mm below the aim)
    flat = ApexShot.from_params(p.plant, p.friction, 0.0, path)
    near = [0.319, 1.996, 0.05, 0.34]
    assert flat.height - flat.hold_depth < flat.landing.height(near) < flat.height
    acc, T = flat.solve(near)
    assert T == 0.04 and abs(flat.torque(near)) < 20.0


def test_the_shot_is_solved_while_link_1_creeps():
    """The estimate of sample 108 of the realistic study at -20 deg (root seed
    9, 1.125 m) 40 ms before the arrival, with the line sensor's downhill
    shot: link 1 creeping at 0.099 rad/s, the gripper 5 cm below the line.
    A shot exists (link 1 stops in 79.5 ms); with ``shoot_min_rate`` 0.1
    rad/s none was solved below that rate and the aim law took over."""
    from bplir_drake.systems.plan_tracker import ApexShot

    p = with_hardware(preset(), "line-sensor")
    assert p.landing.shoot_min_rate == 0.02
    path = dc.replace(p.landing, shoot_min_time=p.landing.shoot_lift_min_time,
                      shoot_height=-0.018)   # as on -20 deg then
    x = [-0.1261, 2.0851, 0.0991, 0.8202]
    law = ApexShot.from_params(p.plant, p.friction, math.radians(-20), path)
    before = ApexShot.from_params(p.plant, p.friction, math.radians(-20),
                                  dc.replace(path, shoot_min_rate=0.1))
    assert law.landing.height(x) == pytest.approx(-0.0496, abs=1e-4)
    acc, T = law.solve(x)
    assert T == pytest.approx(0.0795, abs=5e-4) and acc == pytest.approx(-7.57, abs=0.05)
    assert law.torque(x) == pytest.approx(2.83, abs=0.01)
    assert before.solve(x) is None and before.torque(x) == before.landing.torque(x)


def test_the_shooting_landing_gives_up_rather_than_chase_the_line():
    """The state of sample 770 of the realistic study (held-out root seed
    2, 0 deg, 18 ms of delay, shooting landing) 80 ms after link 1 stopped
    2.4 cm short of its aim: link 1 swings back at 0.47 rad/s.  The held
    shot asks for 244 N m (264 with the -15 mm aim; the elbow then chased the line at the torque
    limit and slid the gripper along it: a crash at 2.2 m/s); with
    ``shoot_give_up_rate`` the elbow is braked to rest instead (8 N m; the
    swing times out with the robot hanging), and a shot still rising (link
    1 at +0.11 rad/s) is not given up."""
    from bplir_drake.systems.plan_tracker import ApexShot

    p = preset()
    assert p.landing.shoot_give_up_rate == 0.1
    chase = ApexShot.from_params(p.plant, p.friction, 0.0,   # uncapped, as then
                                 dc.replace(p.landing, shoot_give_up_rate=0.0, shoot_rate_cap=0.0))
    law = ApexShot.from_params(p.plant, p.friction, 0.0, p.landing)
    back, rising = [0.413, 1.849, -0.47, 0.70], [0.419, 1.844, 0.11, -0.46]
    assert law.landing.height(back) == pytest.approx(-0.039, abs=1e-3)
    assert chase.torque(back) > 240.0 and not chase.gives_up(back)
    assert law.gives_up(back) and law.torque(back) == pytest.approx(-8.06, abs=0.01)
    assert not law.gives_up(rising) and law.torque(rising) == chase.torque(rising)


def test_a_shot_far_out_of_the_motors_reach_brakes_the_elbow():
    """With ``shoot_brake_ratio`` (the 48v option's 1.6 in a traversal's
    swings, ``traverse.shoot_brake_ratio``) a shot asking for
    more than that multiple of the torque the motor gives brakes the elbow:
    the returned torque gives the elbow an acceleration of ``-landing_rate_gain
    * q2'`` on the robot's dynamics (Drake's plant, friction off), link 1
    passive.  The state is the -20 deg swing's where the held shot asks for
    over 900 N m; a shot within the ratio is left as it was."""
    from bplir_drake.params import FrictionParams
    from bplir_drake.systems import plant as K
    from bplir_drake.systems.plan_tracker import ApexShot

    from moves import traverse_swing

    p = preset()
    p48 = with_hardware(preset(), "48v")
    assert p48.traverse.shoot_brake_ratio == 1.6 and p48.landing.shoot_brake_ratio == "never"
    assert traverse_swing(p48, 2, 1.2, 0.0).landing.shoot_brake_ratio == 1.6
    assert traverse_swing(p, 2, 1.2, 0.0).landing.shoot_brake_ratio == "never"
    fr = FrictionParams(enabled=False)
    path = dc.replace(p.landing, landing_law="shoot", shoot_min_time=0.04, shoot_rate_cap=0.0,
                      shoot_height=-0.018, shoot_min_rate=0.1, shoot_hold_depth=1.0)
    x = [-0.010, 1.737, 0.06, 2.59]
    alpha = math.radians(-20)
    free = ApexShot.from_params(p.plant, fr, alpha, path)
    brake = ApexShot.from_params(p.plant, fr, alpha, dc.replace(path, shoot_brake_ratio=1.6))
    window = (-19.9, 19.9)
    assert free.torque(x) > 900.0 and free.torque(x, window) == free.torque(x)
    u = brake.torque(x, window)
    pl = K.make_plant(p.plant)
    M, Cv, g = K.drake_manipulator_terms(pl, pl.CreateDefaultContext(), x[:2], x[2:])
    qdd = np.linalg.solve(M, np.array([0.0, u]) - Cv - g)
    assert qdd[1] == pytest.approx(-p.landing.landing_rate_gain * x[3], rel=1e-9)
    assert abs(u) < 0.1 * free.torque(x)
    # a shot within 1.6 times the window is the shot
    near = [0.319, 1.996, 0.05, 0.34]
    flat, flat_brake = (ApexShot.from_params(p.plant, fr, 0.0, dc.replace(path, shoot_hold_depth=0.03,
                                                                          shoot_brake_ratio=r))
                        for r in (0.0, 1.6))
    assert abs(flat.torque(near)) < 1.6 * 19.9
    assert flat_brake.torque(near, window) == flat.torque(near)


@pytest.mark.parametrize("incline, share, hold, aim, default", [
    (0.0, 0.79, 0.03, -0.018, "shoot"), (20.0, 1.29, 0.03, -0.018, "shoot"),
    (-20.0, 0.14, 0.05, -0.019, "aim")])
def test_auto_landing_law_follows_who_lifts_the_gripper(incline, share, hold, aim, default):
    """``landing.landing_law = "auto"`` shoots where link 1 carries the planned
    gripper to the line (its share of the rise rate 30 cm below the line);
    where the elbow lifts it (the -20 deg plan) it shoots held from
    ``shoot_lift_min_time`` at ``shoot_lift_height`` where ``lift_law`` is
    "shoot" -- the line sensor's tuning -- or, with ``lift_law = "aim"`` (the
    default robot, IMUs alone), it aims."""
    from bplir_drake.planning.solve import scenario_plan
    from bplir_drake.systems.landing import landing_law, link1_share, resolved_landing

    base = preset()
    p = with_hardware(base, "line-sensor")
    assert p.landing.landing_law == base.landing.landing_law == "auto"
    assert (p.landing.shoot_min_time, p.landing.lift_law, p.landing.shoot_lift_min_time) == \
        (0.03, "shoot", 0.05)
    q = p.with_(scenario=dc.replace(p.scenario, incline_deg=incline))
    plan = scenario_plan(q)
    a = math.radians(incline)
    assert link1_share(q.plant, a, plan.states, 0.3) == pytest.approx(share, abs=0.02)
    law, path = resolved_landing(q.plant, a, plan.states, q.landing)
    assert law == "shoot" and (path.shoot_min_time, path.shoot_height) == (hold, aim)
    assert dc.replace(path, shoot_min_time=q.landing.shoot_min_time,
                      shoot_height=q.landing.shoot_height) == q.landing
    assert landing_law(q.plant, a, plan.states, base.landing) == default
    assert base.landing.lift_law == "aim"
    for fixed in ("aim", "shoot"):
        assert resolved_landing(q.plant, a, plan.states, dc.replace(q.landing, landing_law=fixed)) \
            == (fixed, dc.replace(q.landing, landing_law=fixed))
    with pytest.raises(ParameterError, match="lift_law = 'never'"):
        dc.replace(q.landing, lift_law="never")


def test_landing_law_option(tmp_path, capsys):
    """``--landing-law auto`` on the horizontal line is the shot (same swing,
    bit for bit); on the -20 deg line it is the aim law for the default
    robot and, with the line sensor, the shot held from
    ``shoot_lift_min_time`` (measured 0.203 m/s against the aim law's
    0.242); a wrong law is a one-line error naming the allowed ones."""
    import json

    from bplir_drake.cli import main

    runs = {}
    for incline, law, hw in (("0", "shoot", ""), ("0", "auto", ""), ("-20", "aim", ""),
                             ("-20", "auto", ""), ("-20", "aim", "line-sensor"),
                             ("-20", "auto", "line-sensor")):
        extra = ["--hardware", hw] if hw else []
        assert main(["swing", "--incline", incline, "--landing-law", law, "--no-animation",
                     "--no-plots", "--json", "--out", str(tmp_path / f"{law}{incline}{hw}"), *extra]) == 0
        runs[incline, law, hw] = json.loads(capsys.readouterr().out)
    assert all(r["outcome"] == "captured" for r in runs.values())
    assert runs["0", "auto", ""]["capture_speed_mps"] == runs["0", "shoot", ""]["capture_speed_mps"]
    assert runs["-20", "auto", ""]["capture_speed_mps"] == runs["-20", "aim", ""]["capture_speed_mps"]
    sensor_aim, sensor_auto = runs["-20", "aim", "line-sensor"], runs["-20", "auto", "line-sensor"]
    assert sensor_aim["capture_speed_mps"] == pytest.approx(0.242, abs=0.005)
    assert sensor_auto["capture_speed_mps"] == pytest.approx(0.203, abs=0.005)
    assert main(["montecarlo", "-n", "1", "--landing-law", "lqr", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err == ("bplir: error: --landing-law = 'lqr' is unknown; allowed: auto, shoot, aim, "
                   "reach, none\n")


# sample 107's grip spacing (1.196 m): its plan blended from the plan library
@pytest.mark.parametrize("k, aim_speed, auto_speed", [(107, 0.599, 0.222)])
def test_auto_landing_lands_realistic_swings_the_aim_law_crashes(k, aim_speed, auto_speed):
    """Sample 107 of the realistic study, root seed 2, 0 deg (20 ms of
    delay, probed and identified), the default robot: the aim law crashes,
    the auto law (the shot on this line) captures.  Over samples 0-119 of
    that seed the auto law turned 12 crashes into captures and lost none."""
    from bplir_drake.analysis.montecarlo import load_study, sample_params
    from bplir_drake.analysis.swing.swing_runner import SwingRunner

    root = Path(__file__).resolve().parents[1] / "examples"
    p, seed, _ = sample_params(load_study(root / "study_realistic.toml").with_(seed=2), k)
    runner = SwingRunner()
    aim = runner.run(p.with_(landing=dc.replace(p.landing, landing_law="aim")), seed=seed).summary
    assert aim["outcome"] == "crash" and aim["capture_speed_mps"] == pytest.approx(aim_speed, abs=0.01)
    auto = runner.run(p.with_(landing=dc.replace(p.landing, landing_law="auto")), seed=seed).summary
    assert auto["outcome"] == "captured"
    assert auto["capture_speed_mps"] == pytest.approx(auto_speed, abs=0.01)
    assert abs(auto["landing_error_m"]) < 0.1 * p.scenario.grip_spacing


@pytest.mark.parametrize("law", ["shoot", "aim"])
def test_the_compiled_tick_is_the_trackers_law(law):
    """A time-indexed tick (compiled but for the terminal law's ticks) gives
    what the tracker's law, take-over test and delay probe give, bit for
    bit, at 400 states along the default plan with a lead of 0, 1 and 3
    ticks, the latch set and not, and inside the probe's first ticks."""
    from bplir_drake.diagrams.swing import build_swing
    p = preset()
    p = p.with_(landing=dc.replace(p.landing, landing_law=law))
    tracker = build_swing(p, seed=0).systems["controller"].tracker
    assert tracker.probe and tracker.steps_port is not None
    rng = np.random.default_rng(2)
    states = tracker.x0.vector_values(rng.uniform(0, tracker.t_end, 400)).T
    reached = 0
    for i, x in enumerate(states + rng.normal(0.0, 0.05, states.shape)):
        k, latch, steps = float(rng.integers(0, 200)), float(i % 5 == 0), (None, 1.0, 3.0)[i % 3]
        if i % 7 == 0:
            k = float(i % len(tracker.probe)) if tracker.probe else k
        lead = tracker.lead if steps is None else math.floor(steps + 0.5) * tracker.period
        tau = k * tracker.period + lead
        reach = tracker.reaching(tau, x, latch)
        u, ref = tracker.law(tau, x, reach)
        if int(k + 0.5) < len(tracker.probe):
            lo, hi = tracker.window(x)
            u = float(min(max(u + tracker.probe[int(k + 0.5)], lo), hi))
        assert tracker.tick(x, np.array([0.0, k, latch]), steps) == (u, ref, tau, k + 1,
                                                                     float(reach))
        reached += reach
    assert 40 < reached < 360
