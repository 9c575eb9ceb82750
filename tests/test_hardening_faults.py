"""Faults behind the front door, each through the command line's entry
point in a process of its own (forked from the test's, :mod:`forked`; a
fresh one for Ctrl-C and for memory): a full disk, a plug-in that answers
NaN or hangs, a study directory that names code to run, the memory of a
long log.  Every case ends in one line, the right exit status and no file
half-written."""
import resource
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import plugin_source, quick_plan
from forked import bplir_forked

ROOT = Path(__file__).resolve().parents[1]


def run(*argv, limit_bytes=None, timeout=180):
    """``bplir ARGV`` in a process of its own (:func:`forked.bplir_forked`);
    with ``limit_bytes`` no file the process writes may grow past it (a
    full disk: writes fail with an OSError, as with ENOSPC)."""
    def small_disk():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))

    return bplir_forked(*argv, preexec=small_disk if limit_bytes else None, timeout=timeout)


def one_line(err) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def hidden_files(where: Path) -> list[str]:
    """Temporary files left behind (the study lock is kept on purpose)."""
    return [p.name for p in where.rglob(".*") if p.name != ".lock"]


def _imu_log(path, n=300):
    from bplir_drake.estimation import write_imu_csv

    s = np.zeros((n, 6))
    s[:, 3] = s[:, 5] = 9.81
    return write_imu_csv(np.arange(n) * 0.01, s, path)


@pytest.mark.parametrize("argv, wrote", [
    (["swing", "--no-animation", "--out", "{d}/swing"], "swing/swing.png"),
    (["estimate", "{log}", "--out", "{d}/est.csv"], "est.csv"),
    (["traverse", ROOT / "examples" / "line_flat.toml", "--no-animation", "--out", "{d}/trv"],
     "trv/"),
    (["montecarlo", "-n", "2", "--workers", "1", "--out", "{d}/mc"], "mc/"),
])
@pytest.mark.slow
def test_a_full_disk_is_one_line_naming_the_file(argv, wrote, tmp_path):
    """Outputs that cannot be written (no file may grow past 48 KiB):
    one line naming the file the command was writing, exit 1, no temporary
    file left."""
    log = _imu_log(tmp_path / "imu.csv", 3000)   # an estimate of it is about 500 KiB
    d = tmp_path / "full"
    d.mkdir()
    argv = [str(a).format(d=d, log=log) for a in argv]
    rc, _, err = run(*argv, limit_bytes=48 * 1024)
    line = one_line(err)
    assert rc == 1, err
    assert line.startswith(f"bplir: error: {argv[0]}: cannot write or read {d}/{wrote}")
    assert line.endswith("File too large")
    assert hidden_files(d) == []


def test_a_plugin_answering_nan_names_the_swing_the_time_and_the_port(tmp_path):
    """A controller whose torque turns NaN at 0.3 s: one line naming
    the swing (its seed), the time and the port, exit 1."""
    plugin = tmp_path / "nan.py"
    plugin.write_text(plugin_source("out.SetAtIndex(0, float('nan')); return"))
    rc, _, err = run("swing", "--controller", f"{plugin}:make", "--no-animation",
                     "--out", tmp_path / "out")
    assert rc == 1
    line = one_line(err)
    assert line.startswith("bplir: error: swing failed: SimulationError: the swing of seed 0 "
                           "failed at t = 0.30")
    assert "NaN in the actuation input port" in line


@pytest.mark.slow
def test_a_hung_plugin_is_stopped_by_the_wall_clock_limit(tmp_path):
    """A controller that never returns: the swing stops at the wall-clock
    limit (one line naming it, exit 1); in a 2-worker study every sample
    becomes an error row and the study finishes."""
    plugin = tmp_path / "hang.py"
    plugin.write_text(plugin_source("while True: time.sleep(0.01)"))
    spec = f"{plugin}:make"
    rc, _, err = run("swing", "--controller", spec, "--set", "scenario.wall_limit=1",
                     "--no-animation", "--out", tmp_path / "out")
    assert rc == 1
    assert one_line(err) == ("bplir: error: swing failed: WallClockLimit: the swing of seed 0 "
                             "ran past its wall-clock limit of 1 s (scenario.wall_limit; a "
                             "hung controller or plug-in?)")
    rc, out, err = run("montecarlo", "-n", "2", "--workers", "2", "--controller", spec,
                       "--set", "scenario.wall_limit=1", "--no-plots", "--json",
                       "--out", tmp_path / "mc")
    from bplir_drake.analysis import montecarlo as mc

    assert rc == 0, err
    rows = mc.read_results(tmp_path / "mc" / "results.csv")
    assert len(rows) == 2 and all("wall-clock limit of 1 s" in r["error"] for r in rows)


