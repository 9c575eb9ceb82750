"""The shipped plan libraries: a scenario inside a library's grid gets its
plan and tracking gains interpolated in milliseconds, close to the plan
the planner solves there, and only for the nominal model the library was
solved for."""
import dataclasses as dc
import numpy as np
import pytest

from bplir_drake.analysis.traverse.step_setup import swing_chord
from moves import traverse_swing
from bplir_drake.planning import solve as P
from bplir_drake.planning.library import (LIBRARY_INCLINES, LIBRARY_SPACINGS,
                                               library_path, library_plan, load_library)
from bplir_drake.params import preset
from bplir_drake.systems.plant import initial_configuration
from bplir_drake.params import with_hardware


def _at(p, incline=0.0, spacing=1.2, **plan):
    p = p.with_(scenario=dc.replace(p.scenario, incline_deg=incline, grip_spacing=spacing))
    return p.with_(plan=dc.replace(p.plan, **plan)) if plan else p


@pytest.fixture(scope="module")
def robots():
    base = preset()
    return {"swing": base.with_(path=dc.replace(base.path, mode="plan")),
            "traverse-1": traverse_swing(base, 1, 1.2, 0.0),
            "traverse-2": traverse_swing(base, 2, 1.2, 0.0)}


def test_every_default_robot_has_a_library_that_blends_where_it_can(robots):
    """The single swing and both traversal robots ship a library over
    -20..+20 deg and 0.9-1.5 m.  A scenario is blended only where the plans
    around it exist and reverse link 1 equally often
    (:func:`same_manoeuvre`): everywhere but one corner cell for the
    original robot (at -20 deg, 0.9 m the plan's last link-1 bump is
    missing); the swapped robot (the heavy link swinging, at the edge of
    its torque) has holes uphill and switches to a pumping swing."""
    from bplir_drake.planning.library import same_manoeuvre

    for name, p in robots.items():
        lib = load_library(library_path(p))
        assert lib is not None, name
        assert lib.inclines.tolist() == list(LIBRARY_INCLINES)
        assert lib.spacings.tolist() == list(LIBRARY_SPACINGS)
        ok = lib.reversals >= 0
        assert np.nanmax(lib.durations) < p.scenario.max_time
        cells = [same_manoeuvre(lib, a + 2.5, d + 0.05) for a in LIBRARY_INCLINES[:-1]
                 for d in LIBRARY_SPACINGS[:-1]]
        if name != "traverse-2":
            assert ok.all() and cells.count(False) == 1, name
            assert not same_manoeuvre(lib, -17.5, 0.95)
        else:
            assert SWAPPED_BLENDABLE_CELLS == cells.count(True), (name, lib.reversals)
        # the horizontal line at the set-up spacing, and every grid point
        # that has a plan, blends
        assert same_manoeuvre(lib, 0.0, 1.2)
        assert all(same_manoeuvre(lib, a, d) == ok[i, j] for i, a in enumerate(LIBRARY_INCLINES)
                   for j, d in enumerate(LIBRARY_SPACINGS))


#: cells (of 48) of the swapped robot's library where a scenario is blended
SWAPPED_BLENDABLE_CELLS = 38


def test_a_grid_point_gives_the_solved_plan_and_its_gains(robots):
    """At a grid point the library returns its plan unchanged (the end
    shift is below the planner's tolerance) and Drake's LQR gains along it."""
    p = _at(robots["swing"], 10.0, 1.2)
    plan, gains = library_plan(p)
    solved = P.scenario_plan(_at(p, 10.0, 1.2, library=False))   # shipped
    lib = load_library(library_path(p))
    i, j = LIBRARY_INCLINES.index(10.0), LIBRARY_SPACINGS.index(1.2)
    assert np.abs(plan.states - lib.states[i, j]).max() < 2e-4
    assert plan.duration == pytest.approx(lib.durations[i, j], abs=1e-12)
    # the shipped plan at +10 deg is the library's manoeuvre
    assert plan.duration == pytest.approx(solved.duration, abs=0.02)
    assert plan.link1_reversals == solved.link1_reversals
    assert gains.x0.end_time() == pytest.approx(plan.duration)


