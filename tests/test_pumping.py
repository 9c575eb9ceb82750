"""Pumping manoeuvres from the line: what they run with, how their plans
are kept honest, and how commissioning chooses between a swing and a pump."""
from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import pytest

from bplir_drake.planning import solve as P
from bplir_drake.planning.library import model_inputs
from bplir_drake.params import PUMP_TIME, Manoeuvre, ParameterError, derive, from_dict, preset

sys.path.insert(0, str(Path(__file__).parent))
from test_plan_energy import _simulated  # noqa: E402


def pumping(p):
    """The pumping manoeuvre of the robot ``p``."""
    return derive(p, Manoeuvre(reach="pump"))


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
    its limits none; the swing's rows and study are kept, not chosen; the
    report names the ``scenario.manoeuvre`` a traversal does the same with."""
    from bplir_drake.analysis.commission import commissioning as run
    from bplir_drake.analysis.commission.rows import PlanPoint, StudyVerdict

    grids, calls = {}, []

    def manoeuvre(robot, g, **grid):
        kind = robot.scenario.manoeuvre
        ok = kind == "pump"
        grids[kind] = grid["spacings"]
        calls.append(kind)
        study = StudyVerdict(
            incline_deg=0.0, captured=290 if ok else 72, samples=300 if ok else 100,
            rate=0.967 if ok else 0.72, verdict="not shown" if ok else "below",
            wilson95=[0.94, 0.98], holding=g, manoeuvre=kind, seed=1, outcomes={},
            capture_speed_p95_mps=0.3, capture_speed_p50_mps=0.2,
            peak_voltage_V=20.0, peak_torque_Nm=5.0, samples_to_show=400, impact=None)
        return run.Found(points=[PlanPoint(holding=g, start="line", manoeuvre=kind,
                                           incline_deg=0.0, spacing_m=1.2, how="similarity")],
                         studies=[study],
                         limits=[] if ok else [f"gripper {g}: below"],
                         unshown=[f"gripper {g}: pumping: not shown"] if ok else [],
                         plans=[], binding={g: kind})

    monkeypatch.setattr(run, "_manoeuvre", manoeuvre)
    r = run.commission(preset(), grippers=(2,), hanging=False)
    assert r.limits == [] and r.unshown == ["gripper 2: pumping: not shown"]
    assert r.verdict == "not shown" and r.binding == {2: "pump"}
    assert grids == {"swing": (1.092, 1.2, 1.308), "pump": (1.092, 1.146, 1.2, 1.254, 1.308)}
    chosen = {(st.manoeuvre, st.chosen) for st in r.studies}
    assert chosen == {("pump", True), ("swing", False)}
    assert math.isnan(r.rate(0.0, 1)) and r.rate(0.0, 2) == 0.967
    from bplir_drake.analysis.commission.commission_report import report_markdown

    assert r.manoeuvre == r.summary()["manoeuvre"] == "swing,pump"   # what a traversal runs
    assert '`manoeuvre = "swing,pump"` in the robot\'s `[scenario]`' in \
        report_markdown(dataclasses.replace(r, points=[]))
    # a robot whose file already pumps with gripper 2: the swing is still
    # tried first, each manoeuvre studied once, the same choice
    calls.clear()
    says = preset().with_(scenario=dataclasses.replace(preset().scenario, manoeuvre="swing,pump"))
    again = run.commission(says, grippers=(2,), hanging=False)
    assert calls == ["swing", "pump"] and again.manoeuvre == "swing,pump"
    assert {(st.manoeuvre, st.chosen) for st in again.studies} == chosen
    without = run.commission(preset(), grippers=(2,), hanging=False, pumps=False)
    assert without.limits == ["gripper 2: below"] and len(without.studies) == 1
    assert without.manoeuvre == "swing" and "`manoeuvre = " not in \
        report_markdown(dataclasses.replace(without, points=[]))


def test_bplir_plan_pumps_from_either_gripper(monkeypatch, tmp_path, capsys):
    """``bplir plan --pump --gripper 2``: the swapped robot's pump on 151
    knots, its energy balance said; --pump with --knots is refused in one line."""
    import json

    from bplir_drake import cli
    from conftest import quick_plan

    seen = []

    def solver(params, q0, qT, tau_max, power, tmax, knots, *a, **k):
        seen.append((params.plant.l1, knots, tmax))
        return quick_plan(params, q0, qT, tau_max, power, tmax, knots, *a, **k)

    monkeypatch.setattr(P, "_solve_plan", solver)
    monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path / "cache"))
    rc = cli.main(["plan", "--pump", "--gripper", "2", "--no-plots", "--out", str(tmp_path / "o"),
                   "--json"])
    summary = json.loads(capsys.readouterr().out)
    p = preset()
    assert rc == 0 and summary["manoeuvre"] == "pump" and summary["energy_residual_share"] == 0.0
    assert seen == [(p.plant.l2, 151, 9.37)]   # the robot held by gripper 2, one guess
    rc = cli.main(["plan", "--pump", "--knots", "41", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and err == ["bplir: error: --pump plans on its own knots within the motor's "
                               "power rating; allowed without --knots and --power"]


def _fake(reversals, cost=1.0):
    from types import SimpleNamespace

    return SimpleNamespace(link1_reversals=reversals, feasible=True,
                           objective=lambda w, c=cost: c)


def test_a_row_end_takes_the_manoeuvre_most_of_the_grid_shares(monkeypatch):
    """A row of three pumps reversing link 1 6, 8, 8 times: the end with 6
    is re-solved from its neighbour (8); 8, 6, 8: the middle from its two
    neighbours, the ends kept; 6, 8: no manoeuvre most plans share, kept."""
    from bplir_drake.analysis.commission import refine

    calls = []

    def solve_from(q, initial=None, guess_duration=None):
        calls.append(q.scenario.grip_spacing)
        return _fake(initial.link1_reversals)

    monkeypatch.setattr(refine, "solve_from", solve_from)
    p = preset()
    grid = {(0.0, 1.092): _fake(6), (0.0, 1.2): _fake(8), (0.0, 1.308): _fake(8)}
    out, changed = refine.harmonise(p, grid)
    assert changed == {(0.0, 1.092)} and out[0.0, 1.092].link1_reversals == 8
    calls.clear()
    out, changed = refine.harmonise(p, {(0.0, 1.092): _fake(8), (0.0, 1.2): _fake(6),
                                        (0.0, 1.308): _fake(8)})
    assert changed == {(0.0, 1.2)} and calls == [1.2]
    out, changed = refine.harmonise(p, {(0.0, 1.1): _fake(6), (0.0, 1.2): _fake(8)})
    assert changed == set()


def test_a_new_robots_grid_is_solved_outward_from_its_own_spacing(monkeypatch):
    """No similar robot: the robot's own spacing on a level line is solved
    from straight lines first, its neighbours then from it (continuation)."""
    from bplir_drake.analysis.commission import grid as G

    calls = []

    def solve_from(q, initial=None, guess_duration=None):
        d = q.scenario.grip_spacing
        calls.append((d, "continuation" if initial is not None else "straight"))
        return _fake(8)

    for name, value in (("solve_from", solve_from), ("similar_guesses", lambda q, refs: []),
                        ("_entry", lambda q, plan: None), ("_residual", lambda q, plan: 0.0),
                        ("refined", lambda params, plans: (plans, set())),
                        ("assemble_library", lambda *a: SimpleLib()),
                        ("save_library", lambda lib, path: None)):
        monkeypatch.setattr(G, name, value)
    p = preset()
    solved = G.solve_library(p, [0.0], [1.092, 1.2, 1.308], workers=1, path="unused.npz")
    assert calls == [(1.2, "straight"), (1.092, "continuation"), (1.308, "continuation")]
    assert [solved[0.0, d].how for d in (1.092, 1.2, 1.308)] == ["continuation", "straight line",
                                                                 "continuation"]


@dataclasses.dataclass
class SimpleLib:
    """A stand-in for an assembled library (only replaced and saved)."""

    robot: str = ""


def test_pumps_of_other_phases_are_not_blended_but_the_nearest_is_taken(monkeypatch):
    """A row of two pumps reversing link 1 6 and 8 times: between them a
    pump takes the nearer one's plan (its duration), a single swing none."""
    import numpy as np

    from bplir_drake.planning import library as L

    n = L.LIBRARY_SAMPLES
    states = np.zeros((1, 2, n, 4))
    lib = L.PlanLibrary(key="k", inclines=np.array([0.0]), spacings=np.array([1.1, 1.3]),
                        durations=np.array([[4.0, 5.0]]), states=states,
                        torque=np.zeros((1, 2, n)), gain=np.zeros((1, 2, n, 4)),
                        offset=np.zeros((1, 2, n)), reversals=np.array([[6, 8]]))
    monkeypatch.setattr(L, "find_library", lambda params: lib)
    p = preset()
    for d, duration in ((1.15, 4.0), (1.21, 5.0)):
        plan, _ = L.library_plan(pumping(p.with_(scenario=p.scenario.__class__(grip_spacing=d))))
        assert plan.duration == pytest.approx(duration)
    assert L.library_plan(p.with_(scenario=p.scenario.__class__(grip_spacing=1.15))) is None


