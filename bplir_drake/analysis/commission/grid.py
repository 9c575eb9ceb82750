"""A robot's plan library, solved: every grid point first from plans of
similar robots scaled to it (:mod:`.similarity`), then from its solved
neighbours (continuation), then from the planner's straight-line guesses,
then made fit to blend (:mod:`.refine`); in parallel over the grid, each solve in the plan cache (so a stopped run
resumes where it stopped), the library saved where ``swing``,
``montecarlo`` and ``traverse`` look for it
(:func:`~bplir_drake.planning.library.robot_library_path`)."""
from __future__ import annotations

import dataclasses as dc
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

from ...planning import solve as P
from ...planning.swing_plan import energy_balance
from ...planning.library import (assemble_library, library_entry, robot_library_key,
                                      robot_library_path, save_library)
from ...params import BplirParams, on_line
from ...systems.plan_tracker import TrackerWeights
from ..montecarlo.executors import map_jobs
from .margins import supply_energy
from .refine import refined, solve_from
from .similarity import plan_kind, shipped_references, similar_guesses


@dataclass(frozen=True)
class PointResult:
    """How one grid point was solved: ``how`` is "similarity",
    "continuation", "straight line" or "none"; ``plan`` the SwingPlan (None
    without one); ``entry`` its library samples with the tracking gains."""

    incline: float
    spacing: float
    how: str
    plan: object
    entry: dict | None
    wall_s: float
    #: each solve tried, in turn: its first guess and how the solver ended
    tried: tuple = ()
    #: the share of the energy the plan exchanges that its energy balance
    #: leaves unaccounted (:func:`~bplir_drake.planning.swing_plan.energy_balance`)
    energy_residual: float = math.nan

    def row(self) -> dict:
        """The point as a table row."""
        p = self.plan
        ok = p is not None and p.feasible
        return dict(incline_deg=self.incline, spacing_m=self.spacing, how=self.how,
                    duration_s=p.duration if ok else math.nan,
                    peak_torque_Nm=p.peak_torque if ok else math.nan,
                    peak_voltage_V=p.peak_voltage if ok else math.nan,
                    energy_in_J=p.energy_in if ok else math.nan,
                    supply_energy_J=supply_energy(p) if ok else math.nan,
                    status=p.status if p is not None else "no plan", wall_s=self.wall_s,
                    tried="; ".join(self.tried), energy_residual_share=self.energy_residual)


def guess_sources(references=()) -> list:
    """The libraries a commission's first guesses come from: the package's
    shipped ones and ``references`` (libraries this commission solved
    before), never whatever else the plan cache holds, so that the same
    robot and options give the same plans however often and wherever they
    run."""
    return shipped_references() + list(references)


def solve_point(params: BplirParams, incline: float, spacing: float,
                neighbour=None, straight: bool = True, references=()) -> PointResult:
    """The plan at one grid point with its library entry: from ``neighbour``
    (a solved SwingPlan next to it), else from similar robots' plans scaled
    to this one (:func:`guess_sources`), else (with ``straight``) from the
    straight-line guesses."""
    t0 = time.perf_counter()
    q = on_line(params, incline, spacing)
    tries = [("similarity", g) for g in similar_guesses(q, guess_sources(references))]
    if neighbour is not None:
        tries.insert(0, ("continuation", neighbour))
    plan, how, tried = None, "none", []
    for kind, guess in tries:
        p = solve_from(q, initial=guess)
        tried.append(f"{kind}: {_ended(p)}")
        if p.feasible:
            plan, how = p, kind
            break
    if plan is None and straight:
        for duration in straight_guesses(q):
            p = solve_from(q, guess_duration=duration)
            tried.append(f"straight line over {duration:g} s: {_ended(p)}")
            if p.feasible:
                plan, how = p, "straight line"
                break
    return PointResult(float(incline), float(spacing), how, plan, _entry(q, plan),
                       time.perf_counter() - t0, tuple(tried), _residual(q, plan))


