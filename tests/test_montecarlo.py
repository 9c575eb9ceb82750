"""Monte Carlo studies: reproducibility, resume, failures, replay, Dask, CLI."""
import csv
import dataclasses as dc
import json
import math

import numpy as np
from types import SimpleNamespace
import pytest

from bplir_drake.analysis import montecarlo as mc
from bplir_drake.cli import main
from bplir_drake.params import ParameterError

SMALL = 4  # samples of the shared study


@pytest.fixture(scope="module")
def study():
    return mc.Study(samples=SMALL, seed=11)


@pytest.fixture(scope="module")
def two_worker_dir(tmp_path_factory, study):
    out = tmp_path_factory.mktemp("mc2")
    summary = mc.run_study(study, out, workers=2)
    return out, summary


def _table(path):
    return (path / mc.RESULTS_FILE).read_text()


def test_default_study_is_the_dissertations_friction_study():
    st = mc.Study()
    assert st.names == [f"true_friction.{k}" for k in ("fv1", "fv2", "fc1", "fc2")]
    assert all(d.dist == "uniform" and d.rel == 0.2 for d in st.distributions)
    # draws stay within +/-20 % of nominal, are spread over it, and the nominal
    # model the controller uses is unchanged
    draws = np.array([list(mc.draw_values(st, k).values()) for k in range(400)])
    nominal = np.array([st.params.friction.fv1, st.params.friction.fv2,
                        st.params.friction.fc1, st.params.friction.fc2])
    rel = draws / nominal - 1
    assert rel.min() >= -0.2 and rel.max() <= 0.2
    assert rel.min() < -0.19 and rel.max() > 0.19
    assert np.std(rel) == pytest.approx(0.2 / math.sqrt(3), rel=0.08)  # uniform variance
    p, seed, drawn = mc.sample_params(st, 3)
    assert p.friction == st.params.friction and p.true_friction.fc2 == drawn["true_friction.fc2"]
    assert seed == mc.sample_seed(0, 3)


def test_distributions_normal_truncnormal_absolute():
    st = mc.study_from_dict({"samples": 5, "seed": 2, "uncertain": {
        "true_plant.m2": {"dist": "normal", "rel": 0.1},
        "imu.gyro_bias1": {"dist": "truncnormal", "abs": 0.01, "clip": 1.5},
        "imu.misalign1": {"dist": "uniform", "abs": math.radians(2.5)},
        "scenario.wind_torque1": {"dist": "uniform", "abs": 0.5, "center": 0.2}}})
    d = np.array([list(mc.draw_values(st, k).values()) for k in range(2000)])
    assert np.mean(d[:, 0]) == pytest.approx(1.5155, rel=0.01)
    assert np.std(d[:, 0]) == pytest.approx(0.15155, rel=0.06)
    assert np.abs(d[:, 1]).max() <= 0.015 and np.abs(d[:, 1]).max() > 0.014
    # a normal truncated at +/-1.5 sigma has std 0.7426 sigma (scipy's truncnorm)
    from scipy.stats import truncnorm
    assert np.std(d[:, 1]) == pytest.approx(0.01 * truncnorm(-1.5, 1.5).std(), rel=0.05)
    assert np.abs(d[:, 2]).max() <= math.radians(2.5)
    assert d[:, 3].min() >= -0.3 and d[:, 3].max() <= 0.7
    # one stream per quantity: adding a quantity leaves the others' draws alone
    st2 = st.with_(distributions=st.distributions[:1])
    assert mc.draw_values(st2, 7)["true_plant.m2"] == mc.draw_values(st, 7)["true_plant.m2"]


def test_wilson_interval_matches_closed_form():
    def wilson(k, n, z=1.959963984540054):
        p = k / n
        c = (p + z * z / (2 * n)) / (1 + z * z / n)
        h = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
        return c - h, c + h
    from scipy.stats import binomtest

    for k, n in ((19, 20), (1000, 1000), (0, 10), (937, 1000), (3, 7)):
        assert mc.wilson_interval(k, n) == pytest.approx(wilson(k, n), abs=1e-12)
        ci = binomtest(k, n).proportion_ci(0.95, method="wilson")   # scipy's, beside it
        assert mc.wilson_interval(k, n) == pytest.approx((ci.low, ci.high), abs=1e-12)
    lo, hi = mc.wilson_interval(1000, 1000)
    assert lo == pytest.approx(0.99617, abs=1e-5) and hi == 1.0
    assert [mc.wilson_interval(k, n)[k > 0] for k, n in ((0, 400), (400, 400), (0, 7))] \
        == [0.0, 1.0, 0.0]   # exactly, as scipy's


