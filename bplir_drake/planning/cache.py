"""Disk cache of planned swings and their tracking gains, keyed by every
input the planner (or the LQR) reads.

A DirectCollocation solve of a swing takes about a minute; a Monte Carlo
study, the tests and ``bplir swing`` with ``path.mode = "plan"`` need the same
few plans again and again.  :func:`cached` stores a
:class:`~bplir_drake.planning.solve.SwingPlan` as ``plan-<key>.npz`` in
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

The tracking gains of a plan (Drake's finite-horizon LQR, 10-15 s per plan)
are cached the same way as ``gains-<key>.npz``: every piecewise polynomial
is stored as its breaks and per-segment coefficients
(:func:`polynomial_arrays`), so a cache hit evaluates bit for bit like the
LQR's own result (a cubic Hermite rebuild from samples would not: the
Riccati solution's dense output is not C1 at its breaks).
"""
from __future__ import annotations

import contextlib
import dataclasses as dc
import hashlib
import json
import os
import warnings
from pathlib import Path

import numpy as np
from ..io import atomic_path, write_npz
from ..systems.plan_tracker import TrackingGains

#: bump when the planner's formulation changes (old cache files are ignored)
VERSION = 2


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


def plan_cache_path(inputs: dict, kind: str = "plan") -> Path:
    """Where the plan (or, with ``kind="gains"``, the gains) of ``inputs``
    is cached."""
    return cache_dir() / f"{kind}-{plan_key(inputs)}.npz"


#: plans shipped with the package (read-only; same file names and keys as
#: the cache, so they are used only for exactly these inputs and this Drake)
PACKAGED = Path(__file__).resolve().parents[1] / "data" / "plans"


def packaged_plan_path(inputs: dict, kind: str = "plan") -> Path:
    """Where a shipped plan (or gains) of ``inputs`` would be."""
    return PACKAGED / f"{kind}-{plan_key(inputs)}.npz"


def polynomial_arrays(pp) -> dict:
    """A Drake ``PiecewisePolynomial`` as arrays: ``breaks`` (n + 1) and
    ``coefficients`` (n, rows, cols, degree + 1), lowest power first, in
    each segment's local time."""
    n, r, c = pp.get_number_of_segments(), pp.rows(), pp.cols()
    degree = max(pp.getSegmentPolynomialDegree(i, a, b)
                 for i in range(n) for a in range(r) for b in range(c))
    coefficients = np.zeros((n, r, c, degree + 1))
    for i in range(n):
        for a in range(r):
            for b in range(c):
                co = pp.getPolynomial(i, a, b).GetCoefficients()
                coefficients[i, a, b, :len(co)] = co
    return {"breaks": np.asarray(pp.get_segment_times(), dtype=float),
            "coefficients": coefficients}


def polynomial_from_arrays(breaks, coefficients):
    """The ``PiecewisePolynomial`` of :func:`polynomial_arrays` (exact)."""
    from pydrake.polynomial import Polynomial
    from pydrake.trajectories import PiecewisePolynomial

    n, r, c, _ = coefficients.shape
    mats = []
    for i in range(n):
        m = np.empty((r, c), dtype=object)
        for a in range(r):
            for b in range(c):
                m[a, b] = Polynomial(coefficients[i, a, b])
        mats.append(m)
    return PiecewisePolynomial(mats, [float(t) for t in breaks])


def _write_npz(path: Path, arrays: dict) -> None:
    """``arrays`` as ``.npz`` at ``path``, atomically (:func:`~bplir_drake.io.atomic_path`)."""

    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        write_npz(fh, arrays)


def _save(plan, path: Path) -> None:
    fields = dc.asdict(plan)
    arrays = {k: v for k, v in fields.items() if isinstance(v, np.ndarray)}
    meta = {k: v for k, v in fields.items() if not isinstance(v, np.ndarray)}
    _write_npz(path, {"meta": json.dumps(meta), **arrays})


def save_gains(gains, path: Path) -> None:
    """Store tracking gains (``K, x0, u0, k0``) as polynomial arrays."""
    arrays = {}
    for name in GAIN_FIELDS:
        for part, value in polynomial_arrays(getattr(gains, name)).items():
            arrays[f"{name}_{part}"] = value
    _write_npz(path, arrays)


