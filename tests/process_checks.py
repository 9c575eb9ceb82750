"""Adversarial checks of how a ``bplir`` process starts, answers signals
and ends (the fourth round of misuse): each runs the console entry point
in a process of its own and returns None when it holds, else what broke.
``test_misuse.py`` runs them as tests; ``python tests/misuse_checks.py``
runs every check."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from misuse_checks import bplir, one_error_line, said

#: a script that runs ``bplir params plant --json`` as ``python -m
#: bplir_drake.cli`` does, its command first writing a line through Drake's
#: Fortran runtime to unit 6 (standard output), as SNOPT writes its messages:
#: the runtime buffers the line until it is flushed
FORTRAN_PRINT = """\
import ctypes, runpy, sys
from pathlib import Path
import pydrake.solvers
from bplir_drake.cli import params_command
table = params_command.cmd_params
def loud(args):
    maps = Path('/proc/self/maps').read_text().splitlines()
    lib = sorted({m.split()[-1] for m in maps if 'libgfortran' in m and 'drake' in m})[0]
    gf = ctypes.CDLL(lib)
    buf = ctypes.create_string_buffer(4096)
    name = ctypes.c_char_p(b'snopt.f')
    ctypes.c_int32.from_buffer(buf, 0).value = 128   # list-directed
    ctypes.c_int32.from_buffer(buf, 4).value = 6     # unit 6
    ctypes.c_void_p.from_buffer(buf, 8).value = ctypes.cast(name, ctypes.c_void_p).value
    ctypes.c_int32.from_buffer(buf, 16).value = 1
    gf._gfortran_st_write(buf)
    text = b'XXX Singular basis after 40 factorization attempts'
    gf._gfortran_transfer_character_write(buf, ctypes.c_char_p(text), ctypes.c_size_t(len(text)))
    gf._gfortran_st_write_done(buf)
    return table(args)
