"""Plans without waiting: a shipped library of swing plans and their
tracking gains on a grid of line inclines and grip spacings, and the plan
of any scenario inside the grid interpolated from it in milliseconds.

A library belongs to one nominal robot and everything else the planner and
the tracking gains read (:func:`model_inputs`: the nominal plant and
friction, the motor's envelope, the torque and power limits, the timeout,
the plan's end depth, the LQR weights, and the swing's start: from the line,
or from hanging at rest with the hanging planner's own settings, as a
traversal tries a swing again); it is used only when a scenario's
inputs match it exactly, so a plan never comes from another robot's model.
The grid is solved by continuation (``scripts/plan_library.py``), so
that neighbouring plans are mostly the same manoeuvre; each is sampled at
the same fractions of its duration.  A scenario's plan is the bilinear
blend of the four plans around it when they reverse link 1 equally often
(else it is solved) (duration, states, torque, gain ``K`` and affine term
``k0`` at each fraction), its angles then shifted linearly in time so that
it starts exactly at the start pose and ends exactly at the target.  The
blend is not itself a solution of the planner: between grid points it
follows the plans around it, not necessarily the plan the planner would
solve there, and the tracking feedback absorbs the difference.
"""
from __future__ import annotations

import dataclasses
import functools
import json
import warnings
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..params import BplirParams
from ..params.blocks import number_or
from ..systems.friction import friction_torques_along
from ..systems.plan_tracker import RICCATI_ACCURACY, TrackerWeights, TrackingGains, plan_gains
from ..systems.plant import start_configuration
from ..io import atomic_path, write_npz
from .cache import PACKAGED, cache_dir, damage, move_aside, plan_key
from .swing_plan import (
    HANGING_GUESSES, HANGING_KNOTS, HANGING_MINOR_ITERATIONS, PLAN_FRICTION_SMOOTHING, PUMP_KNOTS, UNBALANCED_SHARE, SwingPlan, plan_envelope, plan_friction, plan_time_weight, plan_torque_limit, planned_target, pump_guesses, shifted_angles)
from ..params.derive import as_planned

#: the grid of the shipped libraries: line inclines (deg) and grip spacings (m)
LIBRARY_INCLINES = tuple(float(a) for a in range(-20, 21, 5))
LIBRARY_SPACINGS = (0.9, 1.0, 1.1, 1.2, 1.3, 1.4, 1.5)
#: samples of each plan, at equal fractions of its duration
LIBRARY_SAMPLES = 401
#: the collocation knots of the library's plans (the planner's default)
LIBRARY_KNOTS = 41


@dataclass(frozen=True)
class PlanLibrary:
    """Plans on a grid: ``durations[i, j]`` of the plan at ``inclines[i]``
    (deg) and ``spacings[j]`` (m); ``states``, ``torque``, ``gain`` (K) and
    ``offset`` (k0) sampled at ``LIBRARY_SAMPLES`` equal fractions of it."""

    key: str
    inclines: np.ndarray      # (ni,)
    spacings: np.ndarray      # (ns,)
    durations: np.ndarray     # (ni, ns)
    states: np.ndarray        # (ni, ns, n, 4)
    torque: np.ndarray        # (ni, ns, n)
    gain: np.ndarray          # (ni, ns, n, 4)
    offset: np.ndarray        # (ni, ns, n)
    reversals: np.ndarray     # (ni, ns): link-1 reversals of each plan
    #: JSON of the robot a commissioned library was solved for (``plant``,
    #: ``start``): a first guess for similar robots; "" in the shipped ones
    robot: str = ""

    def covers(self, incline_deg: float, spacing: float) -> bool:
        """Whether the grid contains the scenario (edges included)."""
        eps = 1e-9
        return (self.inclines[0] - eps <= incline_deg <= self.inclines[-1] + eps
                and self.spacings[0] - eps <= spacing <= self.spacings[-1] + eps)