def _residual(q: BplirParams, plan) -> float:
    """The plan's unaccounted share of its energy (nan: no plan)."""
    return math.nan if plan is None else energy_balance(plan, q.plant)["residual_share"]


def straight_guesses(q: BplirParams) -> tuple[float, ...]:
    """The planner's straight-line guess durations for ``q``'s manoeuvre (s)."""
    if q.scenario.start == "hanging":
        return P.HANGING_GUESSES
    return P.pump_guesses(q.plant) if q.scenario.manoeuvre_of() == "pump" else P.PLAN_GUESSES


def _ended(plan) -> str:
    """How one solve ended, in words: feasible, or the solver's status."""
    return "feasible" if plan.feasible else f"not feasible ({plan.status or 'unknown'})"


def _entry(q: BplirParams, plan) -> dict | None:
    """The library samples of ``plan`` with its tracking gains (None: no plan)."""
    if plan is None:
        return None
    gains = P.tracking_gains(q.plant, q.friction, plan, weights=TrackerWeights.of(q.plan))
    return library_entry(plan, gains)


def _neighbour(point, solved: dict):
    """The solved plan nearest ``point`` on the grid (None: none)."""
    best, out = math.inf, None
    for (a, d), res in solved.items():
        if res.plan is None:
            continue
        cost = abs(a - point[0]) / 5.0 + abs(d - point[1]) / 0.1
        if cost < best:
            best, out = cost, res.plan
    return out


def solve_library(params: BplirParams, inclines, spacings, *, workers: int = 0,
                  progress: bool = False, dask: bool = False, scheduler=None,
                  path=None, key: str | None = None, references=()) -> dict:
    """``{(incline, spacing): PointResult}`` over the grid, the library
    saved for ``params``'s model: every point from similar robots first (in
    parallel: ``workers`` processes, or Dask), the point nearest a level
    line at the robot's own spacing from straight lines too, then the points
    without a plan from their solved neighbours (or straight lines, where
    none has one), then the grid made fit to blend
    (:func:`~.refine.refined`; a replaced point's ``how`` says so).  Saved at
    ``path`` under ``key`` (default: the plan cache's commissioned library,
    :func:`~bplir_drake.planning.library.robot_library_path`).  First
    guesses come from :func:`guess_sources` with ``references``; the points
    are taken in grid order whatever order they finish in, so the library
    is a function of its inputs alone."""
    pool = dict(workers=workers, dask=dask, scheduler=scheduler, progress=progress)
    points = [(float(a), float(d)) for a in inclines for d in spacings]
    first = min(points, key=lambda p: (abs(p[0]), abs(p[1] - params.scenario.grip_spacing)))
    refs = tuple(references)
    solved = {}
    for res in map_jobs(solve_point, [(params, a, d, None, (a, d) == first, refs)
                                      for a, d in points],
                        desc="plans", unit="plans", **pool):
        solved[res.incline, res.spacing] = res
    solved = {p: solved[p] for p in points}
    missing = [p for p in points if solved[p].plan is None]
    if missing:
        args = [(params, a, d, _neighbour((a, d), solved), True, refs) for a, d in missing]
        for res in map_jobs(solve_point, args, desc="plans (continued)", unit="plans", **pool):
            solved[res.incline, res.spacing] = res
    plans, changed = refined(params, {p: r.plan for p, r in solved.items()})
    for a, d in changed:
        q = on_line(params, a, d)
        solved[a, d] = dc.replace(solved[a, d], how="refined", plan=plans[a, d],
                                  entry=_entry(q, plans[a, d]),
                                  energy_residual=_residual(q, plans[a, d]))
    robot = json.dumps({"plant": params.plant.as_dict(), "start": plan_kind(params)})
    lib = assemble_library(key or robot_library_key(params), sorted({a for a, _ in points}),
                           sorted({d for _, d in points}),
                           {p: r.entry for p, r in solved.items()})
    path = robot_library_path(params) if path is None else Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    save_library(dc.replace(lib, robot=robot), path)
    return solved
