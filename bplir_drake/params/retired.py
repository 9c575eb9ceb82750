"""Fields that are no longer parameters, and what decides in their place.

A field leaves the parameters when a rule or another field decides what it
did (the robot held by its other gripper lands by the same settings as the
robot held by the first: it is another robot, not a variant).  Files
written before still load: a retired field is dropped, silently where its
value is the one that now decides, with one ``FutureWarning`` naming the
field that decides where it is not.
"""
from __future__ import annotations

import warnings
from dataclasses import fields
from typing import Any

#: retired ``(block, field)`` -> ``(block, field)`` whose value decides now,
#: or a value the retired field always had where nothing replaces it
RETIRED: dict[tuple[str, str], tuple[str, str] | float] = {
    ("estimator", "loop_gyro_meas_sigma"): ("estimator", "tuned_gyro_noise"),
    ("estimator", "loop_inflate_nis"): ("estimator", "inflate_nis"),
    ("traverse", "swapped_landing_margin"): ("landing", "landing_margin"),
    ("traverse", "swapped_landing_law"): ("landing", "landing_law"),
    ("traverse", "swapped_shoot_min_time"): ("landing", "shoot_min_time"),
    ("traverse", "swapped_shoot_height"): ("landing", "shoot_height"),
    ("traverse", "swapped_shoot_rate_cap"): ("landing", "shoot_rate_cap"),
    ("traverse", "swapped_inflate_nis"): ("estimator", "inflate_nis"),
    ("traverse", "swapped_line_range"): ("line_sensor", "range"),
    ("plan", "hanging_rate_limit"): 0.0,
}


#: fields that moved to another block: ``(block, field)`` -> ``(block, field)``
#: (the capture criterion is the gripper's, a property of the robot)
MOVED: dict[tuple[str, str], tuple[str, str]] = {
    ("scenario", "capture_distance"): ("gripper", "capture_distance"),
    ("scenario", "capture_speed"): ("gripper", "capture_speed"),
    ("traverse", "gripper_width"): ("gripper", "width"),
}


def move_fields(data: dict[str, Any]) -> dict[str, Any]:
    """``data`` (tables by block) with moved fields in their new block (a
    value the new block gives itself wins), with one ``FutureWarning``."""
    out, moved = dict(data), []
    for (block, name), (to, new) in MOVED.items():
        table = out.get(block)
        if not isinstance(table, dict) or name not in table:
            continue
        out[block] = {k: v for k, v in table.items() if k != name}
        target = out.get(to)
        target = dict(target) if isinstance(target, dict) else {}
        out[to] = {new: table[name]} | target
        moved.append(f"{block}.{name} is now {to}.{new}")
    if moved:
        warnings.warn("; ".join(moved), FutureWarning, stacklevel=3)
    return out


def drop_retired(data: dict[str, Any], blocks: dict[str, type]) -> dict[str, Any]:
    """``data`` (tables by block) with moved fields moved (:func:`move_fields`)
    and without its retired fields; one ``FutureWarning`` lists those whose
    value is not what decides now."""
    data = move_fields(data)
    out, ignored = dict(data), []
    for (block, name), now in RETIRED.items():
        table = out.get(block)
        if not isinstance(table, dict) or name not in table:
            continue
        value = table[name]
        out[block] = {k: v for k, v in table.items() if k != name}
        decides = now if not isinstance(now, tuple) else _value(data, blocks, *now)
        if value != decides:
            where = f"{now[0]}.{now[1]} ({decides!r})" if isinstance(now, tuple) else repr(now)
            ignored.append(f"{block}.{name} = {value!r} (now {where})")
    if ignored:
        warnings.warn("retired parameters ignored: " + "; ".join(ignored),
                      FutureWarning, stacklevel=3)
    return out


def _value(data: dict, blocks: dict[str, type], block: str, name: str) -> Any:
    """``block.name`` as ``data`` gives it, else the block's default."""
    table = data.get(block)
    if isinstance(table, dict) and name in table:
        return table[name]
    return {f.name: f.default for f in fields(blocks[block])}[name]