def model_inputs(params: BplirParams) -> dict:
    """Every input of a library plan and its gains other than the incline
    and the grip spacing (the planner's defaults for the solver settings;
    from hanging, its own: :func:`~.swing_plan.planned_from_hanging`, knots,
    iteration limit, guesses and i^2 t share; the elbow-rate bound 0, none,
    kept in the key of the libraries shipped when it was a parameter)."""
    made, hanging = as_planned(params), params.scenario.start == "hanging"
    out = dict(plant=params.plant.key_dict(), friction=params.friction.as_dict(),
               envelope=plan_envelope(made), tau_max=plan_torque_limit(made),
               power=params.motor.power_rating, tmax=params.scenario.max_time,
               end_depth=params.plan.end_depth, start=params.scenario.start,
               knots=HANGING_KNOTS if hanging else LIBRARY_KNOTS,
               smoothing=PLAN_FRICTION_SMOOTHING,
               weights=dataclasses.asdict(TrackerWeights.of(params.plan)), riccati=RICCATI_ACCURACY,
               inclines=list(LIBRARY_INCLINES), spacings=list(LIBRARY_SPACINGS),
               samples=LIBRARY_SAMPLES)
    if hanging:
        out.update(rate_limit=0.0, guesses=list(HANGING_GUESSES),
                   minor_iterations=HANGING_MINOR_ITERATIONS,
                   i2t_share=number_or(params.hanging.i2t_share))   # none: 0, as shipped
    elif params.scenario.manoeuvre_of() == "pump":
        out.update(manoeuvre="pump", knots=PUMP_KNOTS, guesses=list(pump_guesses(params.plant)),
                   minor_iterations=HANGING_MINOR_ITERATIONS, balance=UNBALANCED_SHARE)
    return out


def library_path(params: BplirParams, directory: Path = PACKAGED) -> Path:
    """Where the library for ``params``'s model would be stored."""
    return directory / f"library-{plan_key(model_inputs(params))}.npz"


def robot_library_key(params: BplirParams) -> str:
    """The key of a commissioned library for ``params``'s model:
    :func:`model_inputs` without the grid (a commissioned library carries
    its own) and with the planner's price of time."""
    inputs = model_inputs(params)
    for name in ("inclines", "spacings"):
        inputs.pop(name)
    inputs["time_weight"] = plan_time_weight(params.plant)
    return plan_key(inputs)


def robot_library_path(params: BplirParams) -> Path:
    """Where a commissioned library for ``params``'s model is kept (the plan cache)."""
    return cache_dir() / f"library-{robot_library_key(params)}.npz"


def find_library(params: BplirParams) -> PlanLibrary | None:
    """The shipped library for ``params``'s model, else one commissioned for
    it (:func:`robot_library_path`), else None."""
    return load_library(library_path(params)) or load_library(robot_library_path(params))


def covering_library(params: BplirParams) -> PlanLibrary | None:
    """The library for ``params``'s model (:func:`find_library`) where its
    grid covers the scenario's incline and grip spacing, else None."""
    lib = find_library(params)
    sc = params.scenario
    return lib if lib is not None and lib.covers(sc.incline_deg, sc.grip_spacing) else None


def library_covers(params: BplirParams) -> bool:
    """Whether a library for ``params``'s model (shipped, or commissioned
    for the robot) covers its line's incline and grip spacing with plans
    around it that give the scenario's (:func:`_rows_of`): a manoeuvre
    verified there, not one a grid of holes would leave to be solved."""
    lib = covering_library(params)
    return lib is not None and _rows_of(lib, params.scenario) is not None


def _resample(times, values, n: int = LIBRARY_SAMPLES) -> np.ndarray:
    """``values`` (rows at ``times``) at ``n`` equal fractions of the span."""
    s = np.linspace(times[0], times[-1], n)
    values = np.asarray(values, dtype=float)
    if values.ndim == 1:
        return np.interp(s, times, values)
    return np.stack([np.interp(s, times, values[:, k]) for k in range(values.shape[1])], 1)


def build_library(params: BplirParams, plans: dict, model) -> PlanLibrary:
    """The library of ``plans`` (``{(incline, spacing): SwingPlan or
    None}`` on the full grid; None: the planner found none), with each
    plan's tracking gains from Drake's finite-horizon LQR on ``model``
    (the nominal plant with friction, :func:`~.plan.plan_model`)."""
    entries = {}
    for point, plan in plans.items():
        entries[point] = None if plan is None else library_entry(
            plan, plan_gains(model, plan.times, plan.states, plan.torque,
                             TrackerWeights.of(params.plan)))
    return assemble_library(plan_key(model_inputs(params)), LIBRARY_INCLINES,
                            LIBRARY_SPACINGS, entries)


def library_entry(plan: SwingPlan, gains) -> dict:
    """One grid point of a library: ``plan`` and its tracking ``gains``
    sampled at :data:`LIBRARY_SAMPLES` equal fractions of its duration."""
    t = np.linspace(plan.times[0], plan.times[-1], LIBRARY_SAMPLES)
    return dict(durations=plan.duration, states=_resample(plan.times, plan.states),
                torque=_resample(plan.times, plan.torque),
                gain=np.array([gains.K.value(x).ravel() for x in t]),
                offset=np.array([gains.k0.value(x).ravel()[0] for x in t]),
                reversals=plan.link1_reversals)