def test_the_default_wall_clock_limit_is_far_beyond_an_honest_swing():
    """No honest swing comes near the default limit: the default swing
    takes a few seconds of wall-clock time, the limit is minutes."""
    from bplir_drake.params import BplirParams

    assert BplirParams().scenario.wall_limit >= 100 * 3.0


def test_replaying_a_study_runs_its_plugin_only_when_the_user_names_it(tmp_path):
    """A study directory names the plug-in file its samples ran; a replay
    runs that code only when the command line names the same plug-in."""
    spec = f"{ROOT / 'examples' / 'my_controller.py'}:make"
    rc, _, err = run("montecarlo", "-n", "1", "--workers", "1", "--controller", spec,
                     "--no-plots", "--out", tmp_path / "mc")
    assert rc == 0, err
    rc, _, err = run("swing", "--replay", tmp_path / "mc", "--sample", "0", "--no-animation",
                     "--out", tmp_path / "r")
    assert rc == 2 and one_line(err) == (f"bplir: error: study {tmp_path / 'mc'} runs the "
                                         f"plug-in controller {spec}; name it to run it: "
                                         f"--controller {spec}")
    assert not (tmp_path / "r").exists()
    rc, out, err = run("swing", "--replay", tmp_path / "mc", "--sample", "0", "--controller",
                       spec, "--no-animation", "--no-plots", "--out", tmp_path / "r")
    assert rc == 0 and "matches the recorded result exactly" in out


def test_outputs_are_not_left_private(tmp_path):
    """Outputs written through a temporary file get the
    usual mode (0666 less the umask), not the temporary file's 0600."""
    import os

    from bplir_drake.io import write_text_atomic

    umask = os.umask(0o022)
    try:
        path = write_text_atomic(tmp_path / "a.txt", "x")
    finally:
        os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o644


@pytest.mark.slow
def test_reading_a_log_costs_its_numbers_not_its_text(tmp_path):
    """A 300 000-row IMU log is read in a process whose resident memory grows
    by less than 80 bytes per row (its seven numbers are 56 bytes; the text
    is about 85).  The 3.3 M-row estimate is ``benchmarks/bench_long_log.py``."""
    n = 300_000
    log = tmp_path / "long.csv"
    with open(log, "w") as f:
        f.write("t,gyro1,gyro2,acc1_x,acc1_y,acc2_x,acc2_y\n")
        rows = np.column_stack([np.arange(n) * 0.01, np.full((n, 6), 0.012345)])
        np.savetxt(f, rows, delimiter=",", fmt="%.9g")
    code = ("import resource, sys\n"
            "from bplir_drake.estimation import read_imu_csv\n"
            "before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
            f"log = read_imu_csv({str(log)!r})\n"
            "after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
            "print(len(log.t), (after - before) * 1024)\n")
    rows_read, grown = map(int, subprocess.run([sys.executable, "-c", code], check=True,
                                               capture_output=True, text=True).stdout.split())
    assert rows_read == n
    assert grown / n < 80, grown / n


# ------------------------------------------------ the issue's rows, as processes

def _calibration_csv(path, q1d="0.0", tau="1.0", t_end=3.0, note=False):
    lines = ["t,q1,q2,tau,q1d,q2d" + (",note" * note)]
    for k, t in enumerate(np.linspace(0.0, t_end, 301)):
        lines.append(f"{t},{0.3 * np.cos(2.7 * t)},{0.1 * np.sin(3 * t)},"
                     f"{tau if k == 0 else '1.0'},{q1d if k == 0 else '0.0'},0.0"
                     + (",ok" * note))
    path.write_text("\n".join(lines) + "\n")
    return path


def _wild_imu(path, row=20, col=0, value=1e300, jump=0.0):
    from bplir_drake.estimation import write_imu_csv

    t = np.arange(200) * 0.01
    t[100:] += jump
    s = np.tile([0.0, 0.0, 0.0, 9.81, 0.0, 9.81], (200, 1))
    s[row, col] = value
    return write_imu_csv(t, s, path)


