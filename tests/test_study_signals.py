"""A signal that arrives while a sample's plan is solved ends the study."""
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
