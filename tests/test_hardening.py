"""Bad input is one line and exit 2, finished work is never lost or
half-written, JSON is strict, and a plan depends only on what the
controller may know (issue 16).  CLI cases run the command line in a
process of its own (forked, :mod:`forked`) where the whole process matters
(signals, exit status, files left behind); the rest call
``bplir_drake.cli.main`` in-process."""
import math
import signal
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bplir_drake import cli
from bplir_drake.analysis import montecarlo as mc
from bplir_drake.analysis.identification.calibration import CalibrationError, read_calibration_csv
from bplir_drake.estimation import LogError, read_imu_csv, write_imu_csv
from bplir_drake.io import dumps_strict
from bplir_drake.planning.solve import SwingPlan
from bplir_drake.params import ParameterError, load_toml
from conftest import parse_strict_json as strict_json
from conftest import paced_48v, plugin_source
from forked import bplir_forked, start_forked
from bplir_drake.params import with_hardware
from moves import tried


def bplir_process(*argv, timeout=120):
    """Run the ``bplir`` command as its own process (forked from this one,
    :func:`forked.bplir_forked`); (exit status, stdout, stderr)."""
    return bplir_forked(*argv, timeout=timeout)


def bplir(*argv):
    """Run ``bplir`` in-process -- the main() the console script calls --
    capturing what it writes; (exit status, stdout, stderr).  The tests
    that need a process of their own (a signal, the console entry point)
    use :func:`bplir_process`."""
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = cli.main([str(a) for a in argv])
    return rc, out.getvalue(), err.getvalue()


def assert_one_line_error(rc, err, *words):
    assert rc == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("bplir: error: "), err
    assert "Traceback" not in err
    for w in words:
        assert w in lines[0], lines[0]


def _imu_log(path, extra=None):
    t = np.arange(150) * 0.01
    s = np.zeros((150, 6))
    s[:, 3] = s[:, 5] = 9.81
    return write_imu_csv(t, s, path, extra)


# ------------------------------------------------------------------ files in

def test_preset_and_config_combine(tmp_path):
    """The file's tables override the named preset."""
    f = tmp_path / "f.toml"
    f.write_text("[friction]\nfc2 = 0.9\n")
    rc, out, err = bplir("model", "--preset", "lab", "--config", f, "--json")
    assert rc == 0 and err == ""
    params = strict_json(out)["parameters"]
    assert params["preset"] == "lab" and params["friction"]["fc2"] == 0.9
    assert params["estimator"]["l1"] == 0.8 and params["controller"]["preset"] == "lab"


@pytest.mark.parametrize("content, words, subprocess_", [
    (b"\x00\x01\x02\xff binary", "binary file", True),
    ("[friction]\nfc2 = 0.9\n".encode("utf-16"), "UTF-16", False),
    (b"[friction]\nfc2 = 0.9 \xe9\n", "not UTF-8", False),
])
def test_binary_and_utf16_files_are_one_line_errors(tmp_path, content, words, subprocess_):
    """Binary and UTF-16 files are one-line errors for every file-reading command (--config, estimate, calibrate,
    montecarlo --study): through the console entry point for the binary
    file, in-process (the same main()) for the others."""
    f = tmp_path / "bad.dat"
    f.write_bytes(content)
    for argv in (["model", "--config", f], ["estimate", f], ["calibrate", f],
                 ["montecarlo", "--study", f, "--out", tmp_path / "mc"]):
        rc, _, err = (bplir_process if subprocess_ else bplir)(*argv)
        assert_one_line_error(rc, err, words, str(f))


def test_utf8_bom_is_accepted(tmp_path):
    f = tmp_path / "bom.toml"
    f.write_bytes(b"\xef\xbb\xbf[friction]\nfc2 = 0.9\n")
    assert load_toml(f).friction.fc2 == 0.9
    log = _imu_log(tmp_path / "imu.csv")
    log.write_bytes(b"\xef\xbb\xbf" + log.read_bytes())
    assert read_imu_csv(log).samples.shape == (150, 6)


def test_log_readers_name_the_problem(tmp_path):
    """Items 4 and 11: a ragged calibration row, an IMU log's extra text
    column (ignored, as the README says), a duplicated column."""
    cal = tmp_path / "cal.csv"
    cal.write_text("t,q1,q2,tau\n0,0,0,0\n0.01,0,0\n")
    rc, _, err = bplir("calibrate", cal, "--out", tmp_path / "c")
    assert_one_line_error(rc, err, "line 3 has 3 cells, the header has 4")
    cal.write_text("t,q1,q2,tau\n0,0,0,0,7\n")
    with pytest.raises(CalibrationError, match="line 2 has 5 cells"):
        read_calibration_csv(cal, 1.33)
    text = _imu_log(tmp_path / "imu.csv").read_text().splitlines()
    (tmp_path / "note.csv").write_text("\n".join([text[0] + ",note"]
                                                 + [r + ",hello" for r in text[1:]]) + "\n")
    log = read_imu_csv(tmp_path / "note.csv")
    assert log.samples.shape == (150, 6) and "note" not in log.extra
    (tmp_path / "dup.csv").write_text("\n".join([text[0] + ",t"] + [r + ",1" for r in text[1:]]))
    with pytest.raises(LogError, match="column 't' appears twice"):
        read_imu_csv(tmp_path / "dup.csv")


def test_true_plant_errors_name_their_table(tmp_path):
    f = tmp_path / "t.toml"
    f.write_text("[true_plant]\nm1 = -1\n")
    with pytest.raises(ParameterError, match=r"^true_plant\.m1 = -1"):
        load_toml(f)


# ------------------------------------------------------------------ options