def test_same_seed_same_table_with_one_and_two_workers(tmp_path, study, two_worker_dir):
    out2, s2 = two_worker_dir
    s1 = mc.run_study(study, tmp_path, workers=1)
    assert _table(tmp_path) == _table(out2)
    assert s1["success_rate"] == s2["success_rate"] and s1["samples"] == SMALL
    rows = mc.read_results(out2 / mc.RESULTS_FILE)
    assert [r["index"] for r in rows] == list(range(SMALL))
    assert all(r["outcome"] in ("captured", "crash", "timeout", "fault") for r in rows)
    # every fixed gripper opened only after a capture
    assert all(r["fixed_gripper_open"] == r["success"] for r in rows)
    lo, hi = s2["success_rate_ci95"]
    assert lo <= s2["success_rate"] <= hi


def test_interrupted_study_resumes_without_recomputing(tmp_path, study, two_worker_dir):
    out2, _ = two_worker_dir
    # an interrupted run: two finished rows and a third cut short mid-line
    lines = _table(out2).splitlines()
    mc.save_study(study, tmp_path / mc.STUDY_FILE)
    (tmp_path / mc.RESULTS_FILE).write_text("\n".join(lines[:3]) + "\n" + lines[3][:25])
    with pytest.warns(UserWarning, match="1 damaged row run again: line 4: it has 3 cells"):
        summary = mc.run_study(study, tmp_path, workers=1)   # the cut row, said and re-run
    assert summary["run"]["resumed_from"] == 2 and summary["run"]["computed_now"] == SMALL - 2
    assert _table(tmp_path) == _table(out2)
    # growing the study computes only the new samples
    again = mc.run_study(study.with_(samples=SMALL + 1), tmp_path, workers=1)
    assert again["run"]["computed_now"] == 1 and again["samples"] == SMALL + 1
    assert _table(tmp_path).startswith(_table(out2).rstrip("\n"))
    # a different study is refused, not mixed in
    with pytest.raises(mc.StudyError, match="different study"):
        mc.run_study(study.with_(seed=12), tmp_path, workers=1)


def test_failing_samples_are_recorded_and_the_study_goes_on(tmp_path):
    # grip spacings beyond the links' reach (l1 + l2 = 2.154 m) cannot start
    st = mc.study_from_dict({"samples": 6, "seed": 5, "uncertain": {
        "scenario.grip_spacing": {"dist": "uniform", "abs": 2.0, "center": 3.2},
        }})
    # on the path generator: a reachable draw (1.84 m) needs no plan (40 s of SNOPT)
    st = st.with_(params=st.params.with_(path=dc.replace(st.params.path, mode="adaptive")))
    spacing = [mc.draw_values(st, k)["scenario.grip_spacing"] for k in range(6)]
    reachable = [k for k, d in enumerate(spacing) if d < 2.0]
    assert 0 < len(reachable) < 6
    summary = mc.run_study(st, tmp_path, workers=2)
    rows = mc.read_results(tmp_path / mc.RESULTS_FILE)
    assert len(rows) == 6
    for r in rows:
        if r["index"] in reachable:
            assert r["outcome"] != "error" and r["error"] == ""
        else:
            assert r["outcome"] == "error" and "out of reach" in r["error"]
    assert {f["index"] for f in summary["failed_samples"]} == set(range(6)) - set(reachable)
    assert summary["samples"] == 6