def assemble_library(key: str, inclines, spacings, entries: dict) -> PlanLibrary:
    """The library ``key`` on the grid ``inclines`` x ``spacings`` of
    ``entries`` (``{(incline, spacing): library_entry or None}``; None: no
    plan there, a hole that blends around it solve instead)."""
    ni, ns, n = len(inclines), len(spacings), LIBRARY_SAMPLES
    arr = dict(durations=np.zeros((ni, ns)), states=np.zeros((ni, ns, n, 4)),
               torque=np.zeros((ni, ns, n)), gain=np.zeros((ni, ns, n, 4)),
               offset=np.zeros((ni, ns, n)), reversals=np.zeros((ni, ns), dtype=int))
    for i, a in enumerate(inclines):
        for j, d in enumerate(spacings):
            entry = entries.get((a, d))
            if entry is None:
                arr["durations"][i, j], arr["reversals"][i, j] = math.nan, -1
                continue
            for name, value in entry.items():
                arr[name][i, j] = value
    return PlanLibrary(key, np.array(inclines, dtype=float), np.array(spacings, dtype=float),
                       **arr)


def save_library(lib: PlanLibrary, path: Path) -> None:
    """``lib`` as a compressed ``.npz`` (written atomically), its samples
    in single precision (1e-7 of their values: far below what the blend
    changes between grid points)."""
    arrays = {k: (v.astype(np.float32) if v.dtype == np.float64 and v.ndim > 2 else v)
              for k, v in dataclasses.asdict(lib).items() if k not in ("key", "robot")}
    if lib.robot:
        arrays["robot"] = np.array(lib.robot)
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        write_npz(fh, {"key": np.array(lib.key), **arrays}, compressed=True)
    load_library.cache_clear()   # a lookup before it was written found none


@functools.lru_cache(maxsize=16)
def load_library(path: Path) -> PlanLibrary | None:
    """The library stored at ``path``, or None when there is none or it is
    damaged (a warning names the file; the scenario's plan is then solved)."""
    if not path.exists():
        return None
    try:
        lib = _load(path)
        _check_library(lib)
    except Exception as exc:   # truncated, not a zip, wrong fields, non-finite plans
        if path.parent == PACKAGED:
            warnings.warn(f"the shipped plan library {path} is damaged ({damage(exc)}); plans "
                          "it holds are solved instead (reinstall the package to restore it)",
                          stacklevel=2)
            return None
        aside = move_aside(path)
        warnings.warn(f"the plan library {path} is damaged ({damage(exc)}); moved aside to "
                      f"{aside.name}: plans it held are solved instead, and commissioning "
                      "the robot again rebuilds it", stacklevel=2)
        return None
    return lib


def _check_library(lib: PlanLibrary) -> None:
    """Raise ``ValueError`` unless every plan of ``lib`` has a finite, positive
    duration and finite samples, on increasing grid axes."""
    for axis in (lib.inclines, lib.spacings):
        if axis.ndim != 1 or len(axis) < 1 or np.any(np.diff(axis) <= 0):
            raise ValueError("its grid axes do not increase")
    grid = (len(lib.inclines), len(lib.spacings))
    held = lib.reversals >= 0
    if lib.reversals.shape != grid or lib.durations.shape != grid:
        raise ValueError(f"its plans do not fill its {grid[0]} x {grid[1]} grid")
    if not np.all(np.isfinite(lib.durations[held]) & (lib.durations[held] > 0)):
        raise ValueError("a plan's duration is not finite and positive")
    for name in ("states", "torque", "gain", "offset"):
        a = getattr(lib, name)
        if a.shape[:2] != grid or not np.all(np.isfinite(a[held])):
            raise ValueError(f"its {name} have a missing or non-finite value")


def _load(path: Path) -> PlanLibrary:
    """The :class:`PlanLibrary` of :func:`save_library`'s file at ``path``."""
    with np.load(path, allow_pickle=False) as data:
        return PlanLibrary(**{f.name: (str(data[f.name]) if f.name in ("key", "robot")
                                       else np.array(data[f.name], dtype=float
                                                     if data[f.name].dtype.kind == "f"
                                                     else data[f.name].dtype))
                              for f in dataclasses.fields(PlanLibrary) if f.name in data})


def _corners(axis: np.ndarray, value: float):
    """[(index, weight)] of the two grid points around ``value`` (the
    one point of a one-point axis)."""
    if len(axis) == 1:
        return [(0, 1.0)]
    i = int(np.clip(np.searchsorted(axis, value) - 1, 0, len(axis) - 2))
    w = float(np.clip((value - axis[i]) / (axis[i + 1] - axis[i]), 0.0, 1.0))
    return [(i, 1.0 - w), (i + 1, w)]


