"""Adversarial checks, one function for each way a user broke the package:
each runs the ``bplir`` console entry point in a process of its own (or the
package's function, where the check is about one) and returns None when
it holds, else what broke.  ``test_misuse.py`` runs them as tests; ``python
tests/misuse_checks.py`` runs them all."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from conftest import plugin_source, quick_plan
from forked import bplir_forked, start_forked

ROOT = Path(__file__).resolve().parents[1]
ROBOT = ROOT / "bplir_drake" / "data" / "robots" / "bplir.urdf"


# ------------------------------------------------------------------ helpers
def bplir(*argv, timeout=180, env=None, fork=True, before=None):
    """``bplir ARGV`` in a process of its own: (status, stdout, stderr).  The
    process is forked from this one with the package imported
    (:func:`forked.bplir_forked`; ``before()`` runs in it before the
    command), or with ``fork=False`` a fresh ``python -m bplir_drake.cli``."""
    if fork:
        return bplir_forked(*argv, env=env, before=before, timeout=timeout)
    p = subprocess.run([sys.executable, "-m", "bplir_drake.cli", *map(str, argv)],
                       capture_output=True, text=True, timeout=timeout,
                       env=None if env is None else dict(os.environ, **env))
    return p.returncode, p.stdout, p.stderr


def start(*argv, fork=True):
    """``bplir ARGV`` started in a session of its own (Ctrl-C reaches its
    group): forked from this process (:func:`forked.start_forked`), or with
    ``fork=False`` a fresh ``python -m bplir_drake.cli``."""
    if fork:
        return start_forked(*argv, new_session=True)
    return subprocess.Popen([sys.executable, "-m", "bplir_drake.cli", *map(str, argv)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def children(pid: int) -> list[int]:
    """The PIDs of ``pid``'s child processes (Linux)."""
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(c) for c in text.split()]


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def wait_for(check, limit=90.0, step=0.05) -> bool:
    end = time.monotonic() + limit
    while time.monotonic() < end:
        if check():
            return True
        time.sleep(step)
    return False


def said(err: str) -> list[str]:
    """The lines of ``err`` but progress lines (``bplir: progress:``, which a
    command run long in a log adds before its result or its one line)."""
    return [x for x in err.strip().splitlines() if not x.startswith("bplir: progress:")]


def one_error_line(rc, err, status, *words) -> str | None:
    """None when ``err`` is one ``bplir: error:`` line holding ``words`` and
    the exit status is ``status``; else what differs."""
    lines = said(err)
    if "Traceback" in err or len(lines) != 1 or not lines[0].startswith("bplir: error: "):
        return f"not one error line (exit {rc}): {err[-600:]!r}"
    missing = [w for w in words if w not in lines[0]]
    if missing or rc != status:
        return f"exit {rc} (wanted {status}), line {lines[0]!r} lacks {missing}"
    return None


def first(*problems):
    """The first problem of several checks (None when all hold)."""
    return next((p for p in problems if p), None)


def plugin(d: Path, name: str, fault: str, factory: str = "") -> str:
    """A plug-in controller file: zero torque until 0.3 s, then ``fault``."""
    (d / name).write_text(plugin_source(fault, factory or "pass"))
    return f"{d / name}:make"


def robot_config(d: Path, name: str, edit) -> Path:
    """A config reading a copy of the default robot's URDF changed by ``edit(text)``."""
    (d / f"{name}.urdf").write_text(edit(ROBOT.read_text()))
    (d / f"{name}.toml").write_text(f'[robot]\nfile = "{name}.urdf"\n')
    return d / f"{name}.toml"


def angle_log(d: Path, name: str, hole=0.0, row=None, col=1, value=0.0) -> Path:
    """A 1.4 s log of t, q1, q2, tau at 100 Hz; optionally a hole of ``hole``
    s after row 70, or ``value`` at ``row``, column ``col``."""
    t = np.arange(140) * 0.01
    t[70:] += hole
    data = np.c_[t, 0.3 * np.cos(2.7 * t), 0.1 * np.sin(3 * t), np.full(140, 0.5)]
    if row is not None:
        data[row, col] = value
    lines = ["t,q1,q2,tau"] + [",".join(repr(float(v)) for v in r) for r in data]
    (d / name).write_text("\n".join(lines) + "\n")
    return d / name


