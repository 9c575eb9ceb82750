"""Disturbances (gusts, torque noise, actuation delay) and the robustness benchmark."""
import dataclasses as dc
import math

import numpy as np
import pytest

from bplir_drake.plotting import save_figure
from bplir_drake.cli import main
from bplir_drake.systems.disturbance import CommandDelay, disturbance_schedule


def test_gusts_and_torque_noise_statistics(params):
    sc = dc.replace(params.scenario, gust_torque=3.0, gust_rate=2.0, gust_duration=0.1,
                    torque_noise=0.7, wind_torque1=0.25)
    t, tau = disturbance_schedule(dc.replace(sc, torque_noise=0.0), seed=4, period=0.01,
                                  duration=2000.0)
    gust = tau[:, 0] - 0.25
    # Poisson arrivals of 0.1 s rectangles: the line is gusty a fraction 1 - exp(-rate*dur)
    assert np.mean(gust != 0) == pytest.approx(1 - math.exp(-0.2), abs=0.01)
    assert np.all(tau[:, 1][gust == 0] == 0)
    single = np.abs(gust[gust != 0])
    assert np.median(single) < 3.0 and np.percentile(single, 99) < 6.0
    _, tau_n = disturbance_schedule(dc.replace(sc, gust_torque=0.0), seed=4, period=0.01,
                                    duration=400.0)
    assert np.all(tau_n[:, 0] == 0.25)
    assert np.std(tau_n[:, 1]) == pytest.approx(0.7, rel=0.03)
    again = disturbance_schedule(sc, seed=4, period=0.01)[1]
    assert np.array_equal(again, disturbance_schedule(sc, seed=4, period=0.01)[1])
    assert not np.array_equal(again, disturbance_schedule(sc, seed=5, period=0.01)[1])


def test_command_delay_shifts_by_whole_periods():
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import TrajectorySource
    from pydrake.trajectories import PiecewisePolynomial

    from bplir_drake.systems.schedule import TickLogger

    T, steps = 0.01, 3
    # value k from t_k + T/2 on: the delay stores at t_{k+1}, as it stores the
    # tick-k command of the schedule (away from the ticks, no rounding of times)
    times = np.arange(40) * T + T / 2
    b = DiagramBuilder()
    src = b.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(
        times, np.arange(40.0).reshape(1, -1))))
    d = b.AddSystem(CommandDelay(1, T, steps))
    b.Connect(src.get_output_port(0), d.get_input_port(0))
    log = TickLogger(b, d.get_output_port(0), T)
    sim = Simulator(b.Build())
    sim.AdvanceTo(0.3)
    t, y = log.arrays(sim.get_context())
    k = np.round(t / T).astype(int)
    assert np.array_equal(y[:, 0][k >= steps], (k - steps)[k >= steps].astype(float))
    assert np.all(y[:, 0][k < steps] == 0)


def test_benchmark_scores_actuation_delay(tmp_path, params):
    from bplir_drake.analysis.montecarlo.benchmark import benchmark_table, plot_benchmark, run_benchmark

    res = run_benchmark(params, ["plan", "cpfl-qft"], quick=True, categories=("delay",),
                        workers=2, out=tmp_path)
    rows = {(r["controller"], r["label"]): r for r in res["rows"]}
    # the default (the delay probed, identified and compensated) lands both
    # (measured 0.261 m/s at 10 ms, 0.166 at 30 ms); the dissertation's design
    # has no delay compensation and crashes far above the 0.5 m/s limit
    # (5.3 and 11.8 m/s: the loop is past its delay margin)
    for label, (lo, hi) in (("10 ms", (0.24, 0.28)), ("30 ms", (0.15, 0.19))):
        assert rows["plan", label]["outcome"] == "captured"
        assert lo < rows["plan", label]["capture_speed_mps"] < hi
        assert rows["cpfl-qft", label]["outcome"] == "crash"
        assert rows["cpfl-qft", label]["capture_speed_mps"] > 4
    assert res["scores"]["plan"] == {"categories": {"delay": 1.0}, "overall": 1.0, "swings": 2}
    assert res["scores"]["cpfl-qft"]["categories"] == {"delay": 0.0}
    assert "| delay | 1.00 | 0.00 |" in benchmark_table(res)
    assert save_figure(plot_benchmark(res), tmp_path / "b.png").stat().st_size > 20_000
    assert (tmp_path / "benchmark_cases.csv").read_text().count("\n") == 5


