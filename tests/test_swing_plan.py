"""Trajectory-optimised swing plans (planning/solve.py, `bplir plan`):
is the 20 degree uphill swing feasible within the motor's 220 W rating?"""
import dataclasses as dc
import json
import math

import matplotlib
import pytest

matplotlib.use("Agg")

from bplir_drake.plotting import save_figure  # noqa: E402
from bplir_drake.planning.solve import plan_swing  # noqa: E402
from bplir_drake.cli import main  # noqa: E402
from bplir_drake.diagrams import swing_geometry  # noqa: E402
from bplir_drake.params import BplirParams  # noqa: E402
from bplir_drake.systems.plant import potential_energy  # noqa: E402
from bplir_drake.params import with_hardware, around


@pytest.fixture(scope="module")
def uphill():
    p = BplirParams()
    p = p.with_(scenario=dc.replace(p.scenario, incline_deg=20.0))
    return p, plan_swing(p, knots=41)


def test_uphill_swing_is_feasible_within_the_power_rating(uphill):
    p, plan = uphill
    # every collocation constraint holds (SNOPT stops at its iteration limit
    # short of proving optimality, so `solved` is not asserted)
    assert plan.feasible
    assert plan.peak_power < 220.0          # the dissertation's heuristic needed ~400 W
    assert plan.peak_torque <= 20.0 + 1e-6
    assert 0.9 < plan.duration < 3.0        # measured 1.27 s
    q0, qT, _, _ = swing_geometry(p)
    assert plan.states[0, :2] == pytest.approx(q0, abs=1e-9)
    assert plan.states[-1, :2] == pytest.approx(qT, abs=1e-9)


def test_uphill_plan_energy_balance(uphill):
    """Motor work minus friction loss is the rise of potential energy between
    the two rest poses (closed form 8.60 J); the dense reconstruction of a
    41-knot collocation agrees within 10 %."""
    p, plan = uphill
    q0, qT, _, _ = swing_geometry(p)
    rise = potential_energy(qT, p.plant) - potential_energy(q0, p.plant)
    assert rise == pytest.approx(8.596, abs=0.01)
    assert plan.energy_in - plan.dissipated == pytest.approx(rise, rel=0.10)
    assert plan.energy_in > rise


def test_uphill_plan_needs_a_back_swing(uphill):
    """Why a time-independent path of the passive angle cannot climb: the
    planned uphill swing reverses link 1, so it is no function q2 = phi(q1)."""
    _, plan = uphill
    assert plan.link1_reversals >= 1


