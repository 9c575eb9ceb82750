"""Fuzzing what a run reads back from its own earlier runs: a finished
study's ``results.csv`` edited by hand, and a cached plan edited or cut.
A resumed study ends in its result (every damaged row reported in one
note and run again, so the table is the unedited one) or in one ``bplir:
error:`` line (exit 2); a damaged plan is moved aside, named and solved
again -- never used, never a traceback."""
import contextlib
import csv
import io
import json
import shutil
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bplir_drake import cli
from bplir_drake.analysis.montecarlo import runner

FUZZ = settings(max_examples=200, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])


# --------------------------------------------------------- a study resumed
@pytest.fixture(scope="module")
def finished_study(tmp_path_factory):
    """A finished 3-swing study directory and its results table's rows."""
    out = tmp_path_factory.mktemp("study") / "mc"
    with contextlib.redirect_stdout(io.StringIO()):
        assert cli.main(["montecarlo", "-n", "3", "--workers", "1", "--no-plots",
                         "--out", str(out)]) == 0
    return out, list(csv.reader((out / "results.csv").open(newline="")))


#: values that no cell of their kind can hold
BAD = {"figure": ["abc", "1e300", "-1e300", "inf", "-inf", "1,5", "0x10"],
       "flag": ["maybe", "", "1", "True", "yes"],
       "outcome": ["nonsense", "", "CAPTURED", "swinging"],
       "drawn": ["abc", "", "inf", "1e300", "-7"],
       "index": ["x", "1.5", ""],
       "seed": ["abc", "", "1.5"]}


def _kind(column: str) -> str:
    if column in ("index", "seed", "outcome"):
        return column
    if column in ("success", "fixed_gripper_open"):
        return "flag"
    return "drawn" if "." in column else "figure"


@st.composite
def damaged_tables(draw, header_and_rows):
    """The study's rows with one to three of them damaged: a cell given a
    value its kind cannot hold, the row cut short or given a cell more, a
    line of garbage in its place; (rows, the damaged sample indices)."""
    header, *rows = header_and_rows
    rows = [list(r) for r in rows]
    damaged = draw(st.sets(st.integers(0, len(rows) - 1), min_size=1, max_size=len(rows)))
    for k in damaged:
        how = draw(st.sampled_from(["cell", "cell", "cell", "short", "long", "garbage"]))
        if how == "cell":
            col = draw(st.sampled_from([c for c in header if c not in ("error",)]))
            bad = [v for v in BAD[_kind(col)] if v != rows[k][header.index(col)]]
            rows[k][header.index(col)] = draw(st.sampled_from(bad))
        elif how == "short":
            rows[k] = rows[k][:draw(st.integers(0, len(header) - 1))]
        elif how == "long":
            rows[k] = rows[k] + ["1.0"] * draw(st.integers(1, 3))
        else:
            rows[k] = [draw(st.text(st.characters(codec="utf-8", exclude_characters="\r\n\x00"),
                                    min_size=1, max_size=30))]
    return [header] + rows, damaged


@FUZZ
@given(data=st.data())
def test_a_resumed_table_is_the_unedited_one_or_one_error_line(finished_study, data,
                                                               tmp_path, monkeypatch):
    """A damaged table resumed (the samples run again stand in as their
    original rows): exit 0 with one note counting the damaged rows and the
    unedited table back, or exit 2 with one error line; never a traceback."""
    source, table = finished_study
    rows, damaged = data.draw(damaged_tables(table))
    out = Path(tempfile.mkdtemp(dir=tmp_path)) / "mc"   # one an example
    shutil.copytree(source, out)
    with (out / "results.csv").open("w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    header, by_index = table[0], {int(r[0]): r for r in table[1:]}

    def rerun(fn, args, **kw):   # the samples run again: their original rows
        from bplir_drake.analysis.montecarlo.store import _parse
        from bplir_drake.analysis.montecarlo.study import StudyRow

        for _, k in args:
            yield StudyRow({c: _parse(c, v) for c, v in zip(header, by_index[k])})
    monkeypatch.setattr(runner, "map_jobs", rerun)
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err), \
            warnings.catch_warnings():
        warnings.simplefilter("default")
        rc = cli.main(["montecarlo", "-n", "3", "--workers", "1", "--no-plots",
                       "--out", str(out)])
    lines = err.getvalue().splitlines()
    assert "Traceback" not in err.getvalue()
    if rc == 2:
        assert len([x for x in lines if x.startswith("bplir: error:")]) == 1
        return
    assert rc == 0, err.getvalue()
    notes = [x for x in lines if "damaged row" in x]
    assert len(notes) == 1 and f"{len(damaged)} damaged row" in notes[0], lines
    assert list(csv.reader((out / "results.csv").open(newline=""))) == table


