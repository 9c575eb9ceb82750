"""Where the robot grips to pass each obstacle (the traversal's planner).

Passing an obstacle takes two swings.  The robot stops with its front
gripper ``F`` a clearance before the obstacle and its rear gripper a grip
spacing ``D`` behind; ``F`` holds and the rear gripper swings past ``F``
and the obstacle, landing about ``D`` ahead of ``F`` (swing 1).  The robot
now straddles the obstacle; the gripper that landed sets the spacing back
to ``D`` on its wheel, holds, and ``F`` swings past it (swing 2), landing
about ``2 D`` ahead of its old grip.  Both grippers are past the obstacle
and the robot rides on; ``F`` is the front gripper again, so swing 1 of
every obstacle holds with the same gripper and swing 2 with the other.

:func:`hold_position` picks ``F``'s grip and the two swings' grip spacings:
the set-up spacing ``traverse.grip_spacing`` for both where it fits, else
the pair nearest to it within ``[traverse.spacing_min,
traverse.spacing_max]`` (the rear gripper rolls to swing 1's spacing before
it; the landed gripper rolls to swing 2's after it), so obstacles closer
together than two set-up spacings are passed with shorter swings; ``F``
as close to the obstacle as the clearance allows, moved back until both
planned landings keep the clearance, the gripper's half-width and the
landing tolerance from every obstacle, the second lands before the next
obstacle and on the stretch.  :func:`closest_gap` is the shortest gap
between two obstacles the route passes; a line with a closer pair is
refused naming it.  :func:`plan_route` runs it over the whole line with
landings where planned (raising :class:`~.line.LineError` for a line that
cannot be crossed); the traversal calls :func:`hold_position` again from
where the robot really is.  Only the nominal spacings and the line enter:
never the simulated robot.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...params import BplirParams
from .line import Line, LineError, Obstacle

#: step of the search for a hold position (m)
SEARCH_STEP = 0.005


@dataclass(frozen=True)
class ObstaclePlan:
    """The planned grips around one obstacle (positions along the line, m)
    and the grip spacing of each of its two swings."""

    obstacle: Obstacle
    hold: float       # F's grip for swing 1 (before the obstacle)
    rear: float       # the rear gripper's grip before swing 1 (hold - spacing1)
    landing1: float   # swing 1 lands here (past the obstacle)
    landing2: float   # swing 2 lands here (F, ahead of landing1)
    spacing1: float = 0.0   # swing 1's grip spacing (m)
    spacing2: float = 0.0   # swing 2's: the landed gripper rolls to hold + spacing2


#: step of the grip spacings the route chooses from (m)
SPACING_STEP = 0.05


def max_width(params: BplirParams) -> float:
    """The widest obstacle a swing of the longest grip spacing straddles (m)."""
    tp = params.traverse
    margin = tp.clearance + params.gripper.width / 2
    return tp.spacing_max - 2 * margin - tp.landing_tolerance


def spacing_pairs(params: BplirParams) -> list[tuple[float, float]]:
    """The (swing 1, swing 2) grip spacings the route tries, in
    ``[traverse.spacing_min, traverse.spacing_max]`` on a
    :data:`SPACING_STEP` grid: the set-up spacing for both first, then
    pairs further from it."""
    tp = params.traverse
    D = tp.grip_spacing
    grid = {D} | {round(float(d), 6) for d in
                  np.arange(tp.spacing_min, tp.spacing_max + 1e-9, SPACING_STEP)}
    return sorted(((a, b) for a in grid for b in grid),
                  key=lambda p: (abs(p[0] - D) + abs(p[1] - D), abs(p[1] - D), p))


def _clear(line: Line, s: float, margin: float) -> bool:
    return line.obstacle_at(s, margin) is None


def _grips(line: Line, k: int, hi: float, behind: float, d1: float, d2: float,
           near: float, land: float) -> ObstaclePlan | None:
    """The grips around obstacle ``k`` with spacings ``d1``, ``d2``: F's
    grip as close to the obstacle as allowed (at most ``hi``), or None."""
    ob = line.obstacles[k]
    nxt = line.obstacles[k + 1] if k + 1 < len(line.obstacles) else None
    lo = max(ob.end + land - d1, behind + d1, ob.end + near - d2)
    for s in np.arange(hi, lo - 1e-12, -SEARCH_STEP):
        l1, h2, l2 = s + d1, s + d2, s + 2 * d2
        if nxt is not None and l2 > nxt.start - land:
            continue   # the second landing would pass the next obstacle with one gripper
        if l2 > line.length - land:
            continue   # the end of the stretch (a tower's clamp) is an obstacle too
        if not (_clear(line, s, near) and _clear(line, s - d1, near) and _clear(line, l1, land)
                and _clear(line, l2, land)):
            continue
        if line.obstacle_in(min(l1, h2), max(l1, h2), near) is not None:
            continue   # the landed gripper rolls from l1 to h2: nothing on the way
        return ObstaclePlan(ob, float(s), float(s - d1), float(l1), float(l2), d1, d2)
    return None


def hold_position(line: Line, params: BplirParams, k: int, front: float) -> ObstaclePlan:
    """The grips to pass obstacle ``k`` (0-based) with the front gripper now
    at ``front`` (m), at the first of :func:`spacing_pairs` that fits;
    :class:`LineError` when none does."""
    tp = params.traverse
    ob = line.obstacles[k]
    widest = max_width(params)
    where = f"obstacle '{ob.name}' ({ob.start:g}-{ob.end:g} m)"
    reach = f"grip spacings {tp.spacing_min:g}-{tp.spacing_max:g} m"
    if ob.width > widest:
        raise LineError(
            f"{where} is {ob.width:g} m wide; a swing with grip spacing {tp.spacing_max:g} m "
            f"straddles at most {widest:.3g} m (spacing - 2 x (clearance + gripper half-width) - "
            f"landing tolerance); allowed width (0, {widest:.3g}] m or a larger "
            f"traverse.spacing_max (reach < {params.plant.l1 + params.plant.l2:.3g} m)")
    # a front gripper that landed within the clearance of the obstacle rides
    # back to a grip before it; one touching it cannot
    if front + params.gripper.width / 2 > ob.start + 1e-9:
        raise LineError(f"{where}: the front gripper at {front:.3g} m touches it; the "
                        f"obstacles are too close together for {reach}")
    found = _first_fit(line, params, k)
    if found is not None:
        return found
    nxt = line.obstacles[k + 1] if k + 1 < len(line.obstacles) else None
    nxt_text = f" and before '{nxt.name}' at {nxt.start:g} m" if nxt is not None else ""
    raise LineError(f"{where}: no grip before it lands both swings clear of obstacles"
                    f"{nxt_text} and on the stretch (length {line.length:g} m) with {reach}; "
                    f"{closest_text(params, ob.width, nxt)}")


def _first_fit(line: Line, params: BplirParams, k: int) -> ObstaclePlan | None:
    """The grips of the first of :func:`spacing_pairs` that fits obstacle ``k``."""
    tp = params.traverse
    near = tp.clearance + params.gripper.width / 2
    hi = line.obstacles[k].start - near
    behind = line.obstacles[k - 1].end + near if k > 0 else 0.0
    for d1, d2 in spacing_pairs(params):
        found = _grips(line, k, hi, behind, d1, d2, near, near + tp.landing_tolerance)
        if found is not None:
            return found
    return None


def closest_gap(params: BplirParams, width: float, next_width: float = 0.0) -> float:
    """The shortest gap (m) between an obstacle ``width`` wide and the next
    one (``next_width``) that :func:`hold_position` passes on a straight
    line, to 1 mm; ``inf`` when an obstacle that wide is never passed."""
    if width > max_width(params):
        return math.inf

    def passes(gap: float) -> bool:
        obs = (Obstacle(5.0, width, "a"), Obstacle(5.0 + width + gap, next_width, "b"))
        line = Line(12.0 + width + gap, np.array([0.0, 20.0]), np.zeros(2), obs, 3.0)
        return _first_fit(line, params, 0) is not None

    lo, hi = 0.0, 2 * params.traverse.spacing_max + 1.0
    if not passes(hi):
        return math.inf
    while hi - lo > 1e-3:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if passes(mid) else (mid, hi)
    return hi


def closest_text(params: BplirParams, width: float, nxt: Obstacle | None) -> str:
    """What the route can pass next to an obstacle ``width`` wide (for errors)."""
    gap = closest_gap(params, width, 0.0 if nxt is None else nxt.width)
    if not math.isfinite(gap):
        return "no obstacle this wide can be passed"
    return (f"the closest obstacle it passes after one {width:g} m wide starts {gap:.3g} m "
            f"after it; move the obstacles apart or change traverse.spacing_min/spacing_max")


def plan_route(line: Line, params: BplirParams) -> list[ObstaclePlan]:
    """The planned grips of every obstacle, landings where planned; raises
    :class:`LineError` when the line cannot be crossed."""
    tp = params.traverse
    hw = params.gripper.width / 2
    D = tp.grip_spacing
    if line.start - D < 0.0 - 1e-9 or line.obstacle_at(line.start - D, hw + tp.clearance):
        raise LineError(f"the rear gripper's start {line.start - D:.3g} m (start - grip spacing "
                        f"{D:g} m) is off the stretch or on an obstacle; allowed start >= "
                        f"{D:g} m with both grips clear")
    if line.obstacle_at(line.start, hw + tp.clearance):
        raise LineError(f"the start {line.start:g} m is within a clearance of an obstacle")
    first = line.obstacles[0] if line.obstacles else None
    if first is not None and line.start > first.start:
        raise LineError(f"the start {line.start:g} m lies past the first obstacle "
                        f"'{first.name}' at {first.start:g} m; allowed start < {first.start:g} m")
    plans, front = [], line.start
    for k in range(len(line.obstacles)):
        p = hold_position(line, params, k, front)
        plans.append(p)
        front = p.landing2
    return plans


__all__ = ["ObstaclePlan", "hold_position", "plan_route", "max_width", "closest_gap",
           "spacing_pairs"]