def test_plan_figure_and_cli_errors(uphill, tmp_path, capsys):
    p, plan = uphill
    fig = plan.plot(params=p)
    path = save_figure(fig, tmp_path / "plan.png")
    assert path.stat().st_size > 20_000
    # every panel labelled with its units; torque and power each on its own
    # axes with its limit named; the poses keyed by time
    labels = [(a.get_xlabel(), a.get_ylabel()) for a in fig.axes[:4]]
    assert labels == [("time [s]", "joint angle [rad]"), ("time [s]", "elbow torque [N m]"),
                      ("time [s]", "motor power [W]"), ("horizontal [m]", "vertical [m]")]
    assert fig.axes[4].get_ylabel() == "time [s]"   # the colour bar
    for a, name, limit in ((fig.axes[1], "torque limit", plan.torque_limit),
                           (fig.axes[2], "power rating", plan.power_limit)):
        assert name in [t.get_text() for t in a.texts]
        assert sorted(ln.get_ydata()[0] for ln in a.get_lines()
                      if len(set(ln.get_ydata())) == 1) == [-limit, limit]
    assert main(["plan", "--incline", "95", "--out", str(tmp_path)]) == 2
    assert main(["plan", "--knots", "2", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and all(line.startswith("bplir: error:") for line in err)
    assert "allowed" in err[0] and "allowed" in err[1]
    assert math.isfinite(json.loads(json.dumps(plan.summary()))["peak_motor_power_W"])


def test_the_plan_command_writes_no_figure_with_no_plots(monkeypatch, tmp_path, capsys):
    """``bplir plan --no-plots``: the plan's CSV and JSON, no plan.png, and
    the summary's figure is null (the solver a stand-in:
    :func:`conftest.quick_plan`)."""
    from bplir_drake.planning import solve as P
    from conftest import quick_plan

    monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(P, "_solve_plan", quick_plan)
    out = tmp_path / "p"
    assert main(["plan", "--incline", "9", "--no-plots", "--json", "--out", str(out)]) == 0
    assert json.loads(capsys.readouterr().out)["figure"] is None
    assert sorted(f.name for f in out.iterdir()) == ["plan.csv", "plan.json"]
    assert main(["plan", "--incline", "9", "--out", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out and (out / "plan.png").stat().st_size > 20_000


def test_tracking_gains_accept_links_shorter_than_the_default_imu_radii(monkeypatch):
    """A robot with 0.34 m links (DFKI's AcroMonk): the gains' plant model is
    built from its plant and friction alone -- the default IMUs at 0.5 m,
    which would not fit on its links, play no part -- and
    ``params.around`` keeps the IMUs' place along the links (their share of
    the default robot's)."""
    import numpy as np

    from bplir_drake.planning import solve as P
    from bplir_drake.params import BplirParams, ParameterError, PlantParams

    plant = PlantParams(m1=0.63, m2=0.63, l1=0.34, l2=0.34, lc1=0.18, lc2=0.16,
                        I1=0.0017, I2=0.0017)
    with pytest.raises(ParameterError, match="must lie on the links"):
        BplirParams(plant=plant)
    p = around(plant)
    d = BplirParams()
    assert (p.imu.r1, p.imu.r2, p.estimator.l1) == pytest.approx(
        (0.34 * d.imu.r1 / d.plant.l1, 0.34 * d.imu.r2 / d.plant.l2, 0.34), rel=1e-12)
    seen = []
    monkeypatch.setattr(P, "plan_gains", lambda model, *a: seen.append(model) or "gains")
    t = np.linspace(0.0, 1.0, 5)
    plan = P.SwingPlan(t, np.zeros((5, 4)), np.zeros(5), np.zeros((5, 2)), True, True, "test",
                       0.0, 20.0, 220.0, 1e-4)
    assert P.tracking_gains(plant, p.friction, plan, cache=False) == "gains"
    assert seen[0].num_continuous_states() == 4


def test_a_solver_that_stops_early_is_not_called_proof_of_no_plan(tmp_path):
    """SNOPT stopped by its iteration limit reports "iteration limit", and
    the one-line message says that a plan may still exist; only a proof of
    infeasible limits is reported as "no feasible plan"."""
    import dataclasses as dc

    from bplir_drake.planning import solve as P
    from bplir_drake.params import preset

    stopped = P.plan_swing(preset(), knots=7, iterations=1, cache=False)
    assert not stopped.feasible and stopped.status == "iteration limit"
    assert stopped.summary()["solver_status"] == "iteration limit"
    assert "stopped without converging (iteration limit), which does not show that none " \
           "exists" in P.no_plan_message(stopped)
    proof = dc.replace(stopped, status="infeasible")
    assert P.no_plan_message(proof).startswith("no feasible plan for a 0 deg line within ")
    assert "the solver found the limits cannot be met" in P.no_plan_message(proof)


def test_the_plan_command_plans_a_swing_from_hanging_as_the_swing_does(monkeypatch, tmp_path,
                                                                       capsys):
    """``bplir plan --set scenario.start=hanging`` solves as a swing from
    hanging does -- the guesses of 3-6 s in turn on 61 knots, SNOPT's
    150 000 minor iterations, the torque within hanging.torque_share of
    its limit (here 0.85), at 48 V the 30 V envelope (hanging.supply_voltage), from the
    hanging pose -- and with none feasible reports the last one, exit 1 (the
    solver is replaced by one that stops at once)."""
    import numpy as np

    from bplir_drake.planning import solve as P
    from bplir_drake.systems.plant import start_configuration

    monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path / "cache"))
    calls = []

    def stops(params, q0, qT, tau_max, power, tmax, knots, time_weight, guess_duration,
              tolerance, iterations, progress=False, guess=None, minor_iterations=None,
              rate_limit=0.0):
        calls.append((knots, guess_duration, minor_iterations, rate_limit, tuple(q0), tau_max,
                      params.motor.supply_voltage))
        t = np.linspace(0.0, guess_duration, 5)
        return P.SwingPlan(t, np.zeros((5, 4)), np.zeros(5), np.zeros((5, 2)), False, False,
                           "stub", params.scenario.incline_deg, 20.0, 220.0, 1e-4,
                           status="iteration limit")

    monkeypatch.setattr(P, "_solve_plan", stops)
    p = with_hardware(BplirParams(), "48v")   # its tries from hanging are planned at 30 V
    hanging = tuple(start_configuration("hanging", p.scenario.grip_spacing, p.plant, 0.0))
    assert main(["plan", "--hardware", "48v", "--set", "scenario.start=hanging", "--set",
                 "hanging.torque_share=0.85", "--out", str(tmp_path / "h"),
                 "--json"]) == 1
    assert [c[1] for c in calls] == [3.0, 4.0, 5.0, 6.0]
    assert {c[0] for c in calls} == {61} and {c[2] for c in calls} == {150_000}
    assert {c[3] for c in calls} == {0.0}   # no elbow-rate bound
    limit = P.plan_torque_limit(p)   # the torque_share of line swings: all of it
    assert [c[5] for c in calls] == pytest.approx([0.85 * limit] * 4) and limit > 19.0
    assert {c[6] for c in calls} == {30.0} and p.motor.supply_voltage == 48.0
    assert all(np.allclose(c[4], hanging) for c in calls)
    out = json.loads(capsys.readouterr().out)
    assert out["feasible"] is False and out["duration_s"] == pytest.approx(6.0)
    calls.clear()   # a line start: one solve on 41 knots, no rate limit, as before
    assert main(["plan", "--out", str(tmp_path / "l"), "--json"]) == 1
    assert [(c[0], c[1], c[3], c[5]) for c in calls] == [(41, 1.5, 0.0, limit)]


def test_a_plan_from_hanging_that_heats_the_driver_gives_way_to_a_cooler_guess(
        monkeypatch, tmp_path, capsys):
    """With ``hanging.i2t_share`` (here 0.35, at 48 V) a feasible plan
    from hanging whose torque alone uses more of the driver's i^2 t budget
    gives way to the next guess; the least heating feasible plan is kept if
    none keeps to it; without it (the 30 V robot) the first feasible guess
    is the plan.  ``bplir plan`` reports the kept plan's share.  The heat is the driver's rule in closed form: a constant
    current i for n driver ticks of dt gives n dt (i^2 - i_cont^2)."""
    import numpy as np

    from bplir_drake.planning import solve as P
    from bplir_drake.systems.motor import interlock_budget

    monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path / "cache"))
    p48 = with_hardware(BplirParams(), "48v")
    assert p48.hanging.i2t_share == BplirParams().hanging.i2t_share == "none"
    p48 = p48.with_(hanging=dc.replace(p48.hanging, i2t_share=0.35))
    m = p48.motor
    budget = interlock_budget(m)

    def torque_heating(share, duration):   # the constant torque whose plan uses share
        ticks = int(duration / m.driver_period) + 1   # the driver's ticks from 0
        i2 = share * budget / (ticks * m.driver_period) + m.i_cont ** 2
        return math.sqrt(i2) * m.torque_per_amp

    heat = {}   # guess duration -> share of the budget its plan uses
    calls = []

    def solves(params, q0, qT, tau_max, power, tmax, knots, time_weight, guess_duration,
               tolerance, iterations, progress=False, guess=None, minor_iterations=None,
               rate_limit=0.0):
        calls.append(guess_duration)
        t = np.linspace(0.0, guess_duration, 50)
        tau = np.full(50, torque_heating(heat[guess_duration], guess_duration))
        return P.SwingPlan(t, np.zeros((50, 4)), tau, np.zeros((50, 2)), True, True, "stub",
                           params.scenario.incline_deg, 20.0, 220.0, 1e-4, status="solved")

    monkeypatch.setattr(P, "_solve_plan", solves)
    hanging = dc.replace(p48.scenario, start="hanging")
    heat.update({3.0: 0.45, 4.0: 0.2, 5.0: 0.1, 6.0: 0.1})
    plan = P.hanging_plan(p48.with_(scenario=hanging))
    assert calls == [3.0, 4.0] and plan.duration == pytest.approx(4.0)
    assert P.planned_i2t(plan, m) == pytest.approx(0.2 * budget, rel=1e-9)
    # `bplir plan` reports the kept plan and its share of the budget
    assert main(["plan", "--hardware", "48v", "--set", "scenario.start=hanging", "--set",
                 "hanging.i2t_share=0.35", "--json", "--out", str(tmp_path / "plan")]) == 0
    assert json.loads(capsys.readouterr().out)["i2t_share"] == pytest.approx(0.2, rel=1e-9)
    calls.clear()   # none keeps to 0.35: the least heating of the four
    heat.update({3.0: 0.9, 4.0: 0.6, 5.0: 0.45, 6.0: 0.7})
    plan = P.hanging_plan(p48.with_(scenario=dc.replace(hanging, incline_deg=1.0)))
    assert calls == [3.0, 4.0, 5.0, 6.0] and plan.duration == pytest.approx(5.0)
    calls.clear()   # without a share (the default): the first feasible guess, however hot
    p30 = BplirParams()
    plan = P.hanging_plan(p30.with_(scenario=dc.replace(p30.scenario, start="hanging",
                                                        incline_deg=2.0)))
    assert calls == [3.0] and P.planned_i2t(plan, p30.motor) == pytest.approx(0.9 * budget)