def test_a_pumps_grid_halves_each_gap_of_the_swings():
    """A pump is shifted onto a drawn spacing, not blended: its grid splits
    each gap of the swing's grid in two, so no drawn spacing is shifted
    more than a quarter of the swing grid's step."""
    from bplir_drake.analysis.commission.commissioning import PUMP_GRID_DIVISIONS, pump_spacings

    assert PUMP_GRID_DIVISIONS == 2
    assert pump_spacings((1.308, 1.092, 1.2)) == (1.092, 1.146, 1.2, 1.254, 1.308)
    assert pump_spacings((1.2,)) == (1.2,)


def test_a_traversal_pumps_where_commissioning_verified_the_pump(tmp_path, monkeypatch):
    """The default robot at 30 V given ``manoeuvre = "swing,pump"`` with the
    pump library of its stored commission in the cache (grid 1.092-1.308 m
    at 0 deg): a traversal step held by gripper 2 pumps at 1.2 m and at the
    grid's edges, and makes one swing at 0.95 m, at 1.35 m and on a +5 deg
    chord (outside the grid: no verified pump); held by gripper 1 it swings."""
    import shutil

    from bplir_drake.analysis.traverse.step_setup import step_manoeuvre
    from bplir_drake.planning.library import load_library, robot_library_path, save_library

    base = preset()
    pump = derive(base, Manoeuvre(gripper=2, reach="pump"))
    stored = Path(__file__).parents[1] / "results" / "commission" / "bplir" / "plans"
    monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path))
    shutil.copy(stored / robot_library_path(pump).name, tmp_path)
    robot = base.with_(scenario=dataclasses.replace(base.scenario, manoeuvre="swing,pump"))

    def kind(g, spacing, incline=0.0):
        m, p = step_manoeuvre(robot, Manoeuvre(gripper=g, spacing=spacing, incline_deg=incline,
                                               context="traverse"))
        assert m.reach in (None, p.scenario.manoeuvre)
        return p.scenario.manoeuvre

    assert [kind(2, d) for d in (1.092, 1.2, 1.308)] == ["pump"] * 3
    assert [kind(2, 0.95), kind(2, 1.35), kind(2, 1.2, 5.0)] == ["swing"] * 3
    assert kind(1, 1.2) == "swing"
    # the same grid with no plan at 1.146 and 1.2 m: a step between them has
    # nothing verified to pump with (one swing); one beside them still pumps
    path = robot_library_path(pump)
    lib = load_library(path)
    holes = lib.reversals.copy()
    holes[0, 1:3] = -1
    save_library(dataclasses.replace(lib, reversals=holes), path)
    assert [kind(2, 1.17), kind(2, 1.28)] == ["swing", "pump"]
