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

:func:`hold_position` picks ``F``'s grip: as close to the obstacle as the
clearance allows, moved back until both planned landings keep the
clearance, the gripper's half-width and the landing tolerance from every
obstacle, the second lands before the next obstacle and on the stretch.
:func:`plan_route` runs it over the whole line with landings where planned
(raising :class:`~.line.LineError` for a line that cannot be crossed);
the traversal calls :func:`hold_position` again from where the robot
really is.  Only the nominal spacing and the line enter: never the
simulated robot.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...params import BplirParams
from .line import Line, LineError, Obstacle

#: step of the search for a hold position (m)
SEARCH_STEP = 0.005


@dataclass(frozen=True)
class ObstaclePlan:
    """The planned grips around one obstacle (positions along the line, m)."""

    obstacle: Obstacle
    hold: float       # F's grip for swing 1 (before the obstacle)
    rear: float       # the rear gripper's grip before swing 1 (hold - D)
    landing1: float   # swing 1 lands here (past the obstacle)
    landing2: float   # swing 2 lands here (F, ahead of landing1)


def max_width(params: BplirParams) -> float:
    """The widest obstacle a swing of the traversal's grip spacing straddles (m)."""
    tp = params.traverse
    margin = tp.clearance + tp.gripper_width / 2
    return tp.grip_spacing - 2 * margin - tp.landing_tolerance


def _clear(line: Line, s: float, margin: float) -> bool:
    return line.obstacle_at(s, margin) is None


def hold_position(line: Line, params: BplirParams, k: int, front: float) -> ObstaclePlan:
    """The grips to pass obstacle ``k`` (0-based) with the front gripper now
    at ``front`` (m); :class:`LineError` when none exist."""
    tp = params.traverse
    D = tp.grip_spacing
    ob = line.obstacles[k]
    hw = tp.gripper_width / 2
    near = tp.clearance + hw                      # a clasp next to an obstacle
    land = near + tp.landing_tolerance            # a planned landing
    widest = max_width(params)
    where = f"obstacle '{ob.name}' ({ob.start:g}-{ob.end:g} m)"
    if ob.width > widest:
        raise LineError(
            f"{where} is {ob.width:g} m wide; a swing with grip spacing {D:g} m straddles at most "
            f"{widest:.3g} m (spacing - 2 x (clearance + gripper half-width) - landing tolerance); "
            f"allowed width (0, {widest:.3g}] m or a larger traverse.grip_spacing (reach < "
            f"{params.plant.l1 + params.plant.l2:.3g} m)")
    hi = ob.start - near
    # the rear gripper stays on the stretch and past the previous obstacle
    behind = line.obstacles[k - 1].end + near if k > 0 else 0.0
    lo = max(ob.end + land - D, behind + D)
    nxt = line.obstacles[k + 1] if k + 1 < len(line.obstacles) else None
    if hi < front - 1e-9:
        raise LineError(f"{where}: the front gripper is at {front:.3g} m, less than "
                        f"{near:.3g} m before it; the obstacles are too close together for a "
                        f"grip spacing of {D:g} m")
    for s in np.arange(hi, lo - 1e-12, -SEARCH_STEP):
        l1, l2 = s + D, s + 2 * D
        if not (_clear(line, s, near) and _clear(line, s - D, near) and _clear(line, l1, land)
                and _clear(line, l2, land)):
            continue
        if nxt is not None and l2 > nxt.start - land:
            continue   # the second landing would pass the next obstacle with one gripper
        if l2 > line.length - land:
            continue   # the end of the stretch (a tower's clamp) is an obstacle too
        return ObstaclePlan(ob, float(s), float(s - D), float(l1), float(l2))
    nxt_text = f" and before '{nxt.name}' at {nxt.start:g} m" if nxt is not None else ""
    raise LineError(f"{where}: no grip from {lo:.3g} to {hi:.3g} m lands both swings clear of "
                    f"obstacles{nxt_text} and on the stretch (length {line.length:g} m) with "
                    f"grip spacing {D:g} m; move the obstacles apart or change "
                    "traverse.grip_spacing")


def plan_route(line: Line, params: BplirParams) -> list[ObstaclePlan]:
    """The planned grips of every obstacle, landings where planned; raises
    :class:`LineError` when the line cannot be crossed."""
    tp = params.traverse
    hw = tp.gripper_width / 2
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


__all__ = ["ObstaclePlan", "hold_position", "plan_route", "max_width"]