def test_a_plan_from_hanging_no_guess_finds_starts_from_the_level_lines(monkeypatch, tmp_path):
    """On an inclined line where none of the straight-line guesses is
    feasible (SNOPT's iteration limit: the 48 V swapped robot's +13 deg
    chord), the solver starts from the level line's plan from hanging,
    its angles moved onto the inclined line's start and end
    (:func:`warm_guess`); on a level line there is nothing to start from."""
    import numpy as np

    from bplir_drake.planning import solve as P

    monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path / "cache"))
    calls, level_fails = [], False

    def solves(params, q0, qT, tau_max, power, tmax, knots, time_weight, guess_duration,
               tolerance, iterations, progress=False, guess=None, minor_iterations=None,
               rate_limit=0.0):
        inc = params.scenario.incline_deg
        calls.append((inc, guess_duration if guess is None else "warm"))
        ok = (inc == 0.0 and guess_duration == 4.0 and not level_fails) or guess is not None
        t = np.linspace(0.0, 4.5, 30) if guess is None else guess[0]
        states = np.tile(np.r_[q0, 0.0, 0.0], (len(t), 1)) if guess is None else guess[1]
        if guess is not None:
            assert np.allclose(guess[1][0, :2], q0) and np.allclose(guess[1][-1, :2], qT)
        return P.SwingPlan(t, states, np.zeros(len(t)), np.zeros((len(t), 2)), ok, ok, "stub",
                           inc, 20.0, 220.0, 1e-4, status="solved" if ok else "iteration limit")

    monkeypatch.setattr(P, "_solve_plan", solves)
    p = with_hardware(BplirParams(), "48v")
    up = p.with_(scenario=dc.replace(p.scenario, start="hanging", incline_deg=13.0))
    plan = P.hanging_plan(up)
    assert plan.feasible and plan.incline_deg == 13.0
    assert calls == [(13.0, 3.0), (13.0, 4.0), (13.0, 5.0), (13.0, 6.0),
                     (0.0, 3.0), (0.0, 4.0), (13.0, "warm")]
    calls.clear()   # a level line with no feasible guess: no plan, nothing to start from
    level_fails = True
    with pytest.raises(P.ParameterError, match="no plan found"):
        P.hanging_plan(p.with_(scenario=dc.replace(p.scenario, start="hanging",
                                                   grip_spacing=1.1)))
    assert calls == [(0.0, 3.0), (0.0, 4.0), (0.0, 5.0), (0.0, 6.0)]
