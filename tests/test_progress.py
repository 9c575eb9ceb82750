"""Progress on standard error (issue 19): the long computations count their
steps (SNOPT evaluations, calibration simulations, QFT generations, EKF
samples), the bars report the counts the results report, and the command
line shows them as bars on a terminal without ``--json`` and, elsewhere
(a log, a pipe), as plain lines once a command has run long, at least
every 20 s while a phase runs."""
import fcntl
import os
import pty
import re
import struct
import termios

import numpy as np
import pytest
from pathlib import Path

from bplir_drake.analysis.control.qft import QftSpecs, design_qft
from bplir_drake.analysis.control.plants import dissertation_family
from bplir_drake.analysis.identification.calibration import synthetic_log
from bplir_drake.analysis.identification.fit import calibrate
from bplir_drake.planning.solve import plan_swing
from bplir_drake.params import preset
from bplir_drake.progress import progress_bar
from forked import bplir_forked, start_forked

ROOT = Path(__file__).resolve().parents[1]


def _last_count(err: str, desc: str) -> int:
    """The last count a bar ``desc`` printed (tqdm redraws with \\r)."""
    counts = re.findall(re.escape(desc) + r":\s+(?:\d+%\|[^|]*\|\s*)?(\d+)", err)
    assert counts, err
    return int(counts[-1])


def test_qft_design_counts_generations(capsys):
    design_qft(dissertation_family(), QftSpecs(), maxiter=3, progress=True)
    err = capsys.readouterr().err
    assert _last_count(err, "QFT design") == 3 and "3/3" in err and "worst ratio" in err
    design_qft(dissertation_family(), QftSpecs(), maxiter=2)
    assert capsys.readouterr().err == ""  # silent by default


def test_bar_draws_its_final_count_before_clearing(capsys):
    """tqdm draws at most every 0.1 s; counts made faster than that must
    still end on the screen (a CI run once showed 6 of 7 simulations)."""
    with progress_bar(True, desc="steps", unit="steps") as bar:
        for _ in range(7):
            bar.update()
    assert _last_count(capsys.readouterr().err, "steps") == 7


def test_calibration_counts_its_simulations(capsys):
    p = preset()
    result = calibrate(p, synthetic_log(p, free_time=2.0), ("fv1",), progress=True)
    err = capsys.readouterr().err
    assert _last_count(err, "calibrate") == result.nfev > 1


def test_plan_counts_snopt_evaluations(capsys):
    plan_swing(preset(), knots=11, iterations=20, cache=False, progress=True)
    err = capsys.readouterr().err
    assert _last_count(err, "plan (SNOPT)") > 10


def _run_on_terminal(args, size=(24, 100)) -> tuple[int, str]:
    """Run ``bplir args`` with standard error on a pseudo-terminal of ``size``
    (lines, columns)."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", *size, 0, 0))
    proc = start_forked(*args, stdout=False, stderr=slave)
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 65536)
        except OSError:  # the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    return proc.wait(timeout=300), b"".join(chunks).decode(errors="replace")


def test_long_estimation_logs_count_their_samples(capsys, monkeypatch):
    import bplir_drake.estimation as E
    from bplir_drake.params import EstimatorParams

    assert E.PROGRESS_MIN_SAMPLES == 20_000  # logs this long show the EKF's progress
    monkeypatch.setattr(E, "PROGRESS_MIN_SAMPLES", 3_000)  # the same, 7x quicker
    n = 3_000
    t = np.arange(n) * 0.01
    samples = np.zeros((n, 6))
    samples[:, [3, 5]] = 9.81  # hanging still: each accelerometer reads gravity
    E.estimate(t, samples, EstimatorParams().chapter5(), progress=True)
    assert _last_count(capsys.readouterr().err, "estimate") == 3_000
    E.estimate(t[:2_999], samples[:2_999], EstimatorParams().chapter5(), progress=True)
    assert capsys.readouterr().err == ""  # a shorter log is quick: no bar


def test_cli_progress_only_on_a_terminal_without_json(tmp_path):
    mc = ["montecarlo", "-n", "1", "--workers", "1", "--no-plots"]
    code, err = _run_on_terminal(mc + ["--out", str(tmp_path / "a")])
    assert code == 0 and _last_count(err, "samples") == 1
    code, err = _run_on_terminal(mc + ["--out", str(tmp_path / "z")], size=(0, 0))
    assert code == 0 and _last_count(err, "samples") == 1   # a terminal of no size: 80 x 24
    code, err = _run_on_terminal(mc + ["--json", "--out", str(tmp_path / "b")])
    assert code == 0 and "samples:" not in err
    code, _, err = bplir_forked(*mc, "--out", tmp_path / "c")
    assert code == 0 and err == ""  # a pipe: lines, none in a short command's first 20 s


def _slow_solves():
    """Every plan solve takes 1.25 s (the stand-in solver, asleep)."""
    import time

    from conftest import quick_plan

    from bplir_drake.planning import solve as P

    def slow(*a, **k):
        time.sleep(1.25)
        return quick_plan(*a, **k)
    P._solve_plan = slow


#: lines every half second from the start (the tests' stand-ins for 20 s and 20 s)
LINES_NOW = {"BPLIR_PROGRESS_QUIET": "0", "BPLIR_PROGRESS_EVERY": "0.5"}


@pytest.mark.slow
@pytest.mark.parametrize("argv", [
    ["model", "--config", "{robot}", "--out", "{out}"],
    ["commission", "{robot}", "--gripper", "1", "--no-hanging", "--no-pump", "--samples", "2",
     "--out", "{out}"],
    ["traverse", str(ROOT / "examples" / "line_flat.toml"), "--config", "{robot}",
     "--no-animation", "--no-plots", "--out", "{out}"]])
def test_a_new_robots_commands_say_they_run_in_a_log(tmp_path, argv):
    """``model``, ``commission`` and ``traverse`` of a robot whose plans
    nobody solved, standard error a pipe: progress lines name the plan being
    solved and come at least every half second (the stand-in period) while it
    runs, from its beginning to its end."""
    (tmp_path / "new.toml").write_text('[robot]\nfile = "bplir"\n[plant]\nl2 = 1.1\n')
    args = [a.format(robot=tmp_path / "new.toml", out=tmp_path / "out") for a in argv]
    _, _, err = bplir_forked(*args, before=_slow_solves, timeout=300,
                             env=LINES_NOW | {"BPLIR_CACHE_DIR": tmp_path / "cache"})
    said = [x for x in err.splitlines() if x.startswith("bplir: progress: solving a plan")]
    kinds = [x.split(": ")[3].split(",")[0] for x in said]
    assert said and kinds[0] == "begins", err
    solves = kinds.count("begins")   # each solve: its beginning, its end, and between them
    assert kinds.count("done") == solves and kinds.count("running") >= solves, said
    assert all(int(re.search(r", (\d+) s", x).group(1)) <= 2 for x in said), said   # 1.25 s each