def test_between_grid_points_the_blend_is_close_to_the_solved_plan(robots):
    """At 0 deg and 1.15 / 1.27 m (between the 1.1, 1.2 and 1.3 m plans;
    the planner's own plans ship with the package) the blend starts and
    ends exactly at the start pose and the target, keeps the motor's
    voltage envelope, and follows the solved plan within a few mrad and a
    few tenths of a N m, at the same cost."""
    for spacing in (1.15, 1.27):
        p = _at(robots["swing"], 0.0, spacing)
        plan, _ = library_plan(p)
        solved = P.scenario_plan(_at(p, 0.0, spacing, library=False))
        q0 = initial_configuration(spacing, p.plant, 0.0)
        assert np.abs(plan.states[0, :2] - q0).max() < 1e-12
        assert np.abs(plan.states[-1, :2] - P.planned_target(p, p.plan.end_depth)).max() < 1e-12
        assert plan.peak_voltage <= plan.voltage_limit
        s = np.linspace(0.0, 1.0, 201)
        a = np.array([np.interp(s, plan.times / plan.duration, plan.states[:, k])
                      for k in range(2)])
        b = np.array([np.interp(s, solved.times / solved.duration, solved.states[:, k])
                      for k in range(2)])
        assert np.abs(a - b).max() < 0.005, spacing   # measured 0.0014 rad (1.15 m)
        ta = np.interp(s, plan.times / plan.duration, plan.torque)
        tb = np.interp(s, solved.times / solved.duration, solved.torque)
        assert np.abs(ta - tb).max() < 0.4, spacing   # measured 0.26 N m (1.27 m)
        assert plan.duration == pytest.approx(solved.duration, abs=0.01)
        assert plan.objective() == pytest.approx(solved.objective(), rel=0.02)


def test_only_the_model_the_library_was_solved_for_reads_it(robots):
    """Another nominal model, a scenario outside the grid, a single swing
    from hanging (no library: the traversal's tries from hanging have
    theirs, tests/test_hanging_library.py) or ``plan.library = false``:
    no library plan."""
    p = robots["swing"]
    assert library_plan(_at(p, 13.0, 1.23)) is not None
    heavier = p.with_(plant=dc.replace(p.plant, m2=p.plant.m2 * 1.05))
    assert library_plan(_at(heavier, 13.0, 1.23)) is None
    assert library_plan(_at(p, 22.0, 1.2)) is None
    assert library_plan(_at(p, 0.0, 1.55)) is None
    assert library_plan(_at(p, 0.0, 0.85)) is None
    assert library_plan(_at(p, 13.0, 1.2, library=False)) is None
    hanging = p.with_(scenario=dc.replace(p.scenario, start="hanging"))
    assert library_plan(hanging) is None


def test_a_swing_at_an_incline_off_the_grid_captures(robots):
    """+13 deg (between the +10 and +15 deg plans), 1.23 m: the default
    robot tracks the blended plan and captures, seeds 0-2."""
    from bplir_drake.analysis.swing.swing_runner import run_swing

    p = _at(preset(), 13.0, 1.23)
    assert P.tracking_plan(p)[0].status == "interpolated"
    out = [run_swing(p, seed=s).summary for s in range(3)]
    assert [r["outcome"] for r in out] == ["captured"] * 3
    assert max(r["capture_speed_mps"] for r in out) < 0.5
    assert max(r["peak_voltage_V"] for r in out) <= out[0]["max_voltage_V"]


def test_the_tower_span_at_48v_plans_every_swing_from_the_libraries():
    """examples/line_tower.toml (a 60 m span, -10.5..+9.7 deg chords) with
    the 48 V supply it needs (docs/hardware.md): every swing of its route,
    holding with either gripper, has its plan and tracking gains blended
    from the shipped 48 V traversal libraries, so the span waits for no
    planner; at 30 V the swapped robot's swings on its steepest uphill
    chords are not blended (its plans there change manoeuvre)."""
    from pathlib import Path

    from bplir_drake.analysis.traverse.line import load_line
    from bplir_drake.analysis.traverse.route import plan_route

    line = load_line(Path(__file__).resolve().parents[1] / "examples" / "line_tower.toml")

    def swings(p):
        for r in plan_route(line, p):
            for holding, start, hold, reach in ((1, r.rear, r.hold, r.spacing1),
                                                (2, r.hold, r.hold + r.spacing2, r.spacing2)):
                yield traverse_swing(p, holding, *swing_chord(line, start, hold, reach))

    at48 = list(swings(with_hardware(preset(), "48v")))
    assert len(at48) == 20
    assert max(q.scenario.incline_deg for q in at48) > 9.5
    assert all(library_plan(q) is not None for q in at48)
    at30 = [q for q in swings(preset()) if library_plan(q) is None]
    assert at30 and all(q.scenario.incline_deg > 5.0 for q in at30)