def load_gains(path: Path):
    """The :class:`~bplir_drake.systems.plan_tracker.TrackingGains` of :func:`save_gains`
    (``ValueError`` when its breaks are not finite and increasing or a
    coefficient is not finite)."""

    with np.load(path, allow_pickle=False) as data:
        for name in GAIN_FIELDS:
            breaks, co = data[f"{name}_breaks"], data[f"{name}_coefficients"]
            if breaks.ndim != 1 or len(breaks) < 2 or not np.all(np.isfinite(breaks)) \
                    or np.any(np.diff(breaks) <= 0) or not np.all(np.isfinite(co)) \
                    or co.ndim != 4 or co.shape[0] != len(breaks) - 1:
                raise ValueError(f"its gain {name} is not a finite piecewise polynomial over "
                                 "increasing times")
        return TrackingGains(**{name: polynomial_from_arrays(data[f"{name}_breaks"],
                                                             data[f"{name}_coefficients"])
                                for name in GAIN_FIELDS})


#: the trajectories of Drake's LQR result that the plan tracker evaluates
GAIN_FIELDS = ("K", "x0", "u0", "k0")


def _loader(make, fits=None):
    """A reader of :func:`_save`'s files building the plan with
    ``make(**fields)``, checked (its ``check()``, then ``fits(plan)``:
    that it is the plan of the key it is filed under)."""
    def load(path: Path):
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            arrays = {k: np.array(data[k]) for k in data.files if k != "meta"}
        if not isinstance(meta, dict):
            raise ValueError("its meta is not a table of fields")
        plan = make(**arrays, **meta)
        plan.check()
        if fits is not None:
            fits(plan)
        return plan
    return load


@contextlib.contextmanager
def _locked(path: Path):
    """An exclusive lock on ``path``'s ``.lock`` file, opened without
    following a link (a link planted there is refused, never truncated)."""
    import fcntl

    fd = os.open(path.with_suffix(".lock"), os.O_WRONLY | os.O_CREAT | os.O_NOFOLLOW, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fd, fcntl.LOCK_UN)
    finally:
        os.close(fd)


def damage(exc: BaseException) -> str:
    """What is wrong with a stored plan file, in a few words: the error its
    reading or its check raised, on one line."""
    return " ".join(str(exc).split())[:160] or type(exc).__name__


def move_aside(path: Path) -> Path:
    """Rename a damaged file of the cache to ``.damaged`` beside it (kept
    for a look, never read again); returns where it went."""
    aside = path.with_suffix(".damaged")
    with contextlib.suppress(OSError):
        os.replace(path, aside)
    return aside


def _read(load, path: Path):
    """``load(path)``, or None when the file is missing or damaged; a
    damaged file in the cache is moved aside (``.damaged``) to be re-solved,
    with a warning naming it and what is wrong."""
    if not path.exists():
        return None
    try:
        return load(path)
    except Exception as exc:   # truncated, not a zip, wrong fields, NaN, times reversed
        why = damage(exc)
        if path.parent == PACKAGED:
            warnings.warn(f"the shipped plan file {path} is damaged ({why}); it is solved "
                          "instead (reinstall the package to restore it)", stacklevel=2)
            return None
        aside = move_aside(path)
        warnings.warn(f"the cached plan file {path} is damaged ({why}); moved aside to "
                      f"{aside.name} and solved again", stacklevel=2)
        return None


#: when a set: every file :func:`cached` answers from, or writes, is added
#: to it (``scripts/ship_plans.py`` ships exactly the files its set used)
USED: set | None = None


def _used(path: Path) -> None:
    """Add ``path`` to :data:`USED` when that is a set and the file exists."""
    if USED is not None and path.exists():
        USED.add(Path(path))


def cached(inputs: dict, solve, kind: str = "plan", make=None, fits=None):
    """The plan (``kind="gains"``: the tracking gains) for ``inputs``: the
    shipped one when the package has it (whatever state the cache is in),
    else from the cache, else ``solve()`` once (stored when the cache is
    usable; a damaged cache file is moved aside and re-solved).  A plan is
    rebuilt from its file by ``make(**fields)`` (the plan's class,
    :class:`~bplir_drake.planning.solve.SwingPlan`) and must pass
    ``fits(plan)`` (a ``ValueError`` saying why it is not the plan of
    ``inputs``), or it is damaged."""
    if kind == "plan" and make is None:
        raise TypeError("cached(kind='plan') needs make=, the plan's class")
    load, save = (_loader(make, fits), _save) if kind == "plan" else (load_gains, save_gains)
    packaged = packaged_plan_path(inputs, kind)
    shipped = _read(load, packaged)
    if shipped is not None:
        _used(packaged)
        return shipped
    path = plan_cache_path(inputs, kind)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        lock = _locked(path)
        lock.__enter__()
    except OSError:  # no usable cache directory (or a link at the lock)
        return solve()
    try:
        result = _read(load, path)
        if result is None:
            result = solve()
            with contextlib.suppress(OSError):
                save(result, path)
        _used(path)
        return result
    finally:
        lock.__exit__(None, None, None)