def same_manoeuvre(lib: PlanLibrary, incline: float, spacing: float) -> bool:
    """Whether the plans the blend of the scenario weighs exist and reverse
    link 1 equally often (a blend of two kinds of swing is neither)."""
    kinds = {int(lib.reversals[i, j]) for i, wi in _corners(lib.inclines, incline)
             for j, wj in _corners(lib.spacings, spacing) if wi * wj > 0}
    return len(kinds) == 1 and min(kinds) >= 0


def _blend(lib: PlanLibrary, incline: float, spacing: float) -> dict:
    """The bilinear blend of the four plans around the scenario."""
    out = {}
    for name in ("durations", "states", "torque", "gain", "offset"):
        a = getattr(lib, name)
        out[name] = sum(wi * wj * a[i, j] for i, wi in _corners(lib.inclines, incline)
                        for j, wj in _corners(lib.spacings, spacing))
    return out


def _nearest(lib: PlanLibrary, incline: float, spacing: float) -> dict | None:
    """The plan of the grid point nearest the scenario among the corners
    around it that have one (None: none has), as :func:`_blend` gives it."""
    held = [(abs(lib.inclines[i] - incline) + abs(lib.spacings[j] - spacing), i, j)
            for i, _ in _corners(lib.inclines, incline) for j, _ in _corners(lib.spacings, spacing)
            if lib.reversals[i, j] >= 0]
    if not held:
        return None
    _, i, j = min(held)
    return {name: getattr(lib, name)[i, j] for name in
            ("durations", "states", "torque", "gain", "offset")}


def _rows_of(lib: PlanLibrary, sc) -> dict | None:
    """The rows of the scenario ``sc``'s plan in ``lib``: the blend of the
    plans around it where they are one manoeuvre (:func:`same_manoeuvre`),
    for a pumping manoeuvre the nearest of them that has a plan (pumps of
    other phases do not blend), else None."""
    if same_manoeuvre(lib, sc.incline_deg, sc.grip_spacing):
        return _blend(lib, sc.incline_deg, sc.grip_spacing)
    if sc.manoeuvre_of() == "pump":
        return _nearest(lib, sc.incline_deg, sc.grip_spacing)
    return None


def library_plan(params: BplirParams):
    """(plan, tracking gains) of the scenario of ``params`` interpolated
    from the shipped library for its model, or None when ``plan.library``
    is off, no library matches the model, the grid does not cover the
    scenario or the plans around it are not the same manoeuvre
    (:func:`same_manoeuvre`; for a pumping manoeuvre, the nearest of them
    shifted onto the scenario's start and target)."""
    from pydrake.trajectories import PiecewisePolynomial

    sc = params.scenario
    if not params.plan.library:
        return None
    lib = covering_library(params)
    b = None if lib is None else _rows_of(lib, sc)
    if b is None:
        return None
    s = np.linspace(0.0, 1.0, LIBRARY_SAMPLES)
    times = s * b["durations"]
    q0 = start_configuration(sc.start, sc.grip_spacing, params.plant, math.radians(sc.incline_deg))
    states = shifted_angles(s, b["states"], q0, planned_target(params, params.plan.end_depth))
    made = as_planned(params)
    env = plan_envelope(made)
    electric = {} if env is None else dict(
        voltage_limit=env["voltage"], voltage_share=env["share"], resistance=env["resistance"],
        emf_per_rate=env["emf_per_rate"], torque_per_amp=env["torque_per_amp"])
    friction = plan_friction(params.friction)
    fr = friction_torques_along(states, friction)
    plan = SwingPlan(times, states, b["torque"], fr, True, True, "library", sc.incline_deg,
                     plan_torque_limit(made), params.motor.power_rating, 1e-4, **electric,
                     status="interpolated")
    gains = TrackingGains(
        K=PiecewisePolynomial.FirstOrderHold(times, [k.reshape(1, 4) for k in b["gain"]]),
        x0=PiecewisePolynomial.FirstOrderHold(times, states.T),
        u0=PiecewisePolynomial.FirstOrderHold(times, b["torque"].reshape(1, -1)),
        k0=PiecewisePolynomial.FirstOrderHold(times, b["offset"].reshape(1, -1)))
    return plan, gains


def describe(lib: PlanLibrary) -> str:
    """One line: the grid and the plans' manoeuvres."""
    rev = sorted(set(lib.reversals.ravel().tolist()) - {-1})
    holes = int(np.count_nonzero(lib.reversals < 0))
    return (f"{len(lib.inclines)} inclines {lib.inclines[0]:+g}..{lib.inclines[-1]:+g} deg x "
            f"{len(lib.spacings)} spacings {lib.spacings[0]:g}-{lib.spacings[-1]:g} m, "
            f"{holes} without a plan, durations {np.nanmin(lib.durations):.2f}-"
            f"{np.nanmax(lib.durations):.2f} s, link-1 reversals {json.dumps(rev)}")
