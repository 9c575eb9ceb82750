import matplotlib

matplotlib.use("Agg", force=True)

import dataclasses as dc
import json

import pytest

from bplir_drake.params import preset
from bplir_drake.params import with_hardware


@pytest.fixture(scope="session")
def params():
    return preset("dissertation")


def paced_48v(p):
    """``p`` at 48 V with its tries from hanging planned by guesses within
    85 % of the torque limit, on a pump whose torque alone uses at most 35 %
    of the driver's i^2 t budget where a guess gives one
    (hanging.torque_share, hanging.i2t_share; the shipped plans of
    the tests of those mechanisms are made so)."""
    p = with_hardware(p, "48v")
    return p.with_(hanging=dc.replace(p.hanging, torque_share=0.85, i2t_share=0.35))


def parse_strict_json(text):
    """JSON that a parser rejecting NaN and Infinity accepts (hardening item 9)."""
    def reject(const):
        raise ValueError(f"non-strict JSON constant {const}")
    return json.loads(text, parse_constant=reject)


@pytest.fixture
def strict_json():
    """The strict JSON parser (:func:`parse_strict_json`)."""
    return parse_strict_json


def plugin_source(fault: str, factory: str = "pass") -> str:
    """A plug-in controller's source: zero torque until 0.3 s, then the
    statement ``fault`` inside its calc (``os``, ``sys`` and ``time`` are
    imported); ``factory``: a statement its factory runs first."""
    return ("import os, sys, time\n"
            "from pydrake.systems.framework import LeafSystem\n"
            "class Odd(LeafSystem):\n"
            "    def __init__(self):\n"
            "        super().__init__()\n"
            "        self.DeclareVectorInputPort('state', 4)\n"
            "        self.DeclareVectorOutputPort('torque', 1, self.calc)\n"
            "    def calc(self, context, out):\n"
            "        if context.get_time() > 0.3:\n"
            f"            {fault}\n"
            "        out.SetAtIndex(0, 0.0)\n"
            "def make(params):\n"
            f"    {factory}\n"
            "    return Odd()\n")


# ------------------------------------------------- fuzzing the command line
class Reached(BaseException):
    """The command got past its checks to the work itself."""


def _stop(*args, **kwargs):
    raise Reached


@pytest.fixture
def stopped_work(monkeypatch, tmp_path):
    """Simulations, plan solves, QFT designs, studies and filters stop where they start;
    outputs land in a temporary directory."""
    from pydrake.systems.analysis import Simulator

    from bplir_drake import estimation
    from bplir_drake.analysis import montecarlo
    from bplir_drake.analysis.control import qft_report as report
    from bplir_drake.planning import solve as plan

    monkeypatch.setattr(Simulator, "AdvanceTo", _stop)
    monkeypatch.setattr(plan, "_solve_plan", _stop)
    monkeypatch.setattr(report, "qft_report", _stop)   # a QFT design simulates nothing
    monkeypatch.setattr(montecarlo, "run_study", _stop)
    monkeypatch.setattr(estimation, "estimate", _stop)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path / "cache"))


#: how a fuzzed command may end: a result (0), bad input (2), a fault inside
#: (1), or at the work itself, stopped (None)
ENDINGS = (None, 0, 1, 2)


def ends_cleanly(argv) -> int | None:
    """Run ``bplir ARGV`` in-process (under :func:`stopped_work`): it ends in
    a result (0), one ``bplir: error:`` line with exit 1 or 2, or reaches
    the work (None) -- never a traceback.  Returns the exit status."""
    import contextlib
    import io

    from bplir_drake import cli

    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            rc = cli.main([str(a) for a in argv])
    except Reached:
        return None
    except SystemExit as exc:   # argparse's own refusal (or --help)
        rc = exc.code
    text = err.getvalue()
    assert "Traceback" not in text, (argv, text)
    if rc not in (0, None):
        lines = [ln for ln in text.strip().splitlines() if not ln.startswith("bplir: note:")]
        assert rc == 2 or rc == 1, (argv, rc, text)
        assert len(lines) == 1 and lines[0].startswith("bplir: error: "), (argv, text)
    return rc


def quick_plan(params, q0, qT, tau_max, power, tmax, knots, time_weight, guess_duration,
               tolerance, *a, **k):
    """A stand-in for the plan solver (``planning.solve._solve_plan``): a 1 s
    plan at rest at the start pose, with the limits it was asked to keep, not
    SNOPT's minute."""
    import numpy as np

    from bplir_drake.planning.solve import SwingPlan
    from bplir_drake.planning.swing_plan import plan_envelope

    t = np.linspace(0.0, 1.0, 5)
    states = np.tile(np.r_[np.asarray(q0, dtype=float), 0.0, 0.0], (5, 1))
    env = plan_envelope(params)
    electric = {} if env is None else dict(
        voltage_limit=env["voltage"], voltage_share=env["share"],
        resistance=env["resistance"], emf_per_rate=env["emf_per_rate"],
        torque_per_amp=env["torque_per_amp"])
    return SwingPlan(t, states, np.zeros(5), np.zeros((5, 2)), True, True, "stub",
                     params.scenario.incline_deg, tau_max, power, tolerance, **electric)


def pytest_configure(config):
    """Before the workers start (in the controlling process, or in a run
    without workers): load or compile the chain's compiled kernels, so that
    on a fresh checkout every worker and every command the tests start loads
    them from the cache instead of each compiling its own.  The EKF's group
    is compiled here while a second process compiles the others."""
    if not hasattr(config, "workerinput"):
        import subprocess
        import sys

        _own_plan_cache(config)
        _one_copy_of_the_package()

        from bplir_drake.systems.kernels import warm_up

        others = subprocess.Popen([sys.executable, "-c", "from bplir_drake.systems.kernels "
                                   "import warm_up; warm_up('others')"])
        warm_up("filter")
        others.wait()
        warm_up()   # whatever the other process did not leave in the cache


def _own_plan_cache(config):
    """The run's plans and gains go to a cache of its own (``BPLIR_CACHE_DIR``,
    inherited by the workers and every command the tests start, removed at
    the end): a run reads the shipped plans and solves what they lack, as on
    a machine that never ran the package, whatever the user's cache holds."""
    import os
    import shutil
    import tempfile

    path = tempfile.mkdtemp(prefix="bplir-test-cache-")
    os.environ["BPLIR_CACHE_DIR"] = path
    config.add_cleanup(lambda: shutil.rmtree(path, ignore_errors=True))


def _one_copy_of_the_package():
    """Every process the tests start (a command, a study's workers, Dask's)
    imports the package the tests import (``PYTHONPATH``), so the compiled
    kernels loaded here serve them all: an installed copy elsewhere would
    compile its own on first use, in each process that got there first."""
    import os
    from pathlib import Path

    import bplir_drake

    root = str(Path(bplir_drake.__file__).resolve().parents[1])
    rest = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    os.environ["PYTHONPATH"] = os.pathsep.join([root, *rest])
