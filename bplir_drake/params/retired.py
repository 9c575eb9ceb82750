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

from .sensing import CHAPTER5_TUNING

#: retired ``(block, field)`` -> ``(block, field)`` whose value decides now,
#: or a value the retired field always had where nothing replaces it
RETIRED: dict[tuple[str, str], tuple[str, str] | float] = {
    ("estimator", "loop_gyro_meas_sigma"): ("estimator", "gyro_meas_sigma"),
    ("estimator", "loop_inflate_nis"): ("estimator", "inflate_nis"),
    ("traverse", "swapped_landing_margin"): ("landing", "landing_margin"),
    ("traverse", "swapped_landing_law"): ("landing", "landing_law"),
    ("traverse", "swapped_shoot_min_time"): ("landing", "shoot_min_time"),
    ("traverse", "swapped_shoot_height"): ("landing", "shoot_height"),
    ("traverse", "swapped_shoot_rate_cap"): ("landing", "shoot_rate_cap"),
    ("traverse", "swapped_inflate_nis"): ("estimator", "inflate_nis"),
    ("traverse", "swapped_line_range"): ("line_sensor", "range"),
    ("plan", "hanging_rate_limit"): 0.0,
    ("traverse", "swapped_retry_end_depth"): 0.0,   # the free link's pose decides
}

#: retired fields a manoeuvre's rule in the robot's units decides now
#: (``params.derive``): ``(block, field)`` -> (the rule, its value on the
#: default robot, which a file may give silently)
RULED: dict[tuple[str, str], tuple[str, float]] = {
    ("traverse", "plan_end_depth"): ("derive.TRAVERSE_END_SHARE of the capture band", 0.013),
    ("traverse", "retry_max_time"): ("derive.RETRY_TIME sqrt(L/g)", 6.0),
    ("traverse", "retry_lift_min_time"): ("derive.RETRY_LIFT_HOLD sqrt(L/g)", 0.05),
}


#: fields that moved to another block: ``(block, field)`` -> ``(block, field)``
#: (the capture criterion is the gripper's, a property of the robot; how a
#: swing from hanging is planned is the ``[hanging]`` block's)
MOVED: dict[tuple[str, str], tuple[str, str]] = {
    ("scenario", "capture_distance"): ("gripper", "capture_distance"),
    ("scenario", "capture_speed"): ("gripper", "capture_speed"),
    ("traverse", "gripper_width"): ("gripper", "width"),
    ("plan", "hanging_torque_share"): ("hanging", "torque_share"),
    ("plan", "hanging_supply"): ("hanging", "supply_voltage"),
    ("plan", "hanging_i2t_share"): ("hanging", "i2t_share"),
}


def relocate(data: dict[str, Any], moves: dict[tuple[str, str], tuple[str, str]]
             ) -> tuple[dict[str, Any], list[str]]:
    """``data`` (tables by block) with each field of ``moves`` the data gives
    in its new block (a value the new block gives itself wins), and the
    moves made, as ``"block.field is now block.field"``."""
    out, moved = dict(data), []
    for (block, name), (to, new) in moves.items():
        table = out.get(block)
        if not isinstance(table, dict) or name not in table:
            continue
        out[block] = {k: v for k, v in table.items() if k != name}
        target = out.setdefault(to, {})
        if isinstance(target, dict):   # a malformed one is left to be refused
            out[to] = {new: table[name]} | target
        moved.append(f"{block}.{name} is now {to}.{new}")
    return out, moved


def move_fields(data: dict[str, Any]) -> dict[str, Any]:
    """``data`` with the fields of :data:`MOVED` in their new block
    (:func:`relocate`), with one ``FutureWarning``."""
    out, moved = relocate(data, MOVED)
    if moved:
        warnings.warn("; ".join(moved), FutureWarning, stacklevel=3)
    return out


#: the swing's filter tuning, once beside the dissertation's as ``loop_*``
#: fields (and its gyro noise as ``tuned_gyro_noise``): in a table that has
#: them, their values are the filter's fields; the table's own values of
#: those fields were the offline filter's, now ``EstimatorParams.chapter5()``
LOOP_TUNING = {"loop_accel_process_sigma": "accel_process_sigma",
               "loop_accel_meas_sigma": "accel_meas_sigma",
               "tuned_gyro_noise": "gyro_meas_sigma",
               "loop_integration": "integration",
               "loop_estimate_misalignment": "estimate_misalignment"}


