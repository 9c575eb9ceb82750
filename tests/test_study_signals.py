"""A signal that arrives while a plan is solved ends the study or the command."""
import signal

import pytest

from bplir_drake import io
from bplir_drake.analysis import montecarlo as mc
from bplir_drake.analysis.montecarlo import sampling
from bplir_drake.cli.common import Terminated, _terminate


class _SolverWrapsTheStop:
    """A swing runner whose 'plan solve' takes a SIGTERM in a Python
    callback, which the solver (SNOPT through Drake) re-raises as its own
    RuntimeError naming it."""

    def run(self, params, **kw):
        try:
            _terminate(signal.SIGTERM, None)
        except Terminated as exc:
            raise RuntimeError("Exception while evaluating SNOPT costs and constraints: "
                               f"'Terminated: {exc.signum}'") from None


class _SolverFails:
    def run(self, params, **kw):
        raise RuntimeError("Exception while evaluating SNOPT costs and constraints")


def test_a_stop_wrapped_by_the_solver_ends_the_study_instead_of_an_error_row(monkeypatch):
    """The SIGTERM handled inside the solve comes back out of ``run_sample``
    as the stop it was (the command then keeps the finished rows and ends),
    not as the sample's error row with the study going on; once the command
    has ended (``forget_stop``), a solver's own failure is an error row."""
    study = mc.Study(samples=2, seed=0)
    monkeypatch.setattr(sampling, "_RUNNER", _SolverWrapsTheStop())
    try:
        with pytest.raises(Terminated):
            sampling.run_sample(study, 0)
    finally:
        io.forget_stop()
    monkeypatch.setattr(sampling, "_RUNNER", _SolverFails())
    row = sampling.run_sample(study, 1)
    assert row["error"].startswith("RuntimeError: Exception while evaluating SNOPT")


def test_a_stop_wrapped_by_the_solver_ends_a_command_with_the_signals_status(monkeypatch,
                                                                             capsys):
    """``bplir plan`` (any command but a study) whose solve takes a SIGTERM:
    the solver's RuntimeError is the stop it wraps, so the command ends with
    143 and the signal's one line, not as a fault inside (exit 1); the next
    command's own solver failure is a fault again."""
    import argparse
    import sys

    from bplir_drake.cli import main

    def command(func):
        parsed = argparse.Namespace(func=func, command="plan", debug=False, json=False)
        return type("Parser", (), {"parse_args": lambda self, argv: parsed})()

    mod = sys.modules["bplir_drake.cli.main"]
    monkeypatch.setattr(mod, "build_parser", lambda: command(
        lambda args: _SolverWrapsTheStop().run(None)))
    assert main(["plan"]) == 128 + signal.SIGTERM
    assert capsys.readouterr().err == ("bplir: terminated by SIGTERM; no output file was "
                                       "left half-written\n")
    monkeypatch.setattr(mod, "build_parser", lambda: command(
        lambda args: _SolverFails().run(None)))
    assert main(["plan"]) == 1
    assert capsys.readouterr().err.startswith("bplir: error: plan failed: RuntimeError: ")