# ------------------------------------------------------------------ classes
def a_plugin_exit_mid_swing_is_one_line(d: Path):
    """A plug-in calling sys.exit mid-swing: one line and exit 1 (swing); an
    error row naming it (a study on one worker)."""
    spec3 = plugin(d, "exit3.py", "sys.exit(3)")
    rc, _, err = bplir("swing", "--controller", spec3, "--no-animation", "--out", d / "s")
    spec0 = plugin(d, "exit0.py", "sys.exit(0)")
    rc2, _, err2 = bplir("montecarlo", "-n", "1", "--workers", "1", "--controller", spec0,
                         "--no-plots", "--out", d / "mc")
    rows = (d / "mc" / "results.csv").read_text().splitlines() if rc2 == 0 else []
    return first(one_error_line(rc, err, 1, "swing failed", "called sys.exit(3)"),
                 None if rc2 == 0 and len(rows) == 2 and "sys.exit(0)" in rows[1]
                 else f"study: exit {rc2}, rows {rows}, {err2[-300:]!r}")


def a_massless_or_negative_link_is_bad_input(d: Path):
    """A URDF link of mass 0 (with an inertia) or -1, or an inertia no body
    can have: refused with one line, exit 2 (Drake would substitute)."""
    edits = {"mass0": lambda s: s.replace('value="1.5155"', 'value="0"'),
             "mass-1": lambda s: s.replace('value="1.5155"', 'value="-1"'),
             "negative": lambda s: s.replace('iyy="0.1539"', 'iyy="-0.1539"'),
             "triangle": lambda s: s.replace('izz="1.539e-05"', 'izz="1"')}
    words = {"mass0": "has mass 0 and an inertia", "mass-1": "has mass -1",
             "negative": "an inertia no body can have", "triangle": "no body can have"}
    for name, edit in edits.items():
        rc, _, err = bplir("params", "plant", "--config", robot_config(d, name, edit))
        problem = one_error_line(rc, err, 2, words[name], "allowed")
        if problem:
            return f"{name}: {problem}"
    return None


def a_nan_in_a_robot_pose_is_bad_input(d: Path):
    """A NaN in a URDF pose or axis: bad input (exit 2), not a fault."""
    for name, edit in (("origin", lambda s: s.replace('xyz="0 0 -0.9091"', 'xyz="0 0 nan"')),
                       ("axis", lambda s: s.replace('<axis xyz="0 -1 0"/>',
                                                    '<axis xyz="nan 0 0"/>', 1))):
        rc, _, err = bplir("params", "plant", "--config", robot_config(d, name, edit))
        problem = one_error_line(rc, err, 2, "is not 3 finite numbers")
        if problem:
            return f"{name}: {problem}"
    return None


def an_implausible_log_angle_is_refused(d: Path):
    """A log with q1 = 1e300 or q2 = 1000: the range check's own line."""
    for cmd, col, value in (("replay", 1, 1e300), ("calibrate", 2, 1000.0)):
        log = angle_log(d, f"{cmd}.csv", row=20, col=col, value=value)
        rc, _, err = bplir(cmd, log, "--out", d / cmd)
        problem = one_error_line(rc, err, 2, "is not plausible", "allowed [-50, 50] rad")
        if problem:
            return f"{cmd}: {problem}"
    return None


def a_hole_in_a_log_is_refused(d: Path):
    """A 5 s hole in a 1.4 s log: refused by replay and calibrate."""
    log = angle_log(d, "hole.csv", hole=5.0)
    for cmd in ("replay", "calibrate"):
        rc, _, err = bplir(cmd, log, "--out", d / cmd)
        problem = one_error_line(rc, err, 2, "time jumps by 5.01 s at row 71")
        if problem:
            return f"{cmd}: {problem}"
    return None


def a_replay_window_below_two_samples_is_refused(d: Path):
    """``replay --window 1e-9``: refused at once (two sampling periods at least)."""
    rc, _, err = bplir("replay", angle_log(d, "ok.csv"), "--window", "1e-9", "--out", d / "r",
                       timeout=20)
    return one_error_line(rc, err, 2, "--window = 1e-09 s is out of range", "allowed [0.02")