def loop_tuning(table: dict[str, Any]) -> tuple[dict[str, Any], list[str]]:
    """An ``[estimator]`` table written before the filter had one tuning, as
    the filter's fields (:data:`LOOP_TUNING`); and the offline values it set
    that are not the dissertation's, which no longer decide.  A table
    without ``loop_*`` fields is returned as it is."""
    if not any(k in table for k in LOOP_TUNING):
        return table, []
    offline = {new: table[new] for new in LOOP_TUNING.values() if new in table}
    out = {k: v for k, v in table.items() if k not in LOOP_TUNING and k not in offline}
    for old, new in LOOP_TUNING.items():
        if old in table:
            out[new] = table[old]
    if "loop_estimate_misalignment" in table:   # the swing estimated them when either said so
        out["estimate_misalignment"] = bool(table["loop_estimate_misalignment"]
                                            or offline.get("estimate_misalignment", False))
    ignored = [f"estimator.{k} = {v!r} (the offline filter's; now EstimatorParams.chapter5())"
               for k, v in offline.items() if k in CHAPTER5_TUNING and v != CHAPTER5_TUNING[k]
               and k != "estimate_misalignment"]
    return out, ignored


def named_landing_law(table: dict[str, Any]) -> tuple[dict[str, Any], list[str]]:
    """A ``[landing]`` table written when ``landing_lead = 0`` switched the
    apex laws off (the reach on, where ``reach_speed`` was set), as the law
    by name: ``landing_law = "reach"`` or ``"none"``, the lead left at its
    default; and what was read so.  Another table is returned as it is."""
    if table.get("landing_lead") != 0:
        return table, []
    law = "reach" if (table.get("reach_speed") or 0) > 0 else "none"
    out = {k: v for k, v in table.items() if k != "landing_lead"} | {"landing_law": law}
    return out, [f"landing.landing_lead = 0 (now landing.landing_law = {law!r})"]


def fitted_line_sensor(table: dict[str, Any]) -> tuple[dict[str, Any], list[str]]:
    """A ``[line_sensor]`` table written when ``range > 0`` fitted the sensor
    and ``range = 0`` meant none, as ``fitted`` and the range: the same
    sensor, or none (the range then left at its default); and what was read
    so.  A table that says ``fitted`` is returned as it is."""
    if "fitted" in table or "range" not in table:
        return table, []
    out = {k: v for k, v in table.items() if k != "range"}
    if table["range"] == 0:
        return out | {"fitted": False}, []   # what a table without range means too
    return out | {"fitted": True, "range": table["range"]}, [
        f"line_sensor.range = {table['range']!r} (now line_sensor.fitted = true, and the range)"]


def named_lift_law(table: dict[str, Any]) -> tuple[dict[str, Any], list[str]]:
    """A ``[landing]`` table written when ``shoot_lift_min_time > 0`` chose
    the shot where the elbow lifts the gripper (0: the aim law), as
    ``lift_law`` and the hold; and what was read so.  A table that says
    ``lift_law`` is returned as it is."""
    if "lift_law" in table or "shoot_lift_min_time" not in table:
        return table, []
    hold = table["shoot_lift_min_time"]
    out = {k: v for k, v in table.items() if k != "shoot_lift_min_time"}
    if hold == 0:
        return out | {"lift_law": "aim"}, []   # what a table without it means too
    return out | {"lift_law": "shoot", "shoot_lift_min_time": hold}, [
        f"landing.shoot_lift_min_time = {hold!r} without landing.lift_law (now lift_law = "
        "'shoot' and the hold)"]


def drop_retired(data: dict[str, Any], blocks: dict[str, type]) -> dict[str, Any]:
    """``data`` (tables by block) with moved fields moved (:func:`move_fields`)
    and without its retired fields; one ``FutureWarning`` lists those whose
    value is not what decides now."""
    data = move_fields(data)
    out, ignored = dict(data), []
    if isinstance(out.get("estimator"), dict):
        out["estimator"], ignored = loop_tuning(out["estimator"])
        data = out
    if isinstance(out.get("landing"), dict):
        out["landing"], switched = named_landing_law(out["landing"])
        out["landing"], lifted = named_lift_law(out["landing"])
        ignored += switched + lifted
        data = out
    table = out.get("traverse")
    if isinstance(table, dict) and "landing" in table:   # plan tracking alone: a law's name now
        out["traverse"] = {k: v for k, v in table.items() if k != "landing"}
        if table["landing"] is False:
            out["landing"] = dict(out.get("landing") or {}) | {"landing_law": "none"}
            ignored.append("traverse.landing = false (now landing.landing_law = 'none')")
        data = out
    if isinstance(out.get("line_sensor"), dict):
        out["line_sensor"], switched = fitted_line_sensor(out["line_sensor"])
        ignored += switched
        data = out
    for (block, name), (rule, value) in RULED.items():
        table = out.get(block)
        if isinstance(table, dict) and name in table:
            if table[name] != value:
                ignored.append(f"{block}.{name} = {table[name]!r} (now the rule {rule})")
            out[block] = {k: v for k, v in table.items() if k != name}
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
