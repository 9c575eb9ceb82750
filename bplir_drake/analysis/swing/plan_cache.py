"""Disk cache of planned swings, keyed by every input the planner reads.

A DirectCollocation solve of a swing takes about a minute; a Monte Carlo
study, the tests and ``bplir swing`` with ``path.mode = "plan"`` need the same
few plans again and again.  :func:`cached` stores a
:class:`~bplir_drake.analysis.swing.plan.SwingPlan` as ``plan-<key>.npz`` in
the cache directory (``$BPLIR_CACHE_DIR``, default ``~/.cache/bplir-drake``),
where ``key`` is the SHA-256 of the planner's inputs (nominal model,
scenario geometry, limits, solver settings), the Drake version and
:data:`VERSION`.  Only the nominal model enters: a plan can never depend on
the simulated robot.  Files are written to a temporary name and renamed, and
a lock file makes concurrent processes (parallel tests, study workers) wait
for one solve instead of repeating it.  An unreadable or unwritable cache is
bypassed: the plan is then solved in the process.  The package ships the
plans its examples and tests use (``bplir_drake/data/plans``, under the
same keys): they are read when the cache has no copy, so a fresh install
with the Drake version they were solved with does not solve them again.
"""
from __future__ import annotations

import contextlib
import dataclasses as dc
import hashlib
import json
import os
import tempfile
from pathlib import Path

import numpy as np

#: bump when the planner's formulation changes (old cache files are ignored)
VERSION = 1


def cache_dir() -> Path:
    """The cache directory (``$BPLIR_CACHE_DIR`` or ``~/.cache/bplir-drake``)."""
    env = os.environ.get("BPLIR_CACHE_DIR")
    return Path(env) if env else Path.home() / ".cache" / "bplir-drake"


def plan_key(inputs: dict) -> str:
    """SHA-256 of the planner's inputs, the Drake version and :data:`VERSION`."""
    import pydrake

    text = json.dumps({"inputs": inputs, "drake": getattr(pydrake, "__version__", "?"),
                       "version": VERSION}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def plan_cache_path(inputs: dict) -> Path:
    """Where the plan of ``inputs`` is cached."""
    return cache_dir() / f"plan-{plan_key(inputs)}.npz"


#: plans shipped with the package (read-only; same file names and keys as
#: the cache, so they are used only for exactly these inputs and this Drake)
PACKAGED = Path(__file__).resolve().parents[2] / "data" / "plans"


def packaged_plan_path(inputs: dict) -> Path:
    """Where a shipped plan of ``inputs`` would be."""
    return PACKAGED / f"plan-{plan_key(inputs)}.npz"


def _save(plan, path: Path) -> None:
    fields = dc.asdict(plan)
    arrays = {k: v for k, v in fields.items() if isinstance(v, np.ndarray)}
    meta = {k: v for k, v in fields.items() if not isinstance(v, np.ndarray)}
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".plan-", suffix=".npz")
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, meta=json.dumps(meta), **arrays)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _load(path: Path):
    from .plan import SwingPlan

    with np.load(path, allow_pickle=False) as data:
        meta = json.loads(str(data["meta"]))
        arrays = {k: np.array(data[k]) for k in data.files if k != "meta"}
    return SwingPlan(**arrays, **meta)


@contextlib.contextmanager
def _locked(path: Path):
    import fcntl

    with open(path.with_suffix(".lock"), "w") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def cached(inputs: dict, solve):
    """The plan for ``inputs``: from the cache, or ``solve()`` once (stored)."""
    path = plan_cache_path(inputs)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        lock = _locked(path)
        lock.__enter__()
    except OSError:  # no usable cache directory
        return solve()
    try:
        for candidate in (path, packaged_plan_path(inputs)):
            if candidate.exists():
                try:
                    return _load(candidate)
                except (OSError, ValueError, KeyError, TypeError):
                    pass  # a damaged file: solve again and replace it
        plan = solve()
        with contextlib.suppress(OSError):
            _save(plan, path)
        return plan
    finally:
        lock.__exit__(None, None, None)