def test_replay_reproduces_a_sample_exactly(two_worker_dir, tmp_path, capsys):
    out2, _ = two_worker_dir
    k = 2
    assert main(["swing", "--replay", str(out2), "--sample", str(k), "--no-animation",
                 "--no-plots", "--out", str(tmp_path), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert got["replay"]["matches_recorded"] is True
    row = mc.read_results(out2 / mc.RESULTS_FILE)[k]
    assert got["seed"] == row["seed"]
    for f in ("capture_speed_mps", "swing_time_s", "peak_torque_Nm", "energy_in_J"):
        assert got[f] == row[f]
    assert got["true_friction"]["fc2"] == row["true_friction.fc2"]


@pytest.mark.parametrize("argv, words", [
    (["--replay", "DIR", "--sample", "99"], "--sample 99 is out of range; allowed 0..3"),
    (["--replay", "DIR", "--sample", "1", "--incline", "5"], "drop --incline"),
    (["--sample", "1"], "go together"),
])
def test_bad_replay_exit_2(argv, words, two_worker_dir, capsys):
    out2, _ = two_worker_dir
    argv = [a.replace("DIR", str(out2)) for a in argv]
    assert main(["swing", *argv, "--out", str(out2 / "replay")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("bplir: error:") and err.count("\n") == 1 and words in err


@pytest.mark.slow
def test_dask_local_cluster_gives_the_same_table(tmp_path, two_worker_dir):
    pytest.importorskip("dask.distributed")
    out2, _ = two_worker_dir
    small = mc.Study(samples=2, seed=11)
    summary = mc.run_study(small, tmp_path, dask=True, workers=2)
    assert summary["run"]["executor"] == "dask"
    assert _table(tmp_path).splitlines() == _table(out2).splitlines()[:3]


def test_cli_montecarlo_json_plots_and_study_file(tmp_path, capsys):
    f = tmp_path / "study.toml"
    f.write_text('samples = 2\nseed = 11\n[parameters.scenario]\nincline_deg = 0.0\n'
                 '[uncertain."true_friction.fc2"]\ndist = "uniform"\nrel = 0.2\n')
    out = tmp_path / "out"
    assert main(["montecarlo", "--study", str(f), "--workers", "2", "--out", str(out),
                 "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    for key in ("success_rate", "success_rate_ci95", "samples", "failed_samples", "seed"):
        assert key in s
    assert s["samples"] == 2 and s["seed"] == 11
    for name in ("success_vs_parameters.png", "histograms.png", "influence.png"):
        assert (out / name).stat().st_size > 20_000
    with open(out / mc.RESULTS_FILE) as fh:
        header = next(csv.reader(fh))
    assert "true_friction.fc2" in header and "capture_speed_mps" in header


@pytest.mark.parametrize("toml, words", [
    ('[uncertain."true_plant.mass"]\ndist = "uniform"\nrel = 0.1\n',
     "unknown uncertain parameter 'true_plant.mass'"),
    ('[uncertain."plant.m1"]\ndist = "uniform"\nrel = 0.1\n', "perturb true_plant.m1"),
    ('[uncertain."true_plant.m1"]\ndist = "uniform"\nrel = -0.1\n', "must be a finite number >= 0"),
    ('[uncertain."true_plant.m1"]\ndist = "cauchy"\nrel = 0.1\n', "dist = 'cauchy' is unknown"),
    ("samples = 0\n", "samples = 0 must be a whole number >= 1"),
    ("samples = 3\n[parameters.scenario]\nincline_deg = 95\n", "incline_deg = 95 is out of range"),
    ("samples = [3\n", "malformed TOML"),
])
def test_bad_study_files_exit_2(tmp_path, toml, words, capsys):
    f = tmp_path / "bad.toml"
    f.write_text(toml)
    assert main(["montecarlo", "--study", str(f), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("bplir: error:") and err.count("\n") == 1 and words in err


def test_bad_montecarlo_options_exit_2(tmp_path, capsys):
    assert main(["montecarlo", "-n", "0", "--out", str(tmp_path)]) == 2
    assert "samples = 0" in capsys.readouterr().err
    assert main(["montecarlo", "--workers", "0", "--out", str(tmp_path)]) == 2
    assert "--workers = 0 is out of range; allowed [1, 256]" in capsys.readouterr().err


def test_nominal_controller_never_sees_true_parameters():
    st = mc.study_from_dict({"uncertain": {"true_plant.m2": {"dist": "uniform", "rel": 0.3}}})
    p, _, drawn = mc.sample_params(st, 0)
    assert p.true_plant.m2 == drawn["true_plant.m2"] != p.plant.m2 == 1.5155
    with pytest.raises(ParameterError):
        mc.Distribution("controller.period", "uniform", rel=0.1)


def test_broad_example_study_covers_every_kind_of_uncertainty():
    from pathlib import Path

    st = mc.load_study(Path(__file__).parent.parent / "examples" / "study_broad.toml")
    blocks = {d.block for d in st.distributions}
    assert blocks == {"true_friction", "true_plant", "imu", "scenario"}
    assert {d.dist for d in st.distributions} == {"uniform", "normal", "truncnormal"}
    p, _, drawn = mc.sample_params(st, 0)
    assert abs(drawn["imu.misalign1"]) <= math.radians(2.5)
    assert p.plant == st.params.plant            # the controller's model is nominal
    assert p.true_plant.l2 == drawn["true_plant.l2"]


@pytest.mark.slow
def test_unreachable_dask_scheduler_is_one_line_exit_2(tmp_path, capsys, monkeypatch):
    pytest.importorskip("dask.distributed")
    from bplir_drake.analysis.montecarlo import executors

    monkeypatch.setattr(executors, "SCHEDULER_TIMEOUT", 1.0)   # nothing listens on port 9
    assert main(["montecarlo", "-n", "2", "--scheduler", "tcp://127.0.0.1:9",
                 "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in err
    assert (tmp_path / "study.toml").exists()   # nothing computed, nothing lost


def test_true_state_study_records_it_and_swings_on_the_true_state(tmp_path, capsys):
    """``--true-state``: the study file records ``use_estimator = false`` and
    every sample is the swing controlled from the true state (what
    estimation costs a study; README, realistic study)."""
    from bplir_drake.analysis.swing.swing_runner import run_swing

    out = tmp_path / "ts"
    assert main(["montecarlo", "-n", "1", "--seed", "5", "--workers", "1", "--true-state",
                 "--no-plots", "--out", str(out), "--json"]) == 0
    row = json.loads(capsys.readouterr().out)
    st = mc.load_study(out / mc.STUDY_FILE)
    assert st.params.scenario.use_estimator is False
    p, seed, _ = mc.sample_params(st, 0)
    with open(out / mc.RESULTS_FILE) as fh:
        rec = next(csv.DictReader(fh))
    truth = run_swing(p, seed=seed).summary
    assert truth["outcome"] == rec["outcome"] == "captured" and row["successes"] == 1
    assert float(rec["capture_speed_mps"]) == pytest.approx(truth["capture_speed_mps"], abs=1e-12)
    ekf = run_swing(p, seed=seed, use_estimator=True).summary
    assert abs(ekf["capture_speed_mps"] - truth["capture_speed_mps"]) > 1e-4


def test_true_state_and_an_estimator_exclude_each_other(tmp_path, capsys):
    assert main(["montecarlo", "-n", "1", "--true-state", "--estimator", "m:f",
                 "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("bplir: error: --true-state and --estimator") and err.count("\n") == 1


def test_figures_a_reviewer_would_not_send_back(tmp_path):
    """A study of 25 quantities draws the 9 most correlated with the result
    and says so; histogram counts are whole numbers; 4 samples rank nothing
    (the influence figure says so); a line sensor's errors are not ranked on
    a robot without one; another robot's swing figure carries its name."""
    import dataclasses

    from bplir_drake.analysis.montecarlo.statistics import MIN_INFLUENCE_SAMPLES, influence
    from bplir_drake.analysis.montecarlo.study_plots import (MAX_PANELS, plot_histograms,
                                                             plot_influence,
                                                             plot_success_vs_parameters)
    from bplir_drake.params import BplirParams
    from bplir_drake.params.robot import robot_label

    def study_of(names):
        return SimpleNamespace(names=names, seed=3, line=None, params=BplirParams())

    def rows_of(names, n=MIN_INFLUENCE_SAMPLES):
        rng = np.random.default_rng(0)
        return [dict({q: float(rng.normal()) for q in names}, index=k, outcome="captured",
                     success=True, capture_speed_mps=float(rng.uniform(0.1, 0.4)),
                     swing_time_s=1.3, peak_torque_Nm=10.0, peak_motor_power_W=100.0)
                for k in range(n)]
    names = [f"imu.q{k}" for k in range(25)]
    study, rows = study_of(names), rows_of(names)
    fig = plot_success_vs_parameters(study, rows)
    assert len(fig.axes) == 2 * MAX_PANELS   # each panel and its success band
    assert f"the {MAX_PANELS} of 25 drawn quantities most correlated" in fig.bplir_caption
    assert influence(study, rows[:MIN_INFLUENCE_SAMPLES - 1]) == {}
    sensed = ["true_friction.fv1", "line_sensor.bias"]
    assert set(influence(study_of(sensed), rows_of(sensed))) == {"true_friction.fv1"}
    counts = plot_histograms(study, rows).axes[0].get_yticks()
    assert np.all(counts == np.round(counts))
    few = plot_influence(study, rows[:4])
    assert "too few to rank" in few.axes[0].texts[0].get_text()
    other = dataclasses.replace(BplirParams().plant, l2=1.0)
    assert robot_label(BplirParams()) == "BPLIR"
    assert robot_label(BplirParams().with_(plant=other)) == "two-link robot"


def test_a_local_dask_cluster_beside_another_says_nothing_of_its_port():
    """With port 8787 taken (as by another cluster on the machine), a study's
    local Dask cluster runs and warns nothing: its scheduler has no
    dashboard and serves HTTP on a free port."""
    import math
    import socket
    import warnings

    pytest.importorskip("dask.distributed")
    from bplir_drake.analysis.montecarlo.executors import map_jobs

    taken = socket.socket()
    try:
        taken.bind(("", 8787))
        taken.listen()
    except OSError:   # another process holds it already
        pass
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            got = sorted(map_jobs(math.factorial, [(k,) for k in range(4)], workers=2,
                                  dask=True))
    finally:
        taken.close()
    assert got == [1, 1, 2, 6]
    assert [str(w.message) for w in caught if "8787" in str(w.message)] == []