def _file(name, text):
    def make(d):
        (d / name).write_text(text)
        return d / name
    return make


ROWS = {   # row: (files to make, argv, words of the one line)
    1: ({"big": _file("big.toml", "[plant]\nm1 = 1" + "0" * 400 + "\n")},
        ["swing", "--config", "{big}"], "plant.m1 = 100000000000... (401 digits)"),
    2: ({"line": _file("flat.toml", 'length = 10.0\nstart = 1.2\n[catenary]\nspan = 60.0\n'
                                    'sag = 1e-9\n')},
        ["traverse", "{line}"], "sag = 1e-09 is out of range; allowed [0.006, 15]"),
    3: ({"log": lambda d: _calibration_csv(d / "c.csv", q1d="nan")},
        ["calibrate", "{log}"], "log column q1d, q2d: nan is not plausible"),
    4: ({"log": lambda d: _calibration_csv(d / "c.csv", tau="1e300")},
        ["calibrate", "{log}"], "log column tau: 1e+300 is not plausible"),
    6: ({"plugin": _file("raise.py", plugin_source("raise RuntimeError('lost its mind')"))},
        ["swing", "--controller", "{plugin}:make", "--no-animation"], "lost its mind"),
    11: ({"log": lambda d: _wild_imu(d / "imu.csv")},
         ["estimate", "{log}"], "row 21 column gyro1: 1e+300 is not a plausible reading"),
    "11b": ({"log": lambda d: _wild_imu(d / "imu.csv", value=0.0)},
            ["estimate", "{log}", "--l1", "1e300"], "estimator.l1 = 1e+300 is out of range"),
    12: ({"log": lambda d: _wild_imu(d / "imu.csv", value=0.0, jump=1e6)},
         ["estimate", "{log}"], "time jumps by 1e+06 s at row 101"),
    13: ({}, ["freeswing", "--q0", "1e300,0", "--duration", "1"], "--q0 Q1 = 1e+300 rad"),
    14: ({"log": lambda d: _calibration_csv(d / "c.csv")},
         ["calibrate", "{log}", "--fit", "fv1,fv1"], "--fit names fv1 more than once"),
    15: ({}, ["swing", "--out", ""], "--out '' is empty"),
    16: ({"plugin": _file("exit.py", "import sys\ndef make(p):\n    sys.exit(0)\n")},
         ["swing", "--controller", "{plugin}:make"], "the factory raised SystemExit"),
    "16b": ({"plugin": _file("exit3.py", "import sys\nsys.exit(3)\n")},
            ["swing", "--controller", "{plugin}:make"], "cannot load"),
    19: ({"log": lambda d: _calibration_csv(d / "c.csv", t_end=1e5)},
         ["calibrate", "{log}"], "log spans 100000 s; allowed at most 600 s"),
}


@pytest.mark.parametrize("row", list(ROWS), ids=str)
def test_the_issues_rows_through_the_console_entry_point(row, tmp_path):
    """Bad input and broken plug-ins from the hardening issue, each as the
    user meets it: one line, exit 2 (bad input) or 1 (a fault inside), no
    output directory left behind by a refusal, no process left running."""
    makers, argv, words = ROWS[row]
    made = {name: make(tmp_path) for name, make in makers.items()}
    argv = [a.format(**made) for a in argv]
    out = tmp_path / "out"
    if "--out" not in argv:
        argv += ["--out", str(out)]
    rc, _, err = run(*argv, timeout=120)
    line = one_line(err)
    assert line.startswith("bplir: error: ") and words in line, line
    assert rc == (1 if row == 6 else 2), err
    if rc == 2:
        assert not out.exists()


