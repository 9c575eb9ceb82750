"""Dimensionless similarity between two-link robots: a plan solved for one
robot, scaled, is the first guess of another's.

Two robots whose links, masses and inertias have the same ratios swing
alike: over the time scale ``T0 = sqrt(L / g)`` (``L = l1 + l2``, the reach)
and the torque scale ``Q0 = m g L`` (``m = m1 + m2``) their equations of
motion are the same, so a plan of one at a grip spacing ``D`` is the other's
plan at ``D L' / L`` with times multiplied by ``T0' / T0``, rates divided by
it and torques multiplied by ``Q0' / Q0``.  A robot that is only nearly
similar gets a guess the solver corrects in a few iterations, where the
straight-line guess from start to target often ends in no plan at all.
The planner's price of time follows the same rule
(:func:`~bplir_drake.planning.swing_plan.plan_time_weight`), so the scaled
plan is the scaled robot's optimum, not just a feasible swing.
"""
from __future__ import annotations

import dataclasses as dc
import math
from dataclasses import dataclass

import numpy as np

from ...planning.library import (LIBRARY_SAMPLES, PlanLibrary, library_path,
                                      load_library)
from ...planning.swing_plan import SwingPlan
from ...planning.retry import retry
from ...params import BplirParams, Manoeuvre, derive, preset, with_hardware
from ...params.follow import robot_scales


@dataclass(frozen=True)
class Scales:
    """A robot's units: reach ``length`` L (m), ``time`` sqrt(L/g) (s) and
    ``torque`` m g L (N m)."""

    length: float
    time: float
    torque: float

    @classmethod
    def of(cls, plant) -> "Scales":
        """The scales of a ``[plant]`` block."""
        return cls(plant.l1 + plant.l2, *robot_scales(plant))


def shape(plant) -> np.ndarray:
    """The dimensionless numbers that fix how a two-link robot swings: link
    1's share of the reach, each centre of mass and off-axis offset over the
    reach, link 1's share of the mass and each inertia over m L^2."""
    L, m = plant.l1 + plant.l2, plant.m1 + plant.m2
    return np.array([plant.l1 / L, plant.lc1 / L, plant.lc2 / L, plant.oc1 / L,
                     plant.oc2 / L, plant.m1 / m, plant.I1 / (m * L * L),
                     plant.I2 / (m * L * L)])


@dataclass(frozen=True)
class Reference:
    """A solved library and the robot it was solved for."""

    library: PlanLibrary
    plant: object
    start: str


def shipped_robots(hardware=()) -> dict[str, BplirParams]:
    """``{name: parameters}`` of the robots and manoeuvres the package ships
    libraries for: the default robot's single swing (with the ``hardware``
    options), its traversal swings holding with either gripper and those
    swings tried again from hanging (``scripts/plan_library.py`` builds
    them)."""
    base = with_hardware(preset(), *hardware)
    step = {g: Manoeuvre(gripper=g, spacing=1.2, incline_deg=0.0, context="traverse")
            for g in (1, 2)}
    return {"swing": base.with_(path=dc.replace(base.path, mode="plan")),
            "traverse-1": derive(base, step[1]), "traverse-2": derive(base, step[2]),
            "hanging-1": retry(base, step[1]), "hanging-2": retry(base, step[2])}


def shipped_references() -> list[Reference]:
    """The libraries shipped with the package whose robots it knows
    (:func:`shipped_robots`)."""
    out = []
    for p in shipped_robots().values():
        lib = load_library(library_path(p))
        if lib is not None:
            out.append(Reference(lib, p.plant, p.scenario.start))
    return out


def nearest_point(ref: Reference, plant, incline: float, spacing: float) -> tuple[int, int]:
    """(i, j): the solved grid point of ``ref`` nearest the scenario in
    incline and in grip spacing over the reach; (-1, -1) when none is solved."""
    L = plant.l1 + plant.l2
    L_ref = ref.plant.l1 + ref.plant.l2
    best, out = math.inf, (-1, -1)
    for i, a in enumerate(ref.library.inclines):
        for j, d in enumerate(ref.library.spacings):
            if ref.library.reversals[i, j] < 0:
                continue
            cost = abs(a - incline) / 10.0 + abs(d / L_ref - spacing / L) / 0.05
            if cost < best:
                best, out = cost, (i, j)
    return out


def plan_kind(params: BplirParams) -> str:
    """What kind of plan a reference must be to start ``params``'s from:
    "hanging", "pump" (a pumping manoeuvre from the line) or "line"."""
    sc = params.scenario
    return "pump" if sc.manoeuvre_of() == "pump" else sc.start


def similar_guesses(params: BplirParams, references: list[Reference], count: int = 2):
    """Up to ``count`` scaled plans for the scenario of ``params`` (its
    robot, start, incline and grip spacing), from the references of the same
    start whose robots' shapes are nearest, each from its grid point nearest
    the scenario: SwingPlans to start the planner from (their angles are
    shifted onto the scenario's start and target by the planner)."""
    plant, sc = params.plant, params.scenario
    own = shape(plant)
    same = [r for r in references if r.start == plan_kind(params)]
    same.sort(key=lambda r: float(np.linalg.norm(shape(r.plant) - own)))
    out = []
    for ref in same[:count]:
        i, j = nearest_point(ref, plant, sc.incline_deg, sc.grip_spacing)
        if i < 0:
            continue
        out.append(scaled_plan(ref, i, j, plant))
    return out


def scaled_plan(ref: Reference, i: int, j: int, plant) -> SwingPlan:
    """The plan at ``ref``'s grid point (i, j) in the units of ``plant``."""
    mine, theirs = Scales.of(plant), Scales.of(ref.plant)
    kt, kq = mine.time / theirs.time, mine.torque / theirs.torque
    lib = ref.library
    times = np.linspace(0.0, float(lib.durations[i, j]) * kt, LIBRARY_SAMPLES)
    states = np.array(lib.states[i, j], dtype=float)
    states[:, 2:] /= kt
    torque = np.array(lib.torque[i, j], dtype=float) * kq
    return SwingPlan(times, states, torque, np.zeros((LIBRARY_SAMPLES, 2)), True, True,
                     "similarity", float(lib.inclines[i]), math.inf, math.inf, 1e-4)