def test_benchmark_rejects_unknown_controller(tmp_path, capsys):
    assert main(["benchmark", "--quick", "--controllers", "plan,pid", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--controllers: 'pid' is not a controller; allowed" in err
    assert "plan, cpfl-qft, lab" in err


@pytest.mark.parametrize("extra, message", [
    (["--realistic", "no_such_study.toml"], "cannot read study file no_such_study.toml"),
    (["--realistic", "examples/study_realistic.toml", "--realistic-samples", "0"],
     "--realistic-samples = 0 is out of range; allowed [1, 1000000]"),
])
def test_benchmark_checks_its_realistic_study_before_any_work(tmp_path, capsys, monkeypatch,
                                                              extra, message):
    from pathlib import Path

    import bplir_drake.analysis.montecarlo.benchmark as B

    def no_work(*a, **k):
        raise AssertionError("benchmarked before checking --realistic")

    monkeypatch.setattr(B, "run_benchmark", no_work)
    monkeypatch.chdir(Path(__file__).resolve().parents[1])
    assert main(["benchmark", "--quick", *extra, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err


def test_benchmark_refuses_a_realistic_directory_of_another_study_before_any_work(
        tmp_path, capsys, monkeypatch):
    from pathlib import Path

    import bplir_drake.analysis.montecarlo.benchmark as B
    from bplir_drake.analysis.montecarlo import Study
    from bplir_drake.analysis.montecarlo.study import STUDY_FILE, save_study
    from bplir_drake.params import BplirParams

    def no_work(*a, **k):
        raise AssertionError("benchmarked before checking the realistic study's directory")

    monkeypatch.setattr(B, "run_benchmark", no_work)
    monkeypatch.chdir(Path(__file__).resolve().parents[1])
    other = tmp_path / "realistic" / "plan"
    other.mkdir(parents=True)
    save_study(Study(params=BplirParams(), samples=3, seed=5), other / STUDY_FILE)
    assert main(["benchmark", "--quick", "--controllers", "plan", "--realistic",
                 "examples/study_realistic.toml", "--realistic-samples", "2",
                 "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holds results of a different study" in err


@pytest.fixture(scope="module")
def quick_benchmark(tmp_path_factory):
    """``bplir benchmark --quick --seed 1 --format svg`` of the default robot
    and controller: its JSON and its output directory."""
    import contextlib
    import io
    import json

    out = tmp_path_factory.mktemp("benchmark")
    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        assert main(["benchmark", "--quick", "--controllers", "plan", "--seed", "1",
                     "--format", "svg", "--workers", "2", "--out", str(out), "--json"]) == 0
    return json.loads(text.getvalue()), out


@pytest.mark.slow
def test_the_default_on_the_quick_benchmark_held_out_seed_1(quick_benchmark):
    """``bplir benchmark --quick --seed 1`` for the default robot and controller.
    Seed 1 is held out: the calibration default, the noise widening and the
    landing laws were chosen on the realistic study's root seeds 0 and 100
    and this benchmark's seed 0.  Measured: every case captured but IMU
    noise x10 (a crash at 1.16 m/s: with the IMUs alone the landing's height
    estimate is then off by more than the capture band) and the knock of
    severity 2 (a crash at 4.46 m/s)."""
    res, _ = quick_benchmark
    score = res["scores"]["plan"]
    assert score["overall"] == pytest.approx(9 / 10) and score["swings"] == 30
    assert score["categories"]["sensor noise"] == 0.5
    assert score["categories"]["knockdown"] == 0.5
    assert [r["label"] for r in res["rows"] if not r["success"]] == ["IMU noise x10",
                                                                      "severity 2"]


@pytest.mark.slow
def test_figures_are_vector_on_request_and_the_benchmark_legend_covers_no_bar(tmp_path, capsys,
                                                                            quick_benchmark):
    """``bplir swing --format pdf`` and ``bplir benchmark --format svg`` write
    vector figures, the PDF's text in embedded TrueType fonts (no Type 3),
    the SVG's as text; the benchmark figure's category labels are whole,
    inside the figure, and its legend overlaps no bar."""
    import json

    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from bplir_drake.analysis.montecarlo.benchmark import plot_benchmark

    assert main(["swing", "--format", "pdf", "--no-animation", "--out", str(tmp_path / "s"),
                 "--json"]) == 0
    figure = json.loads(capsys.readouterr().out)["files"]["figure"]
    pdf = open(figure, "rb").read()
    assert figure.endswith("swing.pdf") and pdf[:5] == b"%PDF-"
    assert b"/Type3" not in pdf and b"/FontFile2" in pdf
    res, out = quick_benchmark
    svg = (out / "benchmark.svg").read_text()
    assert svg.lstrip().startswith("<?xml") and "<svg" in svg and "<text" in svg
    fig = plot_benchmark(res)
    FigureCanvasAgg(fig).draw()
    renderer = fig.canvas.get_renderer()
    ax = fig.axes[0]
    legend = ax.get_legend().get_window_extent(renderer)
    assert not any(legend.overlaps(bar.get_window_extent(renderer)) for bar in ax.patches)
    labels = [t.get_text() for t in ax.get_xticklabels()]
    assert labels == list(res["categories"]) + ["overall"]
    names = [t.get_text() for t in fig.axes[1].get_yticklabels()]   # the cases, by meaning
    assert "mass of link 2 x1.2" in names and not any("true_" in n for n in names)
    assert {t.get_fontsize() for t in fig.axes[1].get_yticklabels()} == {7.0}
    whole = fig.bbox
    for text in ax.get_xticklabels() + fig.axes[1].get_xticklabels():
        box = text.get_window_extent(renderer)
        assert whole.x0 <= box.x0 and box.x1 <= whole.x1 and whole.y0 <= box.y0, text
