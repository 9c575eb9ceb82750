"""The third hardening round: each class the probe found broken
(``tests/hardening_probe.py``, which also runs them all as a script) as a
test, each through the console entry point in a process of its own where
the class is about a process; and every writer of an output interrupted
half-way: the old file or none is left, never a partial one."""
import json
import signal
import subprocess
import sys

import numpy as np
import pytest

import hardening_probe as probe


@pytest.mark.parametrize("k", sorted(probe.CLASSES))
def test_the_probes_class_holds(k, tmp_path):
    """Class k of the probe: one line and the right exit status (2 bad
    input, 1 a fault, 128 + the signal), files whole, no worker left."""
    problem = probe.CLASSES[k](tmp_path)
    assert problem is None, problem


# ------------------------------------------------------- writers interrupted
class Cut(KeyboardInterrupt):
    """Ctrl-C arriving half-way through a write."""


def _cut_after_half(write):
    """``write(target, data)`` (a path's ``write_text``) that writes half of
    what it is given and is then interrupted."""
    def half(self, data, *a, **k):
        write(self, data[:max(1, len(data) // 2)], *a, **k)
        raise Cut
    return half


def _cut_producer(produce):
    """``produce(obj, target, ...)`` (``np.savez``, ``Figure.savefig``) that
    writes half of its bytes to ``target`` (a path or a binary file) and
    is then interrupted."""
    def half(*a, **k):
        import io as _io

        buf = _io.BytesIO()
        a = list(a)
        target_at = 1 if hasattr(a[0], "savefig") else 0
        target, a[target_at] = a[target_at], buf
        produce(*a, **k)
        data = buf.getvalue()[:len(buf.getvalue()) // 2]
        if hasattr(target, "write"):
            target.write(data)
            target.flush()
        else:
            with open(target, "wb") as fh:
                fh.write(data)
        raise Cut
    return half


def _writers(tmp_path):
    """(kind, path, write(path), (owner, name) of the function to cut) of
    every kind of writer: text, JSON, binary (a plan's .npz), a figure."""
    from pathlib import Path

    from matplotlib.figure import Figure

    from bplir_drake import io
    from bplir_drake.planning.cache import _write_npz
    from bplir_drake.plotting import save_figure

    def figure():
        fig = Figure()
        fig.add_subplot().plot([0, 1], [0, 1])
        return fig

    return {
        "text": (tmp_path / "a.md", lambda p: io.write_text_atomic(p, "new text " * 5000),
                 (Path, "write_text", _cut_after_half)),
        "json": (tmp_path / "a.json", lambda p: io.write_json_atomic(p, {"x": list(range(5000))}),
                 (Path, "write_text", _cut_after_half)),
        "binary": (tmp_path / "a.npz", lambda p: _write_npz(p, {"x": np.arange(50000.0)}),
                   (np, "savez", _cut_producer)),
        "figure": (tmp_path / "a.png", lambda p: save_figure(figure(), p),
                   (Figure, "savefig", _cut_producer)),
    }


@pytest.mark.parametrize("kind", ["text", "json", "binary", "figure"])
def test_an_interrupted_writer_leaves_the_old_file_whole(kind, tmp_path, monkeypatch):
    """Every output goes through the atomic writer: a write interrupted
    half-way (Ctrl-C) leaves the old file as it was and no temporary file
    beside it.  A writer that wrote in place would leave half a file here
    (``io.write_text_atomic`` replaced by a plain write fails this test)."""
    path, write, (owner, name, cut) = _writers(tmp_path)[kind]
    old = b"the finished run's file\n"
    path.write_bytes(old)
    monkeypatch.setattr(owner, name, cut(getattr(owner, name)))
    with pytest.raises(Cut):
        write(path)
    monkeypatch.undo()
    assert path.read_bytes() == old
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]


class _HalfFile:
    """A text file whose next write is cut half-way by an interruption."""

    def __init__(self, fh):
        self.fh = fh

    def write(self, text):
        self.fh.write(text[:len(text) // 2])
        self.fh.flush()
        raise Cut


def test_an_interrupted_row_is_dropped_and_the_finished_rows_kept(tmp_path):
    """A study's results table: a row cut half-way by an interruption is
    left out when the study is read back (and rewritten) on resume; the
    rows finished before it are kept."""
    import csv

    from bplir_drake.analysis.montecarlo.store import ResultWriter, read_results

    cols = ["index", "seed", "outcome", "error"]
    path = tmp_path / "results.csv"
    writer = ResultWriter(path, cols, [])
    writer.write({"index": 0, "seed": 7, "outcome": "captured", "error": ""})
    writer._w = csv.writer(_HalfFile(writer._fh))
    with pytest.raises(Cut):
        writer.write({"index": 1, "seed": 8, "outcome": "captured", "error": ""})
    writer.close()
    assert path.read_text().count("\n") == 2 and not path.read_text().endswith("\n")
    rows = read_results(path, cols)
    assert [r["index"] for r in rows] == [0]
    ResultWriter(path, cols, rows).close()   # the resumed study rewrites the whole rows
    assert path.read_text() == "index,seed,outcome,error\n0,7,captured,\n"


# ------------------------------------------------------- the smaller items
def test_a_solvers_output_on_descriptor_1_stays_off_json_stdout(tmp_path):
    """Under --json a message written straight to file descriptor 1 (SNOPT's
    'XXX Singular basis' from C++, a plug-in's os.write) goes to standard
    error: standard output is the JSON result alone."""
    spec = probe.plugin(tmp_path, "loud.py", "pass",
                        factory="os.write(1, b'XXX Singular basis\\n'); print('hello')")
    rc, out, err = probe.bplir("swing", "--controller", spec, "--no-animation", "--no-plots",
                               "--json", "--out", tmp_path / "s")
    assert rc == 0, err
    assert json.loads(out)["outcome"] in ("timeout", "crashed", "captured", "fell")
    assert "XXX Singular basis" in err and "hello" in err


def test_a_signal_while_the_finished_command_exits_is_one_line(tmp_path):
    """SIGTERM in the interpreter's teardown after the console's command has
    finished: one line saying the outputs are complete and exit 143, not a
    silent death by the signal (-15)."""
    code = ("import os, signal, sys, time\n"
            "sys.argv = ['bplir', 'params', 'plant']\n"
            "from bplir_drake.cli import main\n"
            "main()\n"
            "os.kill(os.getpid(), signal.SIGTERM)\n"
            "time.sleep(5)\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert p.returncode == 128 + signal.SIGTERM
    assert p.stderr == "bplir: SIGTERM after the command had finished; its outputs are complete\n"


@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_a_plugin_argument_must_be_finite(value):
    """``--controller-arg k=nan`` is refused (it would reach the factory as NaN)."""
    from bplir_drake.params import ParameterError, plugin_arguments

    with pytest.raises(ParameterError, match="is not a finite number"):
        plugin_arguments([f"k={value}"])
    assert plugin_arguments(["k=2.5", "n=3", "on=true", "name=abc"]) == {
        "k": 2.5, "n": 3, "on": True, "name": "abc"}


def test_a_calibration_says_how_many_simulations_it_may_take(tmp_path, capsys):
    """``calibrate`` with its progress shown names the most simulations the
    fit may run and the time they take (from the first simulation)."""
    from bplir_drake.analysis.identification.calibration import read_calibration_csv
    from bplir_drake.analysis.identification.fit import MAX_FIT_STEPS, calibrate
    from bplir_drake.params import BplirParams

    p = BplirParams()
    log = read_calibration_csv(probe.angle_log(tmp_path, "log.csv"), p.motor.torque_per_amp,
                               min_duration=0.2)
    res = calibrate(p, log, ("fv1",), progress=True)
    err = capsys.readouterr().err
    assert f"at most {MAX_FIT_STEPS * 2} simulations of" in err
    assert res.nfev <= MAX_FIT_STEPS * 2