# ------------------------------------------------------------ a plan cached
def _inputs_and_plan():
    """The planner's inputs and a stand-in plan for them, as plan_swing
    makes both (the stand-in solver of conftest)."""
    from conftest import quick_plan

    from bplir_drake.params import BplirParams
    from bplir_drake.planning import solve as P

    captured = {}

    def solve_plan(*a, **k):
        captured["plan"] = quick_plan(*a, **k)
        return captured["plan"]

    def cached(inputs, solve, **kw):
        captured["inputs"] = inputs
        return solve()
    with pytest.MonkeyPatch.context() as m:
        m.setattr(P, "_solve_plan", solve_plan)
        m.setattr(P, "cached", cached)
        P.plan_swing(BplirParams())
    return captured["inputs"], captured["plan"]


INPUTS, GOOD = _inputs_and_plan()

def _nan(a):
    out = np.array(a, dtype=float)
    out.flat[1] = np.nan
    return out


#: edits that make each array of the stand-in plan (5 samples over 1 s, at
#: rest at the start pose, no torque) wrong
ARRAY_EDITS = {
    "times": {"x 1e-300": lambda a: a * 1e-300, "x 1e6": lambda a: a * 1e6,
              "negated": lambda a: -a, "from 5 s": lambda a: a + 5.0, "NaN": _nan,
              "reversed": lambda a: a[::-1].copy(), "shortened": lambda a: a[:-1],
              "a 2-d array": lambda a: np.c_[a, a]},
    "states": {"x 1e300": lambda a: a * 1e300, "x 7": lambda a: a * 7.0,
               "shifted": lambda a: a + 0.01, "NaN": _nan, "shortened": lambda a: a[:-1],
               "three columns": lambda a: a[:, :3]},
    "torque": {"beyond its limit": lambda a: a + 30.0, "NaN": _nan,
               "shortened": lambda a: a[:-1], "huge": lambda a: a + 1e300},
    "friction": {"NaN": _nan, "one column": lambda a: a[:, :1]},
}
#: values of another type or range than a meta field holds
META_VALUES = ["no", 1, None, float("nan"), -1.0, 1e300, "1", True, [], {}]


@st.composite
def damaged_plans(draw):
    """The stand-in plan's file fields with one of them made wrong (an
    array by one of :data:`ARRAY_EDITS`; a meta field given a value of
    another type or range, or another key's), or None for a file whose
    bytes are cut short."""
    import dataclasses as dc

    fields = dc.asdict(GOOD)
    arrays = {k: v for k, v in fields.items() if isinstance(v, np.ndarray)}
    meta = {k: v for k, v in fields.items() if not isinstance(v, np.ndarray)}
    how = draw(st.sampled_from(["array", "meta", "cut"]))
    if how == "cut":
        return None
    if how == "array":
        name = draw(st.sampled_from(sorted(ARRAY_EDITS)))
        edit = draw(st.sampled_from(sorted(ARRAY_EDITS[name])))
        arrays[name] = ARRAY_EDITS[name][edit](arrays[name])
        return arrays, meta
    name = draw(st.sampled_from(sorted(meta)))
    if isinstance(meta[name], str):   # a word: any other word is a word
        wrong = [v for v in META_VALUES if not isinstance(v, str)]
    elif isinstance(meta[name], bool):
        wrong = [v for v in META_VALUES if not isinstance(v, bool)]
    else:   # a number: another type, or another value (another key's)
        wrong = [v for v in META_VALUES if v != meta[name]]
        wrong.append(meta[name] * 2 + 1.0)
    meta[name] = draw(st.sampled_from(wrong))
    return arrays, meta


@FUZZ
@given(damage=damaged_plans())
def test_a_damaged_cached_plan_is_moved_aside_and_solved_again(damage, tmp_path, monkeypatch):
    """Any one wrong field of a cached plan (or its file cut short): the
    plan is solved again (a note names the file, moved aside), never used."""
    from bplir_drake.planning.cache import cached
    from bplir_drake.planning.swing_plan import SwingPlan, planned_for

    cache = Path(tempfile.mkdtemp(dir=tmp_path))   # one an example
    monkeypatch.setenv("BPLIR_CACHE_DIR", str(cache))
    resolved = []

    def solve():
        resolved.append(1)
        return GOOD
    cached(INPUTS, solve, make=SwingPlan, fits=lambda p: planned_for(p, INPUTS))
    [path] = cache.glob("plan-*.npz")
    if damage is None:
        path.write_bytes(path.read_bytes()[:len(path.read_bytes()) // 2])
    else:
        arrays, meta = damage
        with open(path, "wb") as fh:
            np.savez(fh, meta=json.dumps(meta), **arrays)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        plan = cached(INPUTS, solve, make=SwingPlan, fits=lambda p: planned_for(p, INPUTS))
    assert len(resolved) == 2, "the damaged plan was used"
    assert plan is GOOD and path.with_suffix(".damaged").exists()
    assert any(f"the cached plan file {path} is damaged" in str(w.message) for w in said)
