"""A traversal's tables: the manoeuvre table, the totals and the per-swing rows as CSV."""
from __future__ import annotations

import math
from .traverse_result import ROW_FIELDS, TraverseResult, TraverseTotals
import io as _io
from ...io import write_text_atomic
import csv

from ...systems.motor import interlock_budget
from .knocked import PHASES, knock_totals


#: columns of the per-manoeuvre table: (row key, header, format), the
#: landing's figures in mm (rows hold metres)
TABLE_COLUMNS = (
    ("index", "#", "{}"), ("kind", "manoeuvre", "{}"), ("obstacle", "obstacle", "{}"),
    ("holding_gripper", "holds", "{}"), ("from_m", "from [m]", "{:.3f}"),
    ("to_m", "to [m]", "{:.3f}"), ("incline_deg", "incline [deg]", "{:.1f}"),
    ("outcome", "outcome", "{}"), ("attempt", "try", "{:.0f}"), ("duration_s", "time [s]", "{:.2f}"),
    ("capture_speed_mps", "capture [m/s]", "{:.3f}"),
    ("landing_bias_m", "aim raised [mm]", "mm"),
    ("landing_height_error_m", "height error [mm]", "mm"),
    ("capture_impulse_Ns", "impulse [N s]", "{:.2f}"),
    ("peak_torque_Nm", "peak torque [N m]", "{:.1f}"), ("peak_power_W", "peak power [W]", "{:.0f}"),
    ("peak_voltage_V", "peak voltage [V]", "{:.1f}"),
    ("energy_J", "energy [J]", "{:.1f}"), ("i2t_end_A2s", "i2t after [A2 s]", "{:.0f}"),
)


def _cell(value, fmt: str) -> str:
    if isinstance(value, float) and not math.isfinite(value):
        return "--"
    if value == "":
        return ""
    if fmt == "mm":
        return f"{1e3 * value:+.1f}"
    return fmt.format(value)


def manoeuvre_table(result: TraverseResult) -> str:
    """The per-manoeuvre table as Markdown (``--`` where a figure does not apply)."""
    head = "| " + " | ".join(h for _, h, _ in TABLE_COLUMNS) + " |"
    rule = "|" + "---|" * len(TABLE_COLUMNS)
    body = ["| " + " | ".join(_cell(r[k], f) for k, _, f in TABLE_COLUMNS) + " |"
            for r in result.rows]
    return "\n".join([head, rule] + body)


def failed_swing_line(result: TraverseResult) -> str | None:
    """Which swing ended a traversal that did not pass, in words: where it
    was (the obstacle, the holding gripper, from and to), how far it
    reached, how it started and what it tried (None: the line was passed)."""
    swings = [r for r in result.rows if r.kind == "swing"]
    if result.totals["outcome"] == "passed" or not swings:
        return None
    r = swings[-1]
    start = "from the line" if r.attempt == 1 else f"from hanging (try {r.attempt})"
    def known(v):
        return isinstance(v, (int, float)) and math.isfinite(v)
    span = f", from {r.from_m:.3f} m" if known(r.from_m) else ""
    span += f" to {r.to_m:.3f} m" if known(r.to_m) else " (reaching for the next grip)"
    return (f"the swing that ended it: manoeuvre {r.index}, past the {r.obstacle}, holding "
            f"with gripper {r.holding_gripper}{span}, {start}, on a {r.incline_deg:+.1f} deg "
            f"line: {r.outcome}")


def totals_lines(result: TraverseResult) -> list[str]:
    """The totals as text lines (and which swing ended it, when it did not pass)."""
    t = result.totals
    failed = failed_swing_line(result)
    return ([failed] if failed else []) + [
        f"{t['outcome']}: {t['obstacles_passed']}/{t['obstacles']} obstacles passed in "
        f"{t['swings']} swings" + (f" ({t['retries']} tried again after a timeout, "
                                   f"{t['recover_time_s']:.0f} s damping)"
                                   if t.get("retries") else "") +
        f", {t['distance_m']:.2f} m in {t['time_s']:.1f} s "
        f"({t['speed_m_per_min']:.1f} m/min; riding {t['ride_time_s']:.1f} s, swinging "
        f"{t['swing_time_s']:.1f} s, resting {t['rest_time_s']:.1f} s, IMU calibration "
        f"{t['calibration_time_s']:.1f} s)",
        f"energy {t['energy_J']:.0f} J ({t['energy_per_m_J']:.1f} J/m): riding "
        f"{t['energy_ride_J']:.1f} J, swinging {t['energy_swing_J']:.1f} J, electronics "
        f"{t['energy_standby_J']:.1f} J; peak capture impulse {t['peak_capture_impulse_Ns']:.2f} "
        f"N s; peak i2t {t['peak_i2t_A2s']:.0f} of {t['i2t_budget_A2s']:.0f} A2 s; seed "
        f"{t['seed']}",
    ] + knock_lines(t)


