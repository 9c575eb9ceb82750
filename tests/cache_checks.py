"""Adversarial checks of the plans the package reads (the fourth round of
misuse): a cached plan that is well-formed but wrong, a plan file whose rows
are too close, a plan library that is damaged in the user's cache.  Each
returns None when it holds, else what broke; ``test_misuse.py`` runs them."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from misuse_checks import bplir, one_error_line, quick_solver


def _plan(cache: Path, d: Path, incline: str, name: str):
    """``bplir plan --incline INCLINE --json`` on the stand-in solver:
    (status, its JSON or None, stderr)."""
    rc, out, err = quick_solver(cache, "plan", "--incline", incline, "--json", "--no-plots",
                                "--out", d / name)
    try:
        return rc, json.loads(out), err
    except ValueError:
        return rc, None, err


def _stored(path: Path) -> tuple[dict, dict]:
    """A cached plan file's arrays and meta."""
    with np.load(path) as data:
        arrays = {k: np.array(data[k]) for k in data.files if k != "meta"}
        return arrays, json.loads(str(data["meta"]))


def _store(path: Path, arrays: dict, meta: dict) -> None:
    with open(path, "wb") as fh:
        np.savez(fh, meta=json.dumps(meta), **arrays)


def wrong_plans(good: dict, meta: dict, other: tuple) -> dict:
    """What a user's cache may hold under a plan's key, well-formed but
    wrong: {what: (arrays, meta)}; ``other`` is another incline's plan."""
    shift = good["states"].copy()
    shift[:, 0] += 0.3
    return {
        "NaN torque": (good | {"torque": np.full_like(good["torque"], np.nan)}, meta),
        "times reversed": (good | {"times": good["times"][::-1].copy()}, meta),
        "short states": (good | {"states": good["states"][:2]}, meta),
        "times x 1e-300": (good | {"times": good["times"] * 1e-300}, meta),
        "times x 1e6": (good | {"times": good["times"] * 1e6}, meta),
        "times from 5 s": (good | {"times": good["times"] + 5.0}, meta),
        "states x 1e300": (good | {"states": good["states"] * 1e300 + 1.0,
                                   "torque": good["torque"] + 1.0}, meta),
        "an offset start": (good | {"states": shift}, meta),
        "feasible 'no'": (good, meta | {"feasible": "no"}),
        "a NaN torque limit": (good, meta | {"torque_limit": float("nan")}),
        "power beyond its limit": (good | {"torque": good["torque"] + 5.0,
                                           "states": good["states"] + [0, 0, 0, 100.0]},
                                   meta),
        "another incline's plan": other,
        "meta a list": (good, [1, 2]),
    }


def a_wrong_cached_plan_is_moved_aside(d: Path):
    """Each of :func:`wrong_plans` under a plan's key (NaN torque, times
    reversed, a short states array, and the well-formed but wrong): moved
    aside, named in one note, solved again (the stand-in's 1 s plan at
    rest, no torque), exit 0."""
    cache = d / "cache"
    for incline in ("9", "45"):
        rc, got, err = _plan(cache, d, incline, f"first{incline}")
        if rc != 0:
            return f"plan --incline {incline}: exit {rc} {err[-300:]!r}"
    files = sorted(cache.glob("plan-*.npz"))
    by_incline = {_stored(f)[1]["incline_deg"]: f for f in files}
    stored = by_incline[9.0]
    good, meta = _stored(stored)
    for what, (arrays, m) in wrong_plans(good, meta, _stored(by_incline[45.0])).items():
        if isinstance(m, dict):
            _store(stored, arrays, m)
        else:
            with open(stored, "wb") as fh:
                np.savez(fh, meta=json.dumps(m), **arrays)
        rc, got, err = _plan(cache, d, "9", "again")
        aside = stored.with_suffix(".damaged")
        note = f"bplir: note: the cached plan file {stored} is damaged"
        if rc != 0 or got is None or note not in err or not aside.exists() \
                or got["duration_s"] != 1.0 or not got["feasible"] \
                or got["peak_torque_Nm"] != 0.0:
            return f"{what}: exit {rc}, moved aside {aside.exists()}, {err[-300:]!r}"
        aside.unlink()
    return None


def plan_file_rows_too_close_are_bad_input(d: Path):
    """plan.file rows 1e-16 s (or 5e-324 s) apart: bad input naming the
    rows, exit 2 -- not a fault from Drake's trajectory."""
    for gap in (1e-16, 5e-324):
        t = np.linspace(0.0, 1.0, 20)
        t[1] = gap
        rows = ["t,q1,q2,q1d,q2d,tau"] + [f"{float(v)!r},0.1,0.2,0.0,0.0,0.5" for v in t]
        (d / "close.csv").write_text("\n".join(rows) + "\n")
        (d / "close.toml").write_text(f'[plan]\nfile = "{d / "close.csv"}"\n')
        rc, _, err = bplir("swing", "--config", d / "close.toml", "--no-animation",
                           "--out", d / "s")
        problem = one_error_line(rc, err, 2, "rows 1 and 2 are", "allowed at least 1e-06 s")
        if problem:
            return f"{gap:g} s apart: {problem}"
    return None


def a_damaged_library_in_the_cache_is_moved_aside(d: Path):
    """A damaged plan library in the user's cache is moved aside and named,
    and the note does not tell the user to reinstall the package."""
    import warnings

    from bplir_drake.planning import library as plan_library

    bad = d / "library-damaged.npz"
    bad.write_bytes(b"PK\x03\x04 not a zip at all")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        lib = plan_library.load_library(bad)
    said = " ".join(str(w.message) for w in caught)
    if lib is not None or "reinstall" in said or f"the plan library {bad} is damaged" not in said:
        return f"a damaged library gave {lib!r}, said {said!r}"
    return None if bad.with_suffix(".damaged").exists() and not bad.exists() else \
        "the damaged library was not moved aside"


#: every check, by what it guards
CHECKS = {f.__name__: f for f in (
    a_wrong_cached_plan_is_moved_aside,
    plan_file_rows_too_close_are_bad_input,
    a_damaged_library_in_the_cache_is_moved_aside,
)}
