"""Pumping manoeuvres from the line: what they run with, how their plans
are kept honest, and how commissioning chooses between a swing and a pump."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

from bplir_drake.diagrams import plan as P
from bplir_drake.diagrams.plan_library import model_inputs
from bplir_drake.params import PUMP_TIME, ParameterError, from_dict, preset, pumping

sys.path.insert(0, str(Path(__file__).parent))
from test_plan_energy import _simulated  # noqa: E402


def test_a_pump_runs_with_the_robots_own_timeout_and_knots():
    """20 sqrt(L/g) (9.37 s on the default robot), 151 knots, guesses of
    8.5, 10.5 and 12.5 sqrt(L/g); a longer timeout of the robot's is kept."""
    p = preset()
    t0 = math.sqrt((p.plant.l1 + p.plant.l2) / p.plant.g)
    pump = pumping(p)
    assert PUMP_TIME == 20.0
    assert pump.scenario.manoeuvre == "pump" and pump.scenario.max_time == round(20 * t0, 2) == 9.37
    assert pumping(p.with_(scenario=p.scenario.__class__(max_time=12.0))).scenario.max_time == 12.0
    inputs, single = model_inputs(pump), model_inputs(p)
    assert inputs["knots"] == P.PUMP_KNOTS == 151 and "manoeuvre" not in single
    assert inputs["guesses"] == [round(k * t0, 2) for k in (8.5, 10.5, 12.5)]
    assert inputs["tmax"] == 9.37 and single["tmax"] == 3.0
    with pytest.raises(ParameterError, match="'pump' starts on the line"):
        from_dict({"scenario": {"manoeuvre": "pump", "start": "hanging"}})


def test_a_pump_whose_plan_does_not_keep_the_robots_energy_is_not_feasible(monkeypatch):
    """The solver's plan claimed with no torque (its work lent by the
    steps): "energy not kept"; the same motion with its torque is kept."""
    p = preset()
    moved = _simulated(p)

    def solved(params, *a, **k):
        return moved

    monkeypatch.setattr(P, "_solve_plan", solved)
    kept = P.pump_solve(pumping(p.with_(scenario=p.scenario.__class__(grip_spacing=1.21))),
                        guess_duration=4.0)
    assert kept.feasible
    lent = type(moved)(**{**moved.__dict__, "torque": 0.0 * moved.torque})
    monkeypatch.setattr(P, "_solve_plan", lambda params, *a, **k: lent)
    plan = P.pump_solve(pumping(p.with_(scenario=p.scenario.__class__(grip_spacing=1.22))),
                        guess_duration=4.0)
    assert not plan.feasible and plan.status == "energy not kept"


def test_commissioning_keeps_the_manoeuvre_whose_studies_do_better(monkeypatch):
    """A swing below the bar and a pump shown ready: the pump is the robot's,
    its limits none; the swing's rows and study are kept, not chosen."""
    from bplir_drake.analysis.commission import run

    def manoeuvre(robot, g, **grid):
        kind = robot.scenario.manoeuvre
        ok = kind == "pump"
        study = dict(incline_deg=0.0, captured=290 if ok else 72, samples=300 if ok else 100,
                     rate=0.967 if ok else 0.72, verdict="not shown" if ok else "below",
                     wilson95=[0.94, 0.98], holding=g, manoeuvre=kind, seed=1, outcomes={},
                     capture_speed_p95_mps=0.3, capture_speed_p50_mps=0.2,
                     peak_voltage_V=20.0, peak_torque_Nm=5.0, samples_to_show=400, impact=None)
        return run.Found(points=[dict(holding=g, start="line", manoeuvre=kind, incline_deg=0.0,
                                      spacing_m=1.2, how="similarity")], studies=[study],
                         limits=[] if ok else [f"gripper {g}: below"],
                         unshown=[f"gripper {g}: pumping: not shown"] if ok else [],
                         plans=[], binding={g: kind})

    monkeypatch.setattr(run, "_manoeuvre", manoeuvre)
    r = run.commission(preset(), grippers=(2,), hanging=False)
    assert r.limits == [] and r.unshown == ["gripper 2: pumping: not shown"]
    assert r.verdict == "not shown" and r.binding == {2: "pump"}
    chosen = {(st["manoeuvre"], st["chosen"]) for st in r.studies}
    assert chosen == {("pump", True), ("swing", False)}
    assert math.isnan(r.rate(0.0, 1)) and r.rate(0.0, 2) == 0.967
    without = run.commission(preset(), grippers=(2,), hanging=False, pumps=False)
    assert without.limits == ["gripper 2: below"] and len(without.studies) == 1