@pytest.mark.slow
def test_a_plan_solve_ends_at_ctrl_c_with_130(tmp_path):
    """Ctrl-C while a plan is solved from a cold cache: exit 130 and
    the interrupt's one line (not a RuntimeError from the solver's
    callback)."""
    import os
    import time

    cache = tmp_path / "cache"
    env = dict(os.environ, BPLIR_CACHE_DIR=str(cache))
    proc = subprocess.Popen([sys.executable, "-m", "bplir_drake.cli", "plan", "--incline", "9",
                             "--out", str(tmp_path / "out")], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not (cache.is_dir() and any(cache.iterdir())):
        time.sleep(0.02)   # the plan's lock: pydrake is loaded and the solve starts
    time.sleep(1.5)   # the collocation problem is built (~0.2 s) and SNOPT iterates
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert err.strip() == "bplir: interrupted; no output file was left half-written"
    assert not list((tmp_path / "cache").glob("plan-*.npz"))


def test_a_resumed_study_keeps_each_row_once_and_replays_any_kept_row(tmp_path):
    """Rows 23 and 24 from the command line: a row repeated in
    ``results.csv`` is kept once on resume; after a smaller rerun the
    study's last kept row still replays, matching its record."""
    from bplir_drake.analysis import montecarlo as mc

    mcdir = tmp_path / "mc"
    study = ["montecarlo", "-n", "3", "--workers", "1", "--no-plots", "--out", mcdir]
    assert run(*study)[0] == 0
    lines = (mcdir / "results.csv").read_text().splitlines()
    (mcdir / "results.csv").write_text("\n".join(lines + [lines[2]]) + "\n")
    rc, _, err = run(*study)
    assert rc == 0, err
    assert sorted(r["index"] for r in mc.read_results(mcdir / "results.csv")) == [0, 1, 2]
    study[2] = "2"
    assert run(*study)[0] == 0
    rc, out, err = run("swing", "--replay", mcdir, "--sample", "2", "--no-animation",
                       "--no-plots", "--out", tmp_path / "r")
    assert rc == 0 and "replay of sample 2" in out and "matches the recorded result" in out


def _bplir_with_solver(solver: str, cache, *argv):
    """``bplir ARGV`` in a process of its own whose plan solver (and LQR
    gains) is replaced: ``refuse`` (no solve may happen) or ``quick``
    (:func:`conftest.quick_plan`); ``BPLIR_CACHE_DIR`` is
    ``cache``.  A ``CompletedProcess``."""
    def replaced():
        from bplir_drake.planning import solve as P

        def refuse(*a, **k):
            raise SystemExit("solved a shipped plan")

        P._solve_plan = refuse if solver == "refuse" else quick_plan
        if solver == "refuse":
            P.plan_gains = refuse

    rc, out, err = bplir_forked(*argv, env={"BPLIR_CACHE_DIR": cache}, before=replaced)
    return subprocess.CompletedProcess(argv, rc, out, err)


@pytest.mark.parametrize("where", ["/proc/bplir-no-such/cache", "a file"])
def test_an_unusable_cache_directory_still_swings_on_the_shipped_plans(where, tmp_path):
    """From the command line, with ``BPLIR_CACHE_DIR`` inside /proc or
    a file the default swing runs on the shipped plan and gains (nothing
    is solved: the solver is switched off in that process) and captures.
    (A file where the directory should be is unusable even to root, which
    a read-only directory is not.)"""
    if where == "a file":
        where = tmp_path / "not-a-directory"
        where.write_text("")
    p = _bplir_with_solver("refuse", where, "swing", "--no-animation", "--no-plots", "--json",
                           "--out", tmp_path / "out")
    assert p.returncode == 0, p.stderr
    assert '"outcome": "captured"' in p.stdout


def _plan_process(cache, out):
    return _bplir_with_solver("quick", cache, "plan", "--incline", "9", "--no-plots", "--out",
                              out)


def test_a_damaged_cached_plan_or_a_planted_link_does_not_stop_bplir_plan(tmp_path):
    """Rows 9 and 25 from the command line (the solver replaced by a quick
    stand-in in that process): a truncated ``plan-<key>.npz`` is moved aside
    as ``.damaged`` and solved again, exit 0; a link planted at the plan's
    ``.lock`` is neither followed nor truncated, and the command still
    succeeds."""
    cache = tmp_path / "cache"
    first = _plan_process(cache, tmp_path / "a")
    assert first.returncode == 0, first.stderr
    [stored] = cache.glob("plan-*.npz")
    stored.write_bytes(stored.read_bytes()[:40])            # row 9: truncated
    again = _plan_process(cache, tmp_path / "b")
    assert again.returncode == 0, again.stderr
    assert stored.with_suffix(".damaged").exists() and stored.stat().st_size > 40
    stored.unlink()
    lock = stored.with_suffix(".lock")
    lock.unlink()
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    lock.symlink_to(victim)                                  # row 25: a planted link
    third = _plan_process(cache, tmp_path / "c")
    assert third.returncode == 0, third.stderr
    assert victim.read_text() == "keep me"
    assert (tmp_path / "c" / "plan.json").exists()