params_command.cmd_params = loud
sys.argv = ['bplir', 'params', 'plant', '--json']
runpy.run_module('bplir_drake.cli', run_name='__main__')
"""


def fortran_output_stays_off_json_stdout(d: Path):
    """A solver's message buffered by the Fortran runtime (SNOPT's "XXX
    Singular basis") is written to standard error under ``--json``, not
    flushed to standard output after the JSON when the process exits."""
    (d / "loud.py").write_text(FORTRAN_PRINT)
    with open(d / "out.json", "w") as out:   # a file: the runtime holds its line (a
        p = subprocess.run([sys.executable, d / "loud.py"], stdout=out,   # pipe's it writes)
                           stderr=subprocess.PIPE, text=True, timeout=120)
    text = (d / "out.json").read_text()
    try:
        json.loads(text)
    except ValueError:
        return f"stdout is not JSON alone (exit {p.returncode}): ...{text[-200:]!r}"
    return None if p.returncode == 0 and "XXX Singular basis" in p.stderr else \
        f"exit {p.returncode}; the message not on stderr: {p.stderr[-300:]!r}"


#: after the command's last line: how long to wait before the signal (s)
TEARDOWN_DELAYS = (0.0, 0.02, 0.05, 0.1, 0.3, 0.6, 1.0, 1.6)


def a_signal_in_the_teardown_gets_its_line(d: Path):
    """SIGTERM at 8 moments after ``bplir params plant``'s output: either
    the process has already ended (exit 0, nothing on stderr) or it says
    one line and exits 143 (that the outputs are complete, or, where the
    signal came as the command was returning, that it was stopped); never
    a silent death by the signal."""
    for delay in TEARDOWN_DELAYS:
        p = subprocess.Popen([sys.executable, "-m", "bplir_drake.cli", "params", "plant"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        line = p.stdout.readline()
        while line and not line.startswith("plant.g "):   # the table's last row
            line = p.stdout.readline()
        time.sleep(delay)
        p.send_signal(signal.SIGTERM)
        _, err = p.communicate(timeout=60)
        said = ("bplir: SIGTERM after the command had finished; its outputs are complete\n",
                "bplir: terminated by SIGTERM; no output file was left half-written\n")
        if not ((p.returncode == 0 and err == "") or (p.returncode == 143 and err in said)):
            return f"{delay} s after the output: exit {p.returncode}, stderr {err[-200:]!r}"
    return None


def _group_gone(pgid: int, limit: float = 15.0) -> bool:
    """True once no process of the process group ``pgid`` is left."""
    end = time.monotonic() + limit
    while time.monotonic() < end:
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.1)
    return False


#: how long after ``montecarlo --dask`` starts its signal comes (s): while the
#: local cluster starts, on this machine about 1.2-1.8 s in
CLUSTER_START_DELAYS = (1.2, 1.5, 1.8)


def a_signal_while_a_dask_cluster_starts_is_one_line(d: Path):
    """SIGTERM (to the process) or Ctrl-C (to its group) while the local
    Dask cluster of ``montecarlo --dask`` starts: the one line, no Dask
    traceback from its exit handler, and no worker process left."""
    for k, delay in enumerate(CLUSTER_START_DELAYS):
        sig = signal.SIGINT if k == 1 else signal.SIGTERM
        p = subprocess.Popen([sys.executable, "-m", "bplir_drake.cli", "montecarlo", "-n", "4",
                              "--dask", "--workers", "2", "--no-plots", "--out", d / f"mc{k}"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             start_new_session=True,
                             preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        time.sleep(delay)
        if sig == signal.SIGINT:
            os.killpg(p.pid, sig)
        else:
            p.send_signal(sig)
        _, err = p.communicate(timeout=120)
        lines = said(err)
        ended = p.returncode == 0 and not lines   # finished before the signal
        stopped = p.returncode == 128 + sig and len(lines) == 1 and \
            lines[0].startswith(("bplir: terminated by SIGTERM", "bplir: interrupted"))
        if not (ended or stopped):
            return f"{sig.name} {delay} s in: exit {p.returncode}, {len(lines)} lines: " \
                   f"{err[-300:]!r}"
        if not _group_gone(p.pid):
            return f"{sig.name} {delay} s in: a worker process is left"
    return None


def _no_solving():
    """Make commissioning's plan solving fail loudly (a check that the
    command refused before it solved)."""
    from bplir_drake.analysis.commission import commissioning

    def solving(*a, **k):
        raise RuntimeError("the commission began solving plans")
    commissioning.solve_library = solving


def _first_robots_out(d: Path) -> Path:
    """An --out holding a first robot's commission: its robot.toml and
    its gripper-1 study at 0 deg (a robot with l2 = 0.6 m)."""
    from bplir_drake.analysis.commission.verdict import DEFAULT_SAMPLES, verification_study
    from bplir_drake.analysis.montecarlo.study import save_study
    from bplir_drake.params import Manoeuvre, derive, preset

    first_robot = preset()
    first_robot = first_robot.with_(plant=first_robot.plant.__class__(
        **(first_robot.plant.as_dict() | {"l2": 0.6})))
    out = d / "first"
    study = verification_study(derive(first_robot, Manoeuvre(gripper=1)), 0.0,
                               DEFAULT_SAMPLES, 1, (1.14, 1.2, 1.26))
    where = out / "studies" / "gripper1_incline_+00.0"   # gripper 1's swing at 0 deg
    where.mkdir(parents=True)
    save_study(study, where / "study.toml")
    (out / "robot.toml").write_text("# the first robot\n")
    return out


#: the default robot's commission file
BPLIR = Path(__file__).resolve().parents[1] / "examples" / "commission" / "bplir.toml"


def commission_workers_are_ranged(d: Path):
    """``commission --workers`` -1 or 100000: one line naming [1, 256], exit 2."""
    for workers in ("-1", "100000"):
        rc, _, err = bplir("commission", BPLIR, "--workers", workers, "--out", d / "w",
                           before=_no_solving)
        problem = one_error_line(rc, err, 2, "--workers", "[1, 256]")
        if problem:
            return f"--workers {workers}: {problem}"
    return None


def a_commission_naming_a_missing_plugin_is_refused_at_once(d: Path):
    """A robot file whose controller plug-in does not exist: refused with one
    line naming it before a plan is solved, its --out not made."""
    (d / "plug.toml").write_text('[robot]\nfile = "bplir"\n'
                                 f'[controller]\nplugin = "{d / "missing.py"}:make"\n')
    rc, _, err = bplir("commission", d / "plug.toml", "--out", d / "p", before=_no_solving)
    problem = one_error_line(rc, err, 2, "missing.py")
    return problem or ("its --out was written" if (d / "p").exists() else None)


def a_commission_refuses_before_it_writes(d: Path):
    """An --out holding another robot's studies (with or without an
    unreachable --scheduler), or a link at its studies/: refused with one
    line before a plan is solved, the first robot's robot.toml untouched;
    an unreachable --scheduler into a new --out leaves no robot.toml."""
    out = _first_robots_out(d)
    for extra in ([], ["--scheduler", "tcp://127.0.0.1:9"]):
        rc, _, err = bplir("commission", BPLIR, "--out", out, *extra, before=_no_solving)
        problem = one_error_line(rc, err, 2, "holds results of a different study")
        if problem or (out / "robot.toml").read_text() != "# the first robot\n":
            return f"{extra}: {problem or 'robot.toml replaced'}"
    (d / "elsewhere").mkdir()
    (d / "linked").mkdir()
    (d / "linked" / "studies").symlink_to(d / "elsewhere")
    rc, _, err = bplir("commission", BPLIR, "--out", d / "linked", before=_no_solving)
    problem = one_error_line(rc, err, 2, "is a symbolic link")
    if problem:
        return f"a link at studies/: {problem}"
    rc, _, err = bplir("commission", BPLIR, "--out", d / "s", "--scheduler",
                       "tcp://127.0.0.1:9", timeout=120, before=_quick_scheduler_timeout)
    problem = one_error_line(rc, err, 2, "cannot reach the Dask scheduler")
    return f"--scheduler: {problem}" if problem else \
        ("--scheduler: robot.toml written" if (d / "s" / "robot.toml").exists() else None)




def _quick_scheduler_timeout():
    """Give up on an unreachable Dask scheduler after 1 s, not 10 s
    (nothing listens on port 9: the wait only idles a test worker)."""
    from bplir_drake.analysis.montecarlo import executors

    executors.SCHEDULER_TIMEOUT = 1.0


def _slow_plans():
    """Make every plan solve take a minute (a solver at work), each solve
    leaving a ``solving-PID`` file in the cache directory as it starts."""
    from bplir_drake.planning import solve as P

    def slow(*a, **k):
        Path(os.environ["BPLIR_CACHE_DIR"], f"solving-{os.getpid()}").touch()
        time.sleep(60)
        raise RuntimeError("the slow solve was not stopped")
    P._solve_plan = slow


def a_sigterm_in_the_commissions_plan_pool_is_one_line(d: Path):
    """SIGTERM while two worker processes solve a commission's plans: the
    stop's one line (no chained tracebacks of the workers), exit 143, and
    no worker left."""
    import tempfile as _tempfile

    from forked import start_forked

    cache = _tempfile.mkdtemp(dir=d)
    proc = start_forked("commission", BPLIR, "--workers", "2", "--no-hanging", "--out",
                        d / "c", env={"BPLIR_CACHE_DIR": cache}, before=_slow_plans,
                        new_session=True)
    end = time.monotonic() + 60
    while len(list(Path(cache).glob("solving-*"))) < 2 and time.monotonic() < end:
        time.sleep(0.1)   # until both workers solve
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(60)
    lines = said(err)
    if proc.returncode != 143 or len(lines) != 1 or "Traceback" in err \
            or not lines[0].startswith("bplir: terminated by SIGTERM"):
        return f"exit {proc.returncode}, {len(lines)} lines: {err[-400:]!r}"
    return None if _group_gone(proc.pid) else "a plan worker is left"


#: every check, by what it guards
CHECKS = {f.__name__: f for f in (
    fortran_output_stays_off_json_stdout,
    a_signal_in_the_teardown_gets_its_line,
    a_signal_while_a_dask_cluster_starts_is_one_line,
    commission_workers_are_ranged,
    a_commission_naming_a_missing_plugin_is_refused_at_once,
    a_commission_refuses_before_it_writes,
    a_sigterm_in_the_commissions_plan_pool_is_one_line,
)}