def knock_lines(t) -> list[str]:
    """A knocked traversal's knocks, uptime and fall as a text line (none
    for a traversal nobody knocked)."""
    if "uptime" not in t:
        return []
    met = ", ".join(f"{p} {t[f'knocks_{p}']}" for p in PHASES if t[f"knocks_{p}"])
    fell = (f"fell ({t['fall_cause']}{', the interlock' if t['interlock_fall'] else ''})"
            if t["fall"] else "no fall")
    return [f"knocks: {t['knocks']} ({met or 'none'}); uptime {t['uptime']:.3f}; {fell}"]


def write_rows_csv(result: TraverseResult, path):
    """The per-manoeuvre rows as CSV at ``path`` (atomic)."""


    buf = _io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(ROW_FIELDS))
    w.writeheader()
    for r in result.rows:
        w.writerow({k: r[k] for k in ROW_FIELDS})
    return write_text_atomic(path, buf.getvalue())


def traverse_totals(tr) -> TraverseTotals:
    """The totals of the traversal ``tr`` (the state :func:`~.run.run_traverse`
    carried): outcome, the first failed swing (swings counted, not their
    tries), the worst figures of its swings, times, energies, i^2 t; a
    knocked traversal's knocks, falls and uptime (:func:`~.knocked.knock_totals`)."""
    swings = [r for r in tr.rows if r.kind == "swing"]
    rides = [r for r in tr.rows if r.kind in ("ride", "adjust")]
    energy = sum(tr.energy.values())
    dist = max(tr.rear - (tr.line.start - tr.params.traverse.grip_spacing), 0.0)
    # the driver's i^2 t peaks within a manoeuvre, not only at its end
    peak_i2t = max([r.i2t_end_A2s for r in tr.rows] + [tr.motion.peak_i2t])
    first = sum(1 for r in swings if r.attempt == 1)   # swings, not their tries
    failed = [first - 1] if swings and swings[-1].outcome != "captured" else []
    speeds = [r.capture_speed_mps for r in swings if r.outcome == "captured"]
    return TraverseTotals({
        "failed_swing": failed[0] if failed else math.nan,
        "capture_speed_mps": max(speeds) if speeds else math.nan,
        "peak_torque_Nm": max([r.peak_torque_Nm for r in swings] + [0.0]),
        "peak_motor_power_W": max([r.peak_power_W for r in swings] + [0.0]),
        "peak_voltage_V": max([r.peak_voltage_V for r in swings] + [0.0]),
        "max_estimation_error_rad": tr.est_err,
        "fixed_gripper_open": tr.fixed_open,
        "outcome": tr.outcome, "success": tr.outcome == "passed",
        "obstacles": len(tr.line.obstacles),
        "obstacles_passed": sum(1 for r in swings if r.outcome == "captured") // 2,
        "swings": first, "retries": len(swings) - first,
        "recover_time_s": sum(r.duration_s for r in tr.rows if r.kind == "recover"),
        "distance_m": dist, "time_s": tr.t,
        "swing_time_s": sum(r.duration_s for r in swings),
        "ride_time_s": sum(r.duration_s for r in rides),
        "rest_time_s": sum(r.duration_s for r in tr.rows if r.kind == "rest"),
        "calibration_time_s": sum(r.duration_s for r in tr.rows
                                  if r.kind == "calibrate"),
        "speed_m_per_min": 60.0 * dist / tr.t if tr.t > 0 else math.nan,
        "energy_J": energy, "energy_ride_J": tr.energy["ride"],
        "energy_swing_J": tr.energy["swing"], "energy_standby_J": tr.energy["standby"],
        "energy_per_m_J": energy / dist if dist > 0 else math.nan,
        "peak_capture_impulse_Ns": max([r.capture_impulse_Ns for r in swings
                                        if not math.isnan(r.capture_impulse_Ns)] + [0.0]),
        "peak_i2t_A2s": peak_i2t, "i2t_budget_A2s": interlock_budget(tr.params.motor),
        "seed": tr.seed,
    } | (knock_totals(tr, dist) if getattr(tr, "knocks", None) is not None else {}))