def a_constant_study_column_draws_its_histogram(d: Path):
    """A study's histogram of a column constant to its last bit (the
    traversals' peak torque at the motor's limit) draws instead of raising
    'Too many bins'."""
    import matplotlib

    matplotlib.use("Agg")
    from bplir_drake.analysis.montecarlo import Study
    from bplir_drake.analysis.montecarlo.study_plots import plot_histograms

    peak = 19.896212903225805
    rows = [{"outcome": "passed", "capture_speed_mps": 0.3 + 0.01 * k, "swing_time_s": 8.38,
             "peak_torque_Nm": np.nextafter(peak, 30.0) if k == 1 else peak,
             "peak_motor_power_W": 310.0 + k} for k in range(4)]
    try:
        fig = plot_histograms(Study(samples=4), rows)
    except ValueError as exc:
        return f"plot_histograms raised {exc}"
    counts = [sum(p.get_height() for p in ax.patches) for ax in fig.axes[:4]]
    return None if counts == [4, 4, 4, 4] else f"histogram counts {counts}"


def a_sigterm_during_a_traverse_rerun_is_one_line(d: Path):
    """SIGTERM during a rerun of ``traverse`` into a finished --out: the
    motion log and the summary are the finished run's, whole; no temporary
    file is left.  Six obstacles: a rerun long enough for the signal to land
    while its swings run, not after it has finished."""
    out = d / "trv"
    line = long_line(d, obstacles=6)
    rc, _, err = bplir("traverse", line, "--no-animation", "--no-plots", "--out", out)
    if rc != 0:
        return f"first run: exit {rc} {err[-300:]!r}"
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    proc = start("traverse", line, "--no-animation", "--no-plots", "--seed", "1", "--out", out)
    if not wait_for(lambda: any(p.stat().st_size > 0 for p in out.glob(".motion-*"))):
        proc.kill()
        return "the rerun never wrote its motion log"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    after = {p.name: p.read_bytes() for p in out.iterdir()}
    return first(one_line_stop(proc.returncode, err, 143, "terminated by SIGTERM"),
                 None if after == before else
                 f"files changed: {sorted(k for k in after if after.get(k) != before.get(k))}")


def one_line_stop(rc, err, status, words) -> str | None:
    lines = said(err)
    if "Traceback" in err or len(lines) != 1 or words not in lines[0] or rc != status:
        return f"exit {rc} (wanted {status}), stderr {err[-800:]!r}"
    return None


def long_line(d: Path, obstacles: int = 22) -> Path:
    """A level line with more obstacles than a traversal runs in-process."""
    text = [f"length = {2.1 * obstacles + 3.0}", "start = 1.2",
            f"incline = [[0.0, 0.0], [{2.1 * obstacles + 3.0}, 0.0]]"]
    for k in range(obstacles):
        text += ["[[obstacles]]", f'name = "o{k}"', f"position = {1.7 + 2.1 * k:.2f}",
                 "width = 0.2"]
    (d / "long.toml").write_text("\n".join(text) + "\n")
    return d / "long.toml"


def signals_reach_a_traversal_run_in_workers(d: Path):
    """A traversal whose swings run in a worker: SIGTERM and Ctrl-C give the
    one line and no worker's traceback; kill -9 of the parent leaves no
    worker running and nothing printed."""
    line = long_line(d)
    for how, status, words in (("TERM", 143, "terminated by SIGTERM"),
                               ("INT", 130, "interrupted"), ("KILL", -9, "")):
        proc = start("traverse", line, "--no-animation", "--no-plots", "--out", d / how)
        if not wait_for(lambda: children(proc.pid)):
            proc.kill()
            return f"{how}: no worker started"
        workers = children(proc.pid)
        time.sleep(0.5)   # the worker is inside a swing
        if how == "INT":
            os.killpg(proc.pid, signal.SIGINT)   # a terminal's Ctrl-C: the whole group
        else:
            proc.send_signal(getattr(signal, f"SIG{how}"))
        _, err = proc.communicate(timeout=60)
        if how == "KILL":
            gone = wait_for(lambda: not any(alive(w) for w in workers), limit=10)
            problem = None if gone and not err.strip() else \
                f"KILL: workers left {gone is False}, stderr {err[-400:]!r}"
        else:
            problem = one_line_stop(proc.returncode, err, status, words)
        if problem:
            return f"{how}: {problem}"
    return None


def ctrl_c_on_a_dask_study_is_one_line(d: Path):
    """``--dask``: Ctrl-C gives the one line, no worker's traceback or log."""
    proc = start("montecarlo", "-n", "200", "--dask", "--workers", "2", "--no-plots",
                 "--out", d / "mc", fork=False)
    if not wait_for(lambda: (d / "mc" / "results.csv").exists() and len(
            (d / "mc" / "results.csv").read_text().splitlines()) > 1, limit=120):
        proc.kill()
        return "no sample finished"
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    return one_line_stop(proc.returncode, err, 130, "interrupted")