@pytest.mark.parametrize("argv, words", [
    (["observability", "--duration", "-1"], "--duration = -1 s is out of range"),
    (["observability", "--threshold", "nan"], "--threshold = nan is out of range"),
    (["freeswing", "--torque", "nan"], "--torque = nan N m is out of range"),
    (["estimate", "LOG", "--r1", "5"], "estimator.r1 = 5 m exceeds estimator.l1"),
    (["estimate", "LOG", "--r1", "50"], "estimator.r1 = 50 is out of range; allowed (0, 10] m"),
    (["estimate", "LOG", "--calibrate", "-5"], "--calibrate = -5 s is out of range"),
    (["montecarlo", "-n", "1000000000000"], "--samples = 1000000000000 is out of range; allowed [1, 1000000]"),
    (["montecarlo", "-n", "2", "--workers", "0"], "--workers = 0 is out of range"),
    (["qft", "--plants", "0"], "--plants = 0 is out of range"),
    (["swing", "--path-mode", "planned"], "--path-mode = 'planned' is unknown; allowed: auto, "
     "adaptive, rts, lab, plan"),
    (["montecarlo", "-n", "2", "--path-mode", ""], "--path-mode = '' is unknown"),
])
def test_every_option_has_a_range(tmp_path, argv, words):
    """An option outside its range is one line naming the range, and nothing
    is written (no empty output directory either)."""
    log = _imu_log(tmp_path / "imu.csv")
    out = tmp_path / "o"
    argv = [str(log) if a == "LOG" else a for a in argv]
    if argv[0] != "estimate":
        argv += ["--out", str(out)]
    rc, _, err = bplir(*argv)
    assert_one_line_error(rc, err, words)
    assert not out.exists()


@pytest.mark.parametrize("controllers", [",", "foo", "plan,nope"])
def test_benchmark_controllers_checked_before_any_output(tmp_path, controllers):
    """Items 8 and 12: no empty output directory is left behind."""
    out = tmp_path / "bench"
    rc, _, err = bplir("benchmark", "--controllers", controllers, "--out", out)
    assert_one_line_error(rc, err, "--controllers")
    assert not out.exists()


def test_unusable_scheduler_address(tmp_path):
    """A scheduler address that is not one is a one-line error."""
    rc, _, err = bplir("montecarlo", "-n", "2", "--scheduler", "notanaddress",
                       "--out", tmp_path / "mc")
    assert_one_line_error(rc, err, "cannot reach the Dask scheduler at notanaddress")


# ------------------------------------------------------------------ files out

def test_unusable_output_locations(tmp_path):
    """Output locations that cannot be used are refused: an existing file, a pseudo filesystem, a missing directory."""
    afile = tmp_path / "afile"
    afile.write_text("keep me")
    rc, _, err = bplir("freeswing", "--out", afile)
    assert_one_line_error(rc, err, "is an existing file")
    assert afile.read_text() == "keep me"
    rc, _, err = bplir("freeswing", "--out", "/proc/x")
    assert_one_line_error(rc, err, "cannot write to output directory /proc/x")
    log = _imu_log(tmp_path / "imu.csv")
    for opt in ("--out", "--plot"):
        rc, _, err = bplir("estimate", log, opt, tmp_path / "missing" / "f.png")
        assert_one_line_error(rc, err, "does not exist")
    if Path("/sys/kernel").is_dir():  # sysfs: no regular files can be created there
        rc, _, err = bplir("swing", "--out", "/sys/kernel")
        assert_one_line_error(rc, err, "cannot write to output directory /sys/kernel")


def test_swing_checks_its_output_before_simulating(monkeypatch, tmp_path):
    import bplir_drake.analysis.swing.swing_runner as S

    def boom(*a, **k):
        raise AssertionError("simulated before checking the output directory")

    monkeypatch.setattr(S, "run_swing", boom)
    afile = tmp_path / "f"
    afile.write_text("")
    rc, _, err = bplir("swing", "--out", afile)
    assert rc == 2 and "is an existing file" in err


def test_interrupted_render_leaves_no_truncated_file(monkeypatch, tmp_path):
    """Ctrl-C while the animation is written: the earlier complete
    outputs stay, no partial or temporary file is left, and the message says
    only that."""
    from PIL import Image

    out = tmp_path / "swing"
    assert bplir("swing", "--no-plots", "--out", out, "--json")[0] == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    real_save = Image.Image.save

    def interrupted(self, fp, *a, **k):
        if k.get("save_all"):  # the animation, not the PNG figure
            Path(fp).write_bytes(b"GIF89a partial")
            raise KeyboardInterrupt
        return real_save(self, fp, *a, **k)

    monkeypatch.setattr(Image.Image, "save", interrupted)
    rc, _, err = bplir("swing", "--no-plots", "--out", out, "--seed", "3")
    assert rc == 130
    assert err.strip() == "bplir: interrupted; no output file was left half-written"
    after = {p.name: p.read_bytes() for p in out.iterdir()}
    assert set(after) <= set(before) and after["swing.gif"] == before["swing.gif"]
    assert all(not n.startswith(".") for n in after)


def test_smaller_n_keeps_finished_rows_and_reports_the_first_n(tmp_path):
    """A rerun asking for fewer samples keeps the finished rows and reports
    the first N."""
    out = tmp_path / "mc"
    args = ("--out", out, "--workers", "1", "--no-plots", "--json")
    assert bplir("montecarlo", "-n", "4", *args)[0] == 0
    table = (out / "results.csv").read_bytes()
    rc, stdout, _ = bplir("montecarlo", "-n", "2", *args)
    assert rc == 0
    summary = strict_json(stdout)
    assert summary["samples"] == 2 and summary["run"]["computed_now"] == 0
    assert (out / "results.csv").read_bytes() == table   # nothing deleted


def test_results_table_rewrite_is_atomic(monkeypatch, tmp_path):
    """A failure while the table is rewritten leaves the old one."""
    study = mc.Study(samples=3, seed=0)
    path = tmp_path / "results.csv"
    rows = [{"index": k, "seed": k, "outcome": "captured", "success": True, "error": ""}
            for k in range(3)]
    mc.ResultWriter(path, mc.columns(study), rows).close()
    good = path.read_bytes()
    from bplir_drake.analysis.montecarlo import store

    real = store._fmt
    calls = {"n": 0}

    def failing(v):
        calls["n"] += 1
        if calls["n"] > 5:
            raise KeyboardInterrupt
        return real(v)

    monkeypatch.setattr(store, "_fmt", failing)
    with pytest.raises(KeyboardInterrupt):
        mc.ResultWriter(path, mc.columns(study), rows)
    assert path.read_bytes() == good
    assert [p.name for p in tmp_path.iterdir()] == ["results.csv"]


