"""Commissioning is a pure function of its inputs: the same robot, options
and seed give the same plans, studies and verdict whether run once from an
empty cache, run again over its finished --out, or stopped at any of three
moments and resumed."""
import json
from pathlib import Path

import pytest

from bplir_drake.analysis.commission import commission, commissioning
from bplir_drake.analysis.montecarlo import runner
from bplir_drake.params import load_toml

ROOT = Path(__file__).resolve().parents[1]
#: the 0.7-scaled BPLIR with its pivot's viscous friction changed: a robot
#: whose plans the package does not ship (its plans are the stand-in solver's)
ROBOT = ROOT / "examples" / "scaled_bplir.toml"


class Stop(KeyboardInterrupt):
    """A Ctrl-C at a chosen moment."""


def _robot():
    import dataclasses as dc

    p = load_toml(ROBOT)
    return p.with_(friction=dc.replace(p.friction, fv1=0.04))


def _commission(out: Path):
    return commission(_robot(), spacings=[0.84], samples=2, seed=2, workers=1,
                      grippers=(1,), pumps=False, out=out)


@pytest.fixture
def counted_solves(monkeypatch):
    """The plan solver is the stand-in (a 1 s plan at rest at its start,
    :func:`conftest.quick_plan`); the list counts its solves."""
    from conftest import quick_plan

    from bplir_drake.planning import solve as P

    solves = []

    def solver(*a, **k):
        solves.append(1)
        return quick_plan(*a, **k)
    monkeypatch.setattr(P, "_solve_plan", solver)
    return solves


def _without_wall(obj):
    """``obj`` without its wall-clock times (the one thing that may differ)."""
    if isinstance(obj, dict):
        return {k: _without_wall(v) for k, v in obj.items()
                if not k.startswith("wall") and k != "run"}
    if isinstance(obj, list):
        return [_without_wall(v) for v in obj]
    return obj


def _outputs(out: Path) -> dict:
    """What a commission leaves in ``out`` that must not change: its JSON but
    the wall times, every study's table and summary, the libraries' bytes."""
    found = {"commission.json": _without_wall(json.loads((out / "commission.json").read_text()))}
    for f in sorted((out / "studies").rglob("results.csv")):
        found[str(f.relative_to(out))] = f.read_text()
    for f in sorted((out / "studies").rglob("summary.json")):
        found[str(f.relative_to(out))] = _without_wall(json.loads(f.read_text()))
    for f in sorted((out / "plans").glob("*.npz")):
        found[str(f.relative_to(out))] = f.read_bytes()
    return found


def _stop_after(monkeypatch, owner, name, calls: int = 1):
    """Make ``owner.name`` raise :class:`Stop` once it has returned ``calls`` times."""
    original, done = getattr(owner, name), []

    def stopping(*a, **k):
        result = original(*a, **k)
        done.append(1)
        if len(done) >= calls:
            raise Stop
        return result
    monkeypatch.setattr(owner, name, stopping)


#: the three moments: the first library solved; a study's first row written;
#: everything computed, the report not yet written
MOMENTS = {"after the first library": (commissioning, "solve_library"),
           "after a study's first row": (runner.ResultWriter, "write"),
           "before the report": (commissioning, "write_report")}


@pytest.mark.slow
def test_a_commission_is_the_same_run_once_again_or_resumed(tmp_path, monkeypatch,
                                                           counted_solves):
    """From an empty cache twice, over a finished --out (solving nothing
    again), and stopped at each of :data:`MOMENTS` then resumed: identical
    commission.json (but its wall times), study tables and summaries, and
    library files byte for byte."""
    runs = {}
    for name in ("once", "again"):
        monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path / f"cache-{name}"))
        _commission(tmp_path / name)
        runs[name] = _outputs(tmp_path / name)
    solved = len(counted_solves)
    assert solved == 4   # each run: the plan from the line and the try from hanging
    _commission(tmp_path / "again")   # over its own finished --out, its cache warm
    assert len(counted_solves) == solved, "a finished commission solved its plans again"
    runs["over a finished --out"] = _outputs(tmp_path / "again")
    monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path / "cache-stopped"))
    for moment, (owner, name) in MOMENTS.items():
        with monkeypatch.context() as m:
            _stop_after(m, owner, name)
            with pytest.raises(Stop):
                _commission(tmp_path / "stopped")
    result = _commission(tmp_path / "stopped")
    runs["stopped three times"] = _outputs(tmp_path / "stopped")
    reference = runs.pop("once")
    assert len(reference) == 5   # the JSON, a study's table and summary, 2 libraries
    for name, found in runs.items():
        assert found.keys() == reference.keys(), name
        for key in reference:
            assert found[key] == reference[key], f"{name}: {key} differs"
    assert result.summary()["plans"]["solved"] == 2
    assert result.studies[0]["samples"] == 2