def a_printing_plugin_under_dask_keeps_json_clean(d: Path):
    """``--dask --json`` with a plug-in that prints and then calls sys.exit
    mid-swing: standard output is the JSON summary alone, each sample is an
    error row naming the exit, nothing else is said."""
    spec = plugin(d, "chatty.py", "print('hello from calc'); sys.exit(0)",
                  factory="print('hello from the factory'); os.write(1, b'XXX Singular basis\\n')")
    rc, out, err = bplir("montecarlo", "-n", "2", "--dask", "--workers", "2", "--controller",
                         spec, "--no-plots", "--json", "--out", d / "mc", fork=False)
    try:
        summary = json.loads(out)
    except ValueError:
        return f"stdout is not JSON: {out[:300]!r}"
    rows = (d / "mc" / "results.csv").read_text().splitlines()[1:]
    if rc != 0 or summary.get("samples") != 2 or not all("sys.exit(0)" in r for r in rows):
        return f"exit {rc}, rows {rows}"
    if "Traceback" in err or "KilledWorker" in err or len(err.splitlines()) > 4:
        return f"stderr says too much: {err[-600:]!r}"
    return None


def _quick_plans():
    """Make the plan solver a 1 s plan at rest (:func:`conftest.quick_plan`)."""
    from bplir_drake.planning import solve as P

    P._solve_plan = quick_plan


def quick_solver(cache: Path, *argv):
    """``bplir ARGV`` whose plan solver is a 1 s plan at rest
    (:func:`_quick_plans`) and whose cache is ``cache``: (status, stdout,
    stderr)."""
    return bplir(*argv, env={"BPLIR_CACHE_DIR": cache}, before=_quick_plans)


def plan_csv(d: Path, name: str, last=None, gap=0.0) -> Path:
    t = np.linspace(0.0, 1.0, 20)
    t[10:] += gap
    if last is not None:
        t[-1] = last
    rows = ["t,q1,q2,q1d,q2d,tau"] + [f"{v},0.1,0.2,0.0,0.0,0.5" for v in t]
    (d / name).write_text("\n".join(rows) + "\n")
    return d / name


def an_odd_plan_file_is_refused(d: Path):
    """plan.file with its last row at t = 1e9, a 30 s gap, or file_columns
    naming one column twice: bad input, one line, exit 2."""
    cases = {"late": ({"last": 1e9}, "", "spans 1e+09 s; allowed at most 60 s"),
             "gap": ({"gap": 30.0}, "", "30.0526 s between rows 10 and 11"),
             "twice": ({}, 'file_columns = ["t", "q1", "q2", "q1d", "q2d", "t"]\n',
                       "names t more than once")}
    for name, (shape, extra, words) in cases.items():
        csv = plan_csv(d, f"{name}.csv", **shape)
        (d / f"{name}.toml").write_text(f'[plan]\nfile = "{csv}"\n{extra}')
        rc, _, err = bplir("swing", "--config", d / f"{name}.toml", "--no-animation",
                           "--out", d / name)
        problem = one_error_line(rc, err, 2, words)
        if problem:
            return f"{name}: {problem}"
    return None


def a_looping_plugin_factory_meets_the_wall_limit(d: Path):
    """A plug-in factory that loops is stopped by scenario.wall_limit."""
    (d / "loop.py").write_text("def make(params):\n    while True:\n        pass\n")
    t0 = time.monotonic()
    rc, _, err = bplir("swing", "--controller", f"{d / 'loop.py'}:make", "--set",
                       "scenario.wall_limit=1", "--no-animation", "--out", d / "s", timeout=60)
    return first(one_error_line(rc, err, 1, "WallClockLimit", "(its module and factory) ran "
                                "past its wall-clock limit of 1 s"),
                 None if time.monotonic() - t0 < 30 else "stopped late")


def tiny_robot(d: Path) -> Path:
    """A robot file whose link 2 weighs 1e-9 kg (in range; the integrator crawls)."""
    return robot_config(d, "tiny", lambda s: s.replace('value="1.5155"', 'value="1e-9"').replace(
        'ixx="0.2191" ixy="0" ixz="0" iyy="0.2191" iyz="0" izz="2.191e-05"',
        'ixx="1e-12" ixy="0" ixz="0" iyy="1e-12" iyz="0" izz="1e-15"'))