def test_killed_study_resumes_to_the_identical_table(tmp_path):
    """A real interruption: SIGKILL after the first rows, rerun, and the
    table is byte-identical to an uninterrupted run's (that one in-process:
    the same main())."""
    args = ["montecarlo", "-n", "5", "--seed", "3", "--workers", "1", "--no-plots", "--json"]
    full = tmp_path / "full"
    assert bplir(*args, "--out", full)[0] == 0
    cut = tmp_path / "cut"
    proc = start_forked(*args, "--out", cut, stdout=False, stderr=False)
    results = cut / "results.csv"
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline and proc.poll() is None:
        if results.exists() and len(results.read_text().splitlines()) >= 3:  # header + 2 rows
            break
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    n_rows = len(results.read_text().splitlines()) - 1
    assert 2 <= n_rows < 5
    rc, out, _ = bplir(*args, "--out", cut)
    assert rc == 0 and strict_json(out)["run"]["resumed_from"] >= 2
    assert results.read_bytes() == (full / "results.csv").read_bytes()


def _wait_for_rows(proc, results: Path, rows: int, timeout: float = 240.0) -> None:
    """Wait until the study run by ``proc`` has written ``rows`` finished rows
    to ``results`` (or it ended, or ``timeout`` s passed)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and proc.poll() is None:
        if results.exists() and len(results.read_text().splitlines()) > rows:   # + header
            return
        time.sleep(0.02)


@pytest.mark.slow
def test_ctrl_c_on_a_two_worker_study_keeps_finished_rows(tmp_path):
    """Ctrl-C (SIGINT to the whole process group, as a terminal
    sends it) on a 2-worker study ends it (exit 130, one line: no worker
    prints), keeps every finished row; the same command then resumes."""
    import os

    out = tmp_path / "mc"
    args = ["montecarlo", "-n", "14", "--workers", "2", "--no-plots", "--out", str(out)]
    # a suite started in the background by a shell inherits SIGINT ignored
    # (Python then installs no KeyboardInterrupt handler): Ctrl-C as a user
    # at a terminal sends it, with the default disposition
    proc = start_forked(*args, stdout=False, new_session=True)
    results = out / "results.csv"
    _wait_for_rows(proc, results, 5)
    os.killpg(proc.pid, signal.SIGINT)
    err = proc.communicate(timeout=120)[1]
    assert proc.returncode == 130
    assert err.strip().splitlines() == [
        f"bplir: interrupted; the finished samples are kept in {out} (the same command "
        "resumes the study)"]
    kept = mc.read_results(results)
    assert len(kept) >= 5
    rc, _, _ = bplir(*args[:-2], "--out", out, "--json")
    assert rc == 0 and len(mc.read_results(results)) == 14
    assert {r["index"]: r for r in mc.read_results(results)}[kept[0]["index"]] == kept[0]


# ------------------------------------------------------------------ JSON

def test_strict_json_replaces_nan_and_infinity():
    text = dumps_strict({"a": math.nan, "b": [math.inf, -math.inf, 1.5],
                         "c": np.float64("nan"), "d": np.array([1.0, np.inf])})
    assert strict_json(text) == {"a": None, "b": [None, None, 1.5], "c": None, "d": [1.0, None]}


@pytest.mark.slow
def test_every_json_output_is_strict(tmp_path):
    """The commands' --json output and their JSON files parse with a
    parser that rejects NaN and Infinity (a timed-out swing has no capture
    speed: null).  In-process: the same main() the console script runs.
    ``benchmark`` and ``qft`` are checked the same way where their own
    tests run them (test_plugin: a benchmark whose controller never
    captures; test_cli_qft)."""
    log = _imu_log(tmp_path / "imu.csv")
    runs = [("model",), ("freeswing", "--duration", "1", "--out", tmp_path / "fs"),
            ("estimate", log),
            ("observability", "--duration", "1", "--out", tmp_path / "ob"),
            ("swing", "--incline", "20", "--controller", "cpfl-qft", "--no-animation",
             "--no-plots", "--out", tmp_path / "sw"),
            ("montecarlo", "-n", "2", "--workers", "1", "--no-plots", "--out", tmp_path / "mc")]
    for argv in runs:
        rc, out, _ = bplir(*argv, "--json")
        assert rc == 0
        data = strict_json(out)
        if argv[0] == "swing":
            assert data["outcome"] == "timeout" and data["capture_speed_mps"] is None
    files = list(tmp_path.rglob("*.json"))
    assert len(files) == 4   # freeswing, observability, swing, montecarlo
    for f in files:
        strict_json(f.read_text())


# ------------------------------------------------------------------ plans

def test_plan_depends_only_on_the_nominal_model_and_a_hit_is_bit_identical(tmp_path,
                                                                             monkeypatch):
    """The plan's inputs (its cache key) are the nominal model and
    the scenario; the simulated robot never enters; a cache hit equals a
    fresh solve bit for bit."""
    import dataclasses as dc

    from bplir_drake.planning import cache as plan_cache
    from bplir_drake.planning.solve import plan_swing
    from bplir_drake.params import preset

    monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path))
    seen = []
    real_cached = plan_cache.cached
    from bplir_drake.planning import solve as P

    def spy(inputs, solve, **kw):
        seen.append(plan_cache.plan_key(inputs))
        return real_cached(inputs, solve, **kw)

    monkeypatch.setattr(P, "cached", spy)
    p = preset()
    kw = dict(knots=7, iterations=40)
    fresh = plan_swing(p, cache=False, **kw)
    first = plan_swing(p, **kw)                     # solved and stored
    other_robot = p.with_(true_plant=dc.replace(p.plant, l2=1.3, m2=1.7))
    hit = plan_swing(other_robot, **kw)             # the same key: read back
    assert seen[0] == seen[1] and len(list(tmp_path.glob("plan-*.npz"))) == 1
    for a, b in ((fresh, first), (first, hit)):
        for f in ("times", "states", "torque", "friction"):
            assert np.array_equal(getattr(a, f), getattr(b, f))
    np.testing.assert_array_equal(hit.states[0, :2], plan_swing(p, **kw).states[0, :2])
    plan_swing(p.with_(plant=dc.replace(p.plant, m2=1.6)), **kw)   # the nominal model: new key
    finer = plan_swing(p, **kw | {"knots": 8})                      # a solver input: new key
    assert len(set(seen)) == 3
    warm = plan_swing(p, initial=first, **kw)       # started from a plan: the guess is an input
    assert len(set(seen)) == 4
    again = plan_swing(p, initial=first, **kw)      # a hit, bit for bit
    assert seen[-1] == seen[-2] and np.array_equal(warm.states, again.states)
    plan_swing(p, initial=finer, **kw)              # another initial plan: new key
    assert len(set(seen)) == 5



def test_tracking_gains_cache_hit_is_bit_identical_and_keyed_by_every_input(tmp_path,
                                                                           monkeypatch):
    """The plan's LQR gains are cached on disk under the nominal model, the
    weights and the plan's samples; a hit (another process: the in-memory
    copy cleared) evaluates exactly like a fresh LQR solve, and a change in
    any input is a new key."""
    import dataclasses as dc

    from bplir_drake.planning import solve as P
    from bplir_drake.planning import cache as plan_cache
    from bplir_drake.params import preset

    monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(P, "_GAINS", {})
    p = preset()
    plan = P.plan_swing(p, knots=7, iterations=40)
    fresh = P.tracking_gains(p.plant, p.friction, plan)   # solved and stored
    P._GAINS.clear()
    solves = []
    monkeypatch.setattr(P, "plan_gains", lambda *a, **k: solves.append(a))
    hit = P.tracking_gains(p.plant, p.friction, plan)     # read back, not solved
    assert not solves and len(list(tmp_path.glob("gains-*.npz"))) == 1
    for name in plan_cache.GAIN_FIELDS:
        a, b = getattr(fresh, name), getattr(hit, name)
        assert a.get_number_of_segments() == b.get_number_of_segments() > 1
        for t in np.linspace(a.start_time(), a.end_time(), 997):
            assert np.array_equal(a.value(t), b.value(t)), name
    key = lambda *a: plan_cache.plan_key(P.gains_inputs(*a))   # noqa: E731
    base = key(p.plant, p.friction, plan)
    moved = dc.replace(plan, states=plan.states + np.r_[0.0, 0.0, 0.0, 1e-12])
    assert len({base, key(dc.replace(p.plant, m2=1.6), p.friction, plan),
                key(p.plant, dc.replace(p.friction, fc2=0.5), plan),
                key(p.plant, p.friction, moved)}) == 4


# ------------------------------------------------------------------ fuzz

_TOML_PIECES = ["[friction]\n", "fc2 = 0.9\n", "[plant]\n", "m1 = -3\n", "preset = 'lab'\n",
                "[scenario]\nseed = 1.5\n", "x = [1, 2\n", "[true_plant]\nl2 = 0\n",
                "samples = 0\n", "[uncertain.\"true_friction.fc2\"]\ndist = 'uniform'\n",
                "rel = 0.2\n", "[uncertain.x]\n", "abs = -1\n", "\u00e9 = 1\n", "= 3\n"]
_CSV_PIECES = ["t,gyro1,gyro2,acc1_x,acc1_y,acc2_x,acc2_y\n", "t,q1,q2,tau\n", "0,0,0,0,9.8,0,9.8\n",
               "0.01,1,2,3\n", "nan,1,1,1,1,1,1\n", "a,b\n", "\n", "0.02,,,,,,\n", ",,,\n",
               "\"unterminated\n", "1e999,0,0,0\n", "0,0,0,0,0,0,0,0\n"]


def _readers(path):
    from bplir_drake.params import load_toml as read_params

    return [(read_params, ParameterError), (mc.load_study, ParameterError),
            (read_imu_csv, LogError),
            (lambda p: read_calibration_csv(p, 1.33), CalibrationError)]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.one_of(st.binary(max_size=300),
                      st.lists(st.sampled_from(_TOML_PIECES + _CSV_PIECES), max_size=12)
                      .map(lambda xs: "".join(xs).encode()),
                      st.lists(st.sampled_from(_CSV_PIECES), min_size=1, max_size=40)
                      .map(lambda xs: "".join(xs).encode())))
def test_file_readers_return_a_result_or_a_one_line_error(tmp_path, data):
    path = tmp_path / "fuzz.dat"
    path.write_bytes(data)
    for reader, error in _readers(path):
        try:
            reader(path)
        except error as exc:
            assert "\n" not in str(exc) and str(exc)


def _quick_benchmark_swings():
    """The swings of ``bplir benchmark --quick`` that need plans of their own
    (the +-10 deg lines and the 1.1 and 1.3 m grip spacings) and of
    ``examples/custom_params.py`` (1.15 m)."""
    import dataclasses as dc

    from bplir_drake.params import preset

    p = preset()
    return ([p.with_(scenario=dc.replace(p.scenario, incline_deg=a)) for a in (-10.0, 10.0)]
            + [p.with_(scenario=dc.replace(p.scenario, grip_spacing=d)) for d in (1.1, 1.15, 1.3)])


def test_shipped_plans_serve_a_fresh_install(monkeypatch, tmp_path):
    """The plans the examples and tests use ship with the package under
    their cache keys: with an empty cache they are read, never solved."""
    import dataclasses as dc

    from bplir_drake.planning import solve as P
    from bplir_drake.planning import cache as plan_cache
    from bplir_drake.params import load_toml

    shipped = sorted(plan_cache.PACKAGED.glob("plan-*.npz"))
    # +-20 deg (the quick start), 0 deg (the default, the landing's tests), 20 deg resting
    # on the line, the lines' 8, the quick benchmark's +-10 deg and 1.1 / 1.3 m swings,
    # custom_params.py's 1.15 m (at 1.1, 1.15 and 1.3 m also the solve started from the
    # 1.2 m plan, plan.warm_spacing), the 1.27 m plans of the warm start's test and
    # the default swing with a 1.6 kg link 2 (the documented --set plant.m2=1.6) and the
    # flat-line swings tried again from hanging (the traversal's recovery, both robots,
    # the swapped robot's planned to end at the line; some guesses too, which SNOPT
    # does not solve), the 48 V swapped robot's on the span's +2.6 deg chord planned
    # by guesses within 85 % of the torque limit and 35 % of the i^2 t budget, ending
    # at the line (its first three guesses: the first heats the driver too much, the
    # second is infeasible) and 13 mm below it (test_traverse_recovery's: its four
    # guesses, the first heats the driver too much, the next two are infeasible), the
    # 48 V original robot's so planned on a level line (the apex shot's test), and
    # examples/acromonk.toml's swing (its guesses and warm start) and `bplir plan`, and
    # the original robot's try from hanging at +2.6 deg, 1.05 m (test_hanging_library's),
    # and the scaled robot's plans commissioned from the default robot's, holding with
    # either gripper, from the line and from hanging (docs/commission.md)
    assert len(shipped) == 47
    monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path))

    def no_solve(*a, **k):
        raise AssertionError("solved a plan the package ships")

    monkeypatch.setattr(P, "_solve_plan", no_solve)
    p = load_toml(Path(__file__).resolve().parents[1] / "examples" / "uphill_plan.toml")
    p = p.with_(scenario=dc.replace(p.scenario, incline_deg=20.0))
    for incline, depth in ((20.0, 0.0), (20.0, p.plan.end_depth),   # test_swing_plan's,
                           (-20.0, p.plan.end_depth),               # the quick start's
                           (0.0, p.plan.end_depth)):                # test_reach's
        q = p.with_(scenario=dc.replace(p.scenario, incline_deg=incline))
        plan = P.plan_swing(q, end_depth=depth)
        assert plan.feasible and plan.incline_deg == incline
    for q in _quick_benchmark_swings():
        assert P.tracking_plan(q)[0].feasible
    # every swing of the example lines (both robots, their inclines)
    from bplir_drake.analysis.traverse.line import load_line
    from bplir_drake.analysis.traverse.route import plan_route
    from moves import traverse_swing
    from bplir_drake.params import preset

    q = preset().with_(scenario=dc.replace(preset().scenario, grip_spacing=1.27),
                       plan=dc.replace(preset().plan, library=False))
    assert P.scenario_plan(q).feasible   # test_plan_tracking's warm start: three solves
    base, seen = preset(), set()
    for name in ("line_flat.toml", "line_span.toml"):
        line = load_line(Path(__file__).resolve().parents[1] / "examples" / name)
        for r in plan_route(line, base):
            for g, (a, b) in ((1, (r.rear, r.landing1)), (2, (r.hold, r.landing2))):
                sp = traverse_swing(base, g, base.traverse.grip_spacing, line.chord(a, b)[1])
                plan = P.scenario_plan(sp)    # as the traversal finds it
                assert plan.feasible and plan.peak_voltage <= base.motor.max_voltage
                seen.add((g, plan.incline_deg))
    assert len(seen) == 8
    volt48 = paced_48v(base)   # tries planned by guesses (test_traverse_recovery's)
    assert P.scenario_plan(tried(volt48, 2, 1.2, math.radians(2.6))).feasible
    deeper = tried(volt48, 2, 1.2, math.radians(2.6), end_at_line=False)
    assert P.scenario_plan(deeper).duration > 4.5   # the fourth guess's
    assert P.scenario_plan(tried(volt48, 1, 1.2, 0.0)).feasible
    acromonk = load_toml(Path(__file__).resolve().parents[1] / "examples" / "acromonk.toml")
    assert P.scenario_plan(acromonk).feasible
    assert P.plan_swing(acromonk, knots=41).status == "iteration limit"   # `bplir plan`'s
    assert not list(tmp_path.glob("plan-*.npz"))     # read in place, not copied


def test_shipped_gains_serve_the_tests_plans(monkeypatch, tmp_path):
    """The LQR gains of the plans the tests and the quick start track ship
    too (the +-20 deg swings of examples/uphill_plan.toml, the 1.6 kg link 2,
    the 48 V robots' tries from hanging planned by guesses, on a level line
    and on the span's +2.6 deg chord; the default robot's other swings, its
    tries from hanging included at 30 V and 48 V, blend theirs from the plan
    libraries): with an empty cache they are read, never solved, and every
    shipped gains file belongs to a plan the tests track."""
    import dataclasses as dc

    from bplir_drake.planning import solve as P
    from bplir_drake.planning import cache as plan_cache
    from moves import traverse_swing
    from bplir_drake.params import from_dict, load_toml, preset

    monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(P, "_GAINS", {})

    def no_solve(*a, **k):
        raise AssertionError("solved gains the package ships")

    monkeypatch.setattr(P, "plan_gains", no_solve)
    up = load_toml(Path(__file__).resolve().parents[1] / "examples" / "uphill_plan.toml")
    up = up.with_(scenario=dc.replace(up.scenario, incline_deg=20.0))
    base = preset()
    down = up.with_(scenario=dc.replace(up.scenario, incline_deg=-20.0))
    flat = base.with_(path=dc.replace(base.path, mode="plan"))
    heavy = from_dict({"plant": {"m2": 1.6}}, base=base)   # --set plant.m2=1.6
    cases = [up, down, flat, heavy] + [traverse_swing(base, g, base.traverse.grip_spacing, 0.0)
                                       for g in (1, 2)] + _quick_benchmark_swings()
    cases += [tried(base, g, base.traverse.grip_spacing, 0.0) for g in (1, 2)]   # tried again
    cases += [tried(with_hardware(base, "48v"), g, 1.2, 0.0)
              for g in (1, 2)]   # at 48 V the 30 V robot's tries (its libraries)
    b48 = paced_48v(base)   # tries planned by guesses (test_traverse_recovery's)
    cases += [tried(b48, 2, 1.2, math.radians(2.6), end_at_line=at)
              for at in (True, False)]   # the span's chord, ending at the line and below
    cases.append(tried(b48, 1, 1.2, 0.0))   # the apex shot's test
    cases.append(load_toml(Path(__file__).resolve().parents[1] / "examples" / "acromonk.toml"))
    keys, blended = set(), 0
    for p in cases:
        plan, gains = P.tracking_plan(p)
        assert gains.K.get_number_of_segments() > 100
        if plan.status == "interpolated":   # the plan library's: no file
            blended += 1
            continue
        keys.add(plan_cache.plan_key(P.gains_inputs(p.plant, p.friction, plan,
                                                    P.TrackerWeights.of(p.plan))))
    assert blended == 14   # +-20 deg, the flat swing, both robots on the flat line (from the
    #                        line and tried again from hanging at 30 V and 48 V), the quick five
    from bplir_drake.analysis.commission.grid import solve_point   # docs/commission.md's robot
    from bplir_drake.params import swapped
    scaled = load_toml(Path(__file__).resolve().parents[1] / "examples" / "scaled_bplir.toml")
    tries = [tried(scaled, g, 0.84, 0.0) for g in (1, 2)]
    for robot in (scaled, swapped(scaled), *tries):   # either gripper, from the line, hanging
        point = solve_point(robot, 0.0, 0.84)
        keys.add(plan_cache.plan_key(P.gains_inputs(robot.plant, robot.friction, point.plan,
                                                    P.TrackerWeights.of(robot.plan))))
    shipped = {f.stem.split("-", 1)[1] for f in plan_cache.PACKAGED.glob("gains-*.npz")}
    assert shipped == keys and not list(tmp_path.glob("gains-*.npz"))


def test_a_fault_inside_is_one_line_and_debug_shows_the_traceback(tmp_path, capsys):
    """A plug-in whose output raises mid-swing: one line ``bplir: error:``
    naming the command and the fault, exit 1, no traceback; with
    ``--debug`` the exception itself."""
    from bplir_drake.cli import main

    plugin = tmp_path / "broken.py"
    plugin.write_text(plugin_source("raise RuntimeError('the controller lost its mind')"))
    argv = ["swing", "--controller", f"{plugin}:make", "--no-animation", "--out",
            str(tmp_path / "out")]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("bplir: error: swing failed:")
    assert "the controller lost its mind" in err and "Traceback" not in err
    with pytest.raises(RuntimeError, match="lost its mind"):
        main(["--debug", *argv])


def _tiny_plan():
    from bplir_drake.planning.solve import SwingPlan

    t = np.linspace(0.0, 1.0, 5)
    return SwingPlan(t, np.zeros((5, 4)), np.zeros(5), np.zeros((5, 2)), True, True, "test",
                     0.0, 20.0, 220.0, 1e-4)


@pytest.mark.parametrize("damage", [b"", b"PK\x03\x04 truncated", b"not a zip file at all"])
def test_a_damaged_cached_plan_is_moved_aside_and_solved_again(monkeypatch, tmp_path, damage):
    """An empty, truncated or foreign ``plan-<key>.npz`` in the cache does not
    stop the robot: it is moved aside (``.damaged``), with a warning naming
    it, the plan solved again and stored."""
    from bplir_drake.planning import cache as plan_cache

    monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path))
    inputs = {"test": "damaged", "damage": damage.decode(errors="replace")}
    path = plan_cache.plan_cache_path(inputs)
    path.write_bytes(damage)
    solves = []
    with pytest.warns(UserWarning, match=f"the cached plan file {path} is damaged"):
        plan = plan_cache.cached(inputs, lambda: solves.append(1) or _tiny_plan(), make=SwingPlan)
    assert solves == [1] and plan.solver == "test"
    assert path.with_suffix(".damaged").read_bytes() == damage
    again = plan_cache.cached(inputs, lambda: solves.append(2) or _tiny_plan(), make=SwingPlan)
    assert solves == [1] and np.array_equal(again.times, plan.times)   # stored, read back


def test_the_shipped_plans_serve_whatever_state_the_cache_is_in(monkeypatch, tmp_path):
    """With ``BPLIR_CACHE_DIR`` unusable (inside /proc, or read-only) the
    shipped plans and gains are still read, never solved; a link planted at
    a lock file is neither followed nor truncated."""
    import os

    from bplir_drake.planning import solve as P
    from bplir_drake.planning import cache as plan_cache
    from bplir_drake.params import preset

    def no_solve(*a, **k):
        raise AssertionError("solved a shipped plan")

    monkeypatch.setattr(P, "_solve_plan", no_solve)
    monkeypatch.setattr(P, "plan_gains", no_solve)
    monkeypatch.setattr(P, "_GAINS", {})
    readonly = tmp_path / "ro"
    readonly.mkdir()
    readonly.chmod(0o500)
    for where in ("/proc/bplir-no-such/cache", str(readonly)):
        monkeypatch.setenv("BPLIR_CACHE_DIR", where)
        plan, gains = P.tracking_plan(preset())
        assert plan.feasible and gains.K.get_number_of_segments() > 100
    monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path / "cache"))
    (tmp_path / "cache").mkdir()
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    inputs = {"test": "link"}
    os.symlink(victim, plan_cache.plan_cache_path(inputs).with_suffix(".lock"))
    plan = plan_cache.cached(inputs, _tiny_plan, make=SwingPlan)
    assert plan.solver == "test" and victim.read_text() == "keep me"


@pytest.mark.parametrize("argv, words", [
    (["swing", "--out", ""], "--out '' is empty"),
    (["freeswing", "--q0", "1e300,0", "--duration", "1"], "--q0 Q1 = 1e+300 rad is out of range"),
    (["calibrate", "nolog.csv", "--fit", "fv1,fv1"], "--fit names fv1 more than once"),
])
def test_implausible_options_are_refused_before_any_work(argv, words, tmp_path, capsys,
                                                         monkeypatch):
    """An empty output directory, an angle of 1e300 rad, a parameter fitted
    twice: one line, exit 2, nothing written."""
    from bplir_drake.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("bplir: error:") and words in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("change, words", [
    (lambda t, x: t.__setitem__(slice(50, None), t[50:] + 1e6), "time jumps by 1e+06 s at row 51"),
    (lambda t, x: x.__setitem__((20, 0), 1e300), "row 21 column gyro1: 1e+300 is not a plausible"),
    (lambda t, x: x.__setitem__((30, 3), -5e3), "row 31 column acc1_y: -5000 is not a plausible"),
])
def test_an_imu_log_with_a_time_jump_or_wild_readings_is_refused(change, words):
    """A 1e6 s jump in the time column, or a reading beyond any IMU's range,
    is a one-line LogError naming the row (not filtered as if it were
    data)."""
    from bplir_drake.estimation import LogError, check_log

    t = np.arange(100) * 0.01
    x = np.tile([0.0, 0.0, 0.0, 9.81, 0.0, 9.81], (100, 1))
    check_log(t, x, 0.01)
    change(t, x)
    with pytest.raises(LogError, match=words.replace("+", r"\+")):
        check_log(t, x, 0.01)


@pytest.mark.parametrize("span, sag", [(60.0, 1e-9), (2000.0, 1e-6)])
def test_a_catenary_too_flat_to_be_a_conductor_is_refused(span, sag):
    """A catenary whose sag is under 1e-4 of its span (no conductor is that
    taut; a straight line is given by incline points) is a one-line
    LineError naming the allowed range, not a solver's traceback."""
    from bplir_drake.analysis.traverse.line import LineError, line_from_dict

    data = {"length": 10.0, "start": 1.2, "catenary": {"span": span, "sag": sag}}
    with pytest.raises(LineError, match=r"sag = .* is out of range; allowed \["):
        line_from_dict(data)
    data["catenary"]["sag"] = span * 2e-4   # the flattest allowed still solves
    assert line_from_dict(data).length == 10.0


