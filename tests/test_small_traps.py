"""Small traps a Drake and python-control user met, each mended: what the
commands print for a swing that did not capture and for a plan the solver
did not prove optimal, the benchmark's plug-in arguments, the hanging
linearisation's friction pole, the traversal's motion log, the modes."""
import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest

from bplir_drake import cli

ROOT = Path(__file__).resolve().parents[1]


def bplir(*argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = cli.main([str(a) for a in argv])
    return rc, out.getvalue(), err.getvalue()


def test_a_swing_that_did_not_capture_prints_its_closest_approach(tmp_path):
    """A timed-out swing has no capture speed: its line says how close the
    gripper came (no 'nan m/s'); the files line names summary.json."""
    spec = f"{ROOT / 'examples' / 'my_controller.py'}:make"
    rc, out, err = bplir("swing", "--controller", spec, "--no-animation", "--no-plots",
                         "--out", tmp_path)
    assert rc == 0, err
    first = out.splitlines()[0]
    assert first.startswith("timeout: t = 3.000 s, no capture: the gripper came within 0.15")
    assert "nan" not in out
    assert out.splitlines()[-1] == f"files in {tmp_path}: swing_log.csv, summary.json"


def test_plan_says_feasible_and_whether_the_solver_proved_it_optimal(tmp_path, monkeypatch):
    """``bplir plan`` says "feasible, not proven optimal (solver ...: its
    status)" instead of "feasible (..., optimal: False)"."""
    from bplir_drake.planning import solve as P

    def stopped(params, *a, **k):
        t = np.linspace(0.0, 1.0, 5)
        return P.SwingPlan(t, np.zeros((5, 4)), np.zeros(5), np.zeros((5, 2)), False, True,
                           "stub", params.scenario.incline_deg, 20.0, 220.0, 1e-4,
                           status="iteration limit")

    monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(P, "_solve_plan", stopped)
    rc, out, err = bplir("plan", "--incline", "9", "--out", tmp_path / "p")
    assert rc == 0, err
    assert out.splitlines()[0] == ("planned swing on a 9 deg line: feasible, not proven optimal "
                                   "(solver stub: iteration limit)")


def test_the_benchmark_passes_controller_arguments_to_its_plugins(tmp_path, monkeypatch):
    """``bplir benchmark --controller-arg`` reaches the factories of the
    plug-ins among --controllers (the presets ignore it), and needs one."""
    from bplir_drake.analysis.montecarlo import benchmark

    seen = []

    def stop(params, controllers, controller_args, **kw):
        seen.extend(benchmark.case_params(params, c, {}, controller_args).controller
                    for c in controllers)
        raise SystemExit(0)

    monkeypatch.setattr(benchmark, "run_benchmark", stop)
    (tmp_path / "gain.py").write_text(
        f"import sys\nsys.path.insert(0, {str(ROOT / 'examples')!r})\n"
        "from my_controller import make as pd\n"
        "def make(params, kp=1.0):\n    return pd(params)\n")
    spec = f"{tmp_path / 'gain.py'}:make"
    with pytest.raises(SystemExit):
        bplir("benchmark", "--controllers", f"plan,{spec}", "--controller-arg", "kp=3.5",
              "--out", tmp_path / "b")
    assert [c.plugin_args for c in seen] == [(), ("kp=3.5",)]
    rc, _, err = bplir("benchmark", "--controllers", "plan", "--controller-arg", "kp=3.5",
                       "--out", tmp_path / "c")
    assert rc == 2 and "--controller-arg needs a plug-in among --controllers" in err


def test_model_names_the_friction_pole_of_the_hanging_linearisation(tmp_path):
    """The hanging eigenvalues' -382 /s pole is the smoothed Coulomb
    friction's slope 2 fc2/(pi b) = 48.9 N m s/rad over the elbow's inertia,
    said beside it; ``modes`` is a property like ``eigenvalues``."""
    from bplir_drake.analysis.model.linearization import hanging_linearization
    from bplir_drake.params import BplirParams

    rc, out, err = bplir("model", "--no-swing", "--json", "--out", tmp_path)
    note = json.loads(out)["hanging_eigenvalues_note"]
    assert rc == 0 and note.startswith("the real pole(s) -382.4 /s come from the smoothed "
                                       "Coulomb friction")
    assert "0.789 and 48.9 N m s/rad (friction.b = 0.01 rad/s)" in note
    lin = hanging_linearization(BplirParams())
    wn, zeta = lin.modes
    assert np.allclose(wn, np.abs(lin.eigenvalues))
    assert bplir("model", "--no-swing", "--json", "--set", "friction.fc1=0",
                 "--set", "friction.fc2=0", "--out", tmp_path)[1].count('"hanging_eigenvalues_'
                                                                        'note": null') == 1


def test_the_traversals_motion_log_says_its_layout(tmp_path):
    """traverse.json says how motion.f64 is laid out, and reading it that way
    gives the traversal's clock and the driver's i^2 t."""
    rc, out, err = bplir("traverse", ROOT / "examples" / "line_flat.toml", "--no-animation",
                         "--no-plots", "--json", "--out", tmp_path)
    data = json.loads(out)
    fmt = data["motion_log_format"]
    assert fmt["columns"][0] == "t (s)" and fmt["columns"][-1] == "i2t (A^2 s)"
    motion = np.fromfile(data["files"]["motion_log"], "<f8").reshape(-1, len(fmt["columns"]))
    assert motion[-1, 0] == pytest.approx(data["totals"]["time_s"], abs=0.02)
    assert motion[:, -1].max() == pytest.approx(data["totals"]["peak_i2t_A2s"], rel=1e-6)


def test_the_swing_figure_draws_the_gripper_against_its_inclined_line():
    """On a +20 deg line the free gripper ends on the line in the figure's
    line frame (above it by the capture distance at most, the grip
    spacing along it), where its height y ends 0.41 m up; every panel has
    its units."""
    from dataclasses import replace

    from bplir_drake.analysis.swing import run_swing
    from bplir_drake.analysis.swing.logs import log_table
    from bplir_drake.params import BplirParams

    p = BplirParams()
    p = p.with_(scenario=replace(p.scenario, incline_deg=20.0))
    res = run_swing(p)
    cols, data = log_table(res)
    end = dict(zip(cols, data[-1]))
    assert res.summary["outcome"] == "captured"
    assert abs(end["gripper_above"]) <= p.gripper.capture_distance + 1e-3
    assert end["gripper_along"] == pytest.approx(p.scenario.grip_spacing, abs=0.05)
    assert end["gripper_y"] == pytest.approx(1.2 * np.sin(np.radians(20.0)), abs=0.03)
    fig = res.plot()
    labels = [a.get_ylabel() for a in fig.axes]
    assert all("[" in label for label in labels), labels
    assert [t.get_text() for t in fig.axes[4].get_legend().get_texts()] == [
        "along the line", "above the line", "the line (20 deg)", "the grip, 1.2 m along it"]


@pytest.mark.slow
@pytest.mark.parametrize("n, columns", [(4, 2), (6, 3), (25, 5), (7, 2)])
def test_success_vs_parameters_has_no_empty_panel_and_keeps_its_rate_clear(n, columns):
    """One panel per drawn quantity (a grid with no empty panel where one
    fits), and the success rate's ticks above the capture-speed limit line
    and its label, not on them."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from bplir_drake.analysis.montecarlo import Distribution, Study
    from bplir_drake.analysis.montecarlo.study_plots import (
        _grid_columns, plot_success_vs_parameters)

    assert _grid_columns(n) == columns
    names = ["true_friction.fv1", "true_friction.fv2", "true_friction.fc1", "true_friction.fc2"]
    study = Study(distributions=tuple(Distribution(f, "uniform", rel=0.2) for f in names),
                  samples=30)
    rng = np.random.default_rng(0)
    rows = [{"capture_speed_mps": s, "success": s < 0.45, "outcome": "captured",
             **{f: rng.uniform(0.8, 1.2) for f in names}} for s in rng.uniform(0.1, 0.6, 30)]
    fig = plot_success_vs_parameters(study, rows)
    FigureCanvasAgg(fig).draw()
    renderer = fig.canvas.get_renderer()
    main = [a for a in fig.axes if a.get_ylabel() == "capture speed [m/s]"]
    twins = [a for a in fig.axes if a.get_ylabel() == "success"]
    assert len(main) == len(twins) == 4 and len(fig.axes) == 8
    title = fig._suptitle.get_window_extent(renderer)
    for ax, twin in zip(main, twins):
        assert not twin.yaxis.label.get_window_extent(renderer).overlaps(title)
        limit_label = ax.texts[0].get_window_extent(renderer)
        limit_line = next(ln for ln in ax.get_lines() if ln.get_linestyle() == "--")
        for tick in twin.get_yticklabels():
            box = tick.get_window_extent(renderer)
            assert not box.overlaps(limit_label)
            assert not box.overlaps(limit_line.get_window_extent(renderer))