def a_crawling_free_swing_meets_the_wall_limit(d: Path):
    """``freeswing`` of a robot with a 1e-9 kg link honours wall_limit; so
    does a calibration's simulation of it."""
    config = tiny_robot(d)
    with open(config, "a") as fh:
        fh.write("[scenario]\nwall_limit = 1\n[friction]\nfv1 = 0.1\nfv2 = 0.1\nfc1 = 0.0\n"
                 "fc2 = 0.0\n")
    rc, _, err = bplir("freeswing", "--config", config, "--out", d / "f", timeout=60)
    rc2, _, err2 = bplir("calibrate", angle_log(d, "log.csv"), "--config", config,
                         "--out", d / "c", timeout=60)
    return first(one_error_line(rc, err, 1, "the free swing ran past its wall-clock limit"),
                 one_error_line(rc2, err2, 1, "a simulation of the log ran past its "
                                "wall-clock limit of 1 s"))


def a_negative_results_index_is_refused(d: Path):
    """A results.csv row with index -1: the resumed study refuses it."""
    study = ["montecarlo", "-n", "1", "--workers", "1", "--no-plots", "--out", d / "mc"]
    rc, _, err = bplir(*study)
    if rc != 0:
        return f"first run: exit {rc} {err[-300:]!r}"
    table = d / "mc" / "results.csv"
    lines = table.read_text().splitlines()
    table.write_text("\n".join(lines + ["-1" + lines[1][lines[1].index(","):]]) + "\n")
    rc, out, err = bplir(*study)
    return one_error_line(rc, err, 2, "holds a row of sample -1")


def seeds_are_ranged_on_every_path(d: Path):
    """scenario.seed in [0, 2^32) from --seed, --set and a config; run_swing's
    seed a whole number in that range."""
    from bplir_drake.analysis.swing.swing_runner import run_swing
    from bplir_drake.params import BplirParams, ParameterError

    (d / "seed.toml").write_text("[scenario]\nseed = 4294967296\n")
    for argv in (["--seed", "4294967296"], ["--set", "scenario.seed=4294967296"],
                 ["--config", d / "seed.toml"]):
        rc, _, err = bplir("swing", *argv, "--out", d / "s")
        problem = one_error_line(rc, err, 2, "is not a seed; allowed a whole number in [0, 2^32)")
        if problem:
            return f"{argv[0]}: {problem}"
    for seed in (-1, "3", 2 ** 32):
        try:
            run_swing(BplirParams(), seed=seed)
            return f"run_swing(seed={seed!r}) ran"
        except ParameterError as exc:
            if "is not a seed" not in str(exc):
                return f"run_swing(seed={seed!r}): {exc}"
    return None


#: every check, by what it guards
CHECKS = {f.__name__: f for f in (
    a_plugin_exit_mid_swing_is_one_line,
    a_massless_or_negative_link_is_bad_input,
    a_nan_in_a_robot_pose_is_bad_input,
    an_implausible_log_angle_is_refused,
    a_hole_in_a_log_is_refused,
    a_replay_window_below_two_samples_is_refused,
    a_constant_study_column_draws_its_histogram,
    a_sigterm_during_a_traverse_rerun_is_one_line,
    signals_reach_a_traversal_run_in_workers,
    ctrl_c_on_a_dask_study_is_one_line,
    a_printing_plugin_under_dask_keeps_json_clean,
    an_odd_plan_file_is_refused,
    a_looping_plugin_factory_meets_the_wall_limit,
    a_crawling_free_swing_meets_the_wall_limit,
    a_negative_results_index_is_refused,
    seeds_are_ranged_on_every_path,
)}


#: the modules of further checks (each with its CHECKS), run with these
MORE = ("process_checks", "cache_checks", "input_checks")


def every_check() -> dict:
    """The checks of this module and of :data:`MORE`, by name."""
    import importlib

    out = dict(CHECKS)
    for module in MORE:
        out |= importlib.import_module(module).CHECKS
    return out


def main() -> int:
    broken = 0
    checks = every_check()
    for name, case in checks.items():
        with tempfile.TemporaryDirectory() as d:
            t0 = time.monotonic()
            try:
                problem = case(Path(d))
            except Exception as exc:   # noqa: BLE001 - a probe that broke is a class broken
                problem = f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]}"
        broken += problem is not None
        print(f"{'holds ' if problem is None else 'BROKEN'} ({time.monotonic() - t0:5.1f} s) "
              f"{name}" + (f"\n    {problem}" if problem else ""))
    print(f"{len(checks) - broken} of {len(checks)} checks hold")
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