@pytest.mark.parametrize("source, words", [
    ("import sys\nsys.exit(3)\ndef make(p):\n    return None\n", "cannot load"),
    ("import sys\ndef make(p):\n    sys.exit(0)\n", "the factory raised SystemExit"),
])
def test_a_plugin_that_exits_is_one_line_naming_it(source, words, tmp_path, capsys):
    """A plug-in module that calls ``sys.exit`` at import, or a factory that
    does, cannot end the command silently: one line naming the plug-in,
    exit 2."""
    from bplir_drake.cli import main

    plugin = tmp_path / "exits.py"
    plugin.write_text(source)
    assert main(["swing", "--controller", f"{plugin}:make", "--no-animation",
                 "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "controller plugin" in err and words in err


def test_a_chatty_plugin_leaves_json_output_json(tmp_path, capsys):
    """A plug-in that prints while it flies: with ``--json`` its text goes to
    standard error and standard output is still one JSON document."""
    import json

    from bplir_drake.cli import main

    plugin = tmp_path / "chatty.py"
    plugin.write_text(
        "import importlib.util, pathlib\n"
        "spec = importlib.util.spec_from_file_location('ex', pathlib.Path("
        f"{str(Path(__file__).resolve().parents[1] / 'examples' / 'my_controller.py')!r}))\n"
        "ex = importlib.util.module_from_spec(spec); spec.loader.exec_module(ex)\n"
        "def make(p):\n"
        "    print('hello from the plug-in')\n"
        "    return ex.make(p)\n")
    assert main(["swing", "--controller", f"{plugin}:make", "--no-animation", "--no-plots",
                 "--json", "--out", str(tmp_path / "out")]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["controller"] == "chatty:make"
    assert "hello from the plug-in" in captured.err


def _slow_renames(out):
    """In the child: the first atomic write's rename onto an output in
    ``out`` waits up to 30 s first, in short sleeps (a signal another
    thread takes is handled between them), so a signal sent while its
    temporary file exists finds the command inside the write (writes
    elsewhere, a cache's, go at once)."""
    import os

    replace, first = os.replace, []

    def slow(src, dst, *a, **k):
        if Path(src).name.startswith(".") and Path(src).parent == out and not first:
            first.append(src)
            end = time.monotonic() + 30.0
            while time.monotonic() < end:
                time.sleep(0.05)
        return replace(src, dst, *a, **k)

    return lambda: setattr(os, "replace", slow)


@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, 143), (signal.SIGHUP, 129)])
def test_sigterm_and_sighup_end_a_swing_like_ctrl_c(sig, code, tmp_path):
    """SIGTERM and SIGHUP while ``bplir swing`` writes an output (its
    temporary file made, not yet renamed): one line naming the signal,
    exit 128 + signal, no temporary file left."""
    out = tmp_path / "swing"
    proc = start_forked("swing", "--html", "--out", out, before=_slow_renames(out))
    deadline = time.time() + 60
    while time.time() < deadline and not (
            out.exists() and any(p.name.startswith(".") for p in out.iterdir())):
        time.sleep(0.05)
    assert proc.poll() is None, "the swing ended before writing its first output"
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == code
    assert err.strip() == (f"bplir: terminated by {signal.Signals(sig).name}; no output file "
                           "was left half-written")
    assert not [p for p in out.iterdir() if p.name.startswith(".")]


def test_a_write_ended_before_its_with_block_leaves_no_temporary_file(tmp_path, monkeypatch):
    """A signal between an atomic write's temporary file and its ``with``
    block skips the write's own clean-up; the command line's clean-up
    removes the file, and a finished write is not touched."""
    from bplir_drake import io
    from bplir_drake.cli import main

    done = tmp_path / "done.txt"
    io.write_text_atomic(done, "finished\n")
    cut = io.atomic_path(tmp_path / "cut.png")
    tmp = cut.__enter__()          # made, then ended before the with-block ran
    assert tmp.exists() and tmp.name.startswith(".cut-")

    def interrupted(args):
        raise KeyboardInterrupt
    monkeypatch.setattr(sys.modules["bplir_drake.cli.main"], "build_parser",
                        lambda: _OneCommand(interrupted))
    assert main(["swing"]) == 130
    assert sorted(p.name for p in tmp_path.iterdir()) == ["done.txt"]
    assert done.read_text() == "finished\n"


def test_a_signal_handled_while_the_temporary_file_is_made_waits_for_its_name(tmp_path,
                                                                              monkeypatch):
    """Python runs a signal's handler in the main thread even while that
    thread blocks the signal (another thread took it): a SIGTERM handled
    inside ``mkstemp`` is held until the file has a name, then ends the
    write and removes the file."""
    import tempfile

    from bplir_drake import io
    from bplir_drake.cli.common import Terminated, _terminate

    real = tempfile.mkstemp

    def mkstemp_then_signal(**kw):
        made = real(**kw)
        _terminate(signal.SIGTERM, None)     # the handler, mid-way through mkstemp
        return made
    monkeypatch.setattr(tempfile, "mkstemp", mkstemp_then_signal)
    with pytest.raises(Terminated):
        with io.atomic_path(tmp_path / "swing.png") as tmp:
            tmp.write_text("never finished")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(Terminated):          # outside a write it ends the command at once
        _terminate(signal.SIGTERM, None)
    io.forget_stop()                         # the command has ended


class _OneCommand:
    """A parser whose one command is ``func``."""

    def __init__(self, func):
        self.func = func

    def parse_args(self, argv):
        import argparse
        return argparse.Namespace(func=self.func, command=argv[0], debug=False, json=False)


def test_kill_9_of_a_study_leaves_no_worker_running(tmp_path):
    """``kill -9`` of a 2-worker study's parent: its pool workers die with it
    (none is left orphaned under PID 1)."""
    import os

    out = tmp_path / "mc"
    proc = start_forked("montecarlo", "-n", "40", "--workers", "2", "--no-plots", "--out", out,
                        stdout=False, stderr=False)
    _wait_for_rows(proc, out / "results.csv", 2)

    def children(pid):
        kids = []
        for entry in Path("/proc").iterdir():
            if entry.name.isdigit():
                try:
                    fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
                except OSError:
                    continue
                if int(fields[1]) == pid:
                    kids.append(int(entry.name))
        return kids

    workers = children(proc.pid)
    assert len(workers) >= 2
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)
    def running(pid):
        try:   # gone, or a zombie waiting for its (dead) parent's reaper
            return (Path(f"/proc/{pid}") / "stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
        except OSError:
            return False

    deadline = time.monotonic() + 20
    alive = workers
    while alive and time.monotonic() < deadline:
        time.sleep(0.1)
        alive = [w for w in workers if running(w)]
    assert alive == []


@pytest.mark.slow
def test_a_second_study_into_the_same_directory_is_refused_with_the_holders_pid(tmp_path):
    """Two ``bplir montecarlo`` runs into one directory: while the first
    runs the second is one line naming the first's PID (exit 2), and the
    first finishes with every row."""
    from bplir_drake.analysis import montecarlo as mc

    out = tmp_path / "mc"
    n = 20   # about 1.5 s of swings after the lock is taken: the second starts and
    #          reads the lock within a fraction of that (it imports no simulator)
    args = ["montecarlo", "-n", n, "--workers", "1", "--no-plots", "--out", out]
    first = start_forked(*args, stdout=False)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not (out / ".lock").exists():
        time.sleep(0.02)
    second = bplir_process(*args)
    assert first.wait(timeout=240) == 0
    assert second[0] == 2
    assert second[2].strip() == (f"bplir: error: study directory {out} is in use by "
                                     f"process {first.pid}; wait for it to finish or choose "
                                     "another output directory (--out)")
    rows = mc.read_results(out / "results.csv")
    assert sorted(r["index"] for r in rows) == list(range(n))
    assert (out / ".lock").read_text() == ""   # released and emptied, kept as a file


def test_a_resumed_study_keeps_a_repeated_row_once_and_refuses_a_foreign_one(tmp_path):
    """A row repeated in ``results.csv``: the resumed study keeps it once
    (4 rows for 4 samples); a row edited to another seed is refused."""
    from bplir_drake.analysis import montecarlo as mc

    out = tmp_path / "mc"
    study = mc.Study(samples=4, seed=0)
    mc.run_study(study, out, workers=1)
    lines = (out / "results.csv").read_text().splitlines()
    (out / "results.csv").write_text("\n".join(lines + [lines[2]]) + "\n")
    summary = mc.run_study(study, out, workers=1)
    assert summary["samples"] == 4 and len(mc.read_results(out / "results.csv")) == 4
    rows = mc.read_results(out / "results.csv")
    header = (out / "results.csv").read_text().splitlines()[0].split(",")
    seed_col = header.index("seed")
    lines = (out / "results.csv").read_text().splitlines()
    cells = lines[1].split(",")
    cells[seed_col] = str(int(float(cells[seed_col])) + 1)
    (out / "results.csv").write_text("\n".join([lines[0], ",".join(cells), *lines[2:]]) + "\n")
    with pytest.raises(mc.StudyError, match=f"the row of sample {rows[0]['index']} has seed"):
        mc.run_study(study, out, workers=1)


def test_any_kept_row_replays_after_a_smaller_rerun(tmp_path):
    """A study run with 3 samples, then again with 2: sample 2's row is kept
    and replays, matching its record."""
    from bplir_drake.analysis import montecarlo as mc

    out = tmp_path / "mc"
    mc.run_study(mc.Study(samples=3, seed=0), out, workers=1)
    mc.run_study(mc.Study(samples=2, seed=0), out, workers=1)
    result, recorded = mc.replay(out, 2)
    assert recorded is not None and recorded["index"] == 2
    assert result.summary["capture_speed_mps"] == pytest.approx(recorded["capture_speed_mps"],
                                                                abs=1e-12)
    with pytest.raises(mc.StudyError, match="out of range"):
        mc.replay(out, 3)


def _calibration_log(tmp_path, extra_header="", extra_cell=lambda k: "", q1d="0.0", tau=None,
                     t_end=3.0):
    lines = ["t,q1,q2,tau,q1d,q2d" + extra_header]
    for k, t in enumerate(np.linspace(0.0, t_end, 301)):
        torque = tau if tau is not None and k == 0 else "1.0"
        rate = q1d if k == 0 else "0.0"
        lines.append(f"{t},{0.3 * math.cos(2.7 * t)},{0.1 * math.sin(3 * t)},{torque},{rate},0.0"
                     + extra_cell(k))
    path = tmp_path / "log.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("kw, words", [
    ({"q1d": "nan"}, "log column q1d, q2d: nan is not plausible"),
    ({"q1d": "1e300"}, "log column q1d, q2d: 1e+300 is not plausible"),
    ({"tau": "1e300"}, "log column tau: 1e+300 is not plausible"),
    ({"t_end": 1e5}, "log spans 100000 s; allowed at most 600 s"),
])
def test_a_calibration_log_with_implausible_values_is_refused(kw, words, tmp_path, capsys):
    """NaN or 1e300 initial rates or torques, a log spanning 1e5 s: one line,
    exit 2, before any simulation."""
    from bplir_drake.cli import main

    log = _calibration_log(tmp_path, **kw)
    assert main(["calibrate", str(log), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err


def test_a_calibration_log_ignores_extra_columns_text_or_numbers(tmp_path):
    """Extra columns -- a note in text -- are ignored, as the reader says."""
    from bplir_drake.analysis.identification.calibration import read_calibration_csv

    plain = read_calibration_csv(_calibration_log(tmp_path), 1.33)
    noted = read_calibration_csv(_calibration_log(tmp_path, ",note", lambda k: ",ok"), 1.33)
    np.testing.assert_array_equal(plain.q, noted.q)
    np.testing.assert_array_equal(plain.tau, noted.tau)


def test_ctrl_c_inside_a_solver_callback_is_an_interrupt(monkeypatch, tmp_path, capsys):
    """Ctrl-C while SNOPT runs reaches Python wrapped in a RuntimeError from
    Drake's callback: still the interrupt's one line and exit 130."""
    from bplir_drake.planning import solve as P
    from bplir_drake.cli import main

    def interrupted(*a, **k):
        raise RuntimeError("Python callback raised: KeyboardInterrupt")

    monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(P, "_solve_plan", interrupted)
    assert main(["plan", "--incline", "9", "--out", str(tmp_path / "out")]) == 130
    assert capsys.readouterr().err == ("bplir: interrupted; no output file was left "
                                       "half-written\n")


def test_a_number_of_hundreds_of_digits_in_a_config_is_bad_input(tmp_path, capsys):
    """``[plant] m1 = 1`` followed by 400 zeros: one line naming the field and
    its range, exit 2 (not an OverflowError)."""
    from bplir_drake.cli import main

    config = tmp_path / "big.toml"
    config.write_text("[plant]\nm1 = 1" + "0" * 400 + "\n")
    assert main(["swing", "--config", str(config), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "plant.m1 = 100000000000... (401 digits)" in err
    assert "allowed range (0, 1000]" in err
