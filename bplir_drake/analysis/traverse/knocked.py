"""A traversal knocked at random moments, and its score.

:class:`KnockLog` hands the traversal's phases the knocks of its
:class:`~bplir_drake.analysis.model.knock.KnockClock` that fall in them and
keeps a row per knock: its time, the phase it met and what became of it.
Where both grippers hold the line (riding, setting the spacing, resting,
the IMUs' standstill on the line) the robot and the line are one rigid
chain in the model and the knock is absorbed (the IMUs' standstill average
sees the links return to the same pose).  In a swing, a pump, a catch or a try
again from hanging the knock is a torque pulse in the simulation; while the
robot damps its swing or hangs at rest before a try it is one too, and the
robot damps again.

:func:`knock_totals` scores a traversal: a **fall** is any end before the
line's end (the retry budget spent, a crash, the driver tripped, a landing
on an obstacle, a swing that could not be damped, no plan from hanging, or
a gripper opened while the other did not hold -- the interlock's fault,
counted apart); the **uptime** is the share of the run's
time the robot was on the line and making progress.  Riding, swinging,
resting, calibrating and recovering within the retry budget are up; after
a fall the robot is down for the time the rest of the line would have
taken at the pace it kept, so a fallen run's uptime is the share of the
line it crossed, a run that crossed the line has uptime 1.
"""
from __future__ import annotations

from ...params.follow import robot_scales
from ...params.knocks import Knocks
from ..model.knock import Knock, KnockClock, pulses_from

#: a knock this close before a swing's arrival, in the robot's time unit
#: sqrt(L/g), meets the catch
CATCH_SHARE = 0.5

#: the phases a knock can meet
PHASES = ("ride", "adjust", "rest", "calibrate", "swing", "pump", "catch", "retry", "damp",
          "hanging")

#: the recovery's ends that end a traversal (a fall's cause)
RECOVERY_ENDS = ("not damped", "no plan from hanging")

#: what became of a knock where both grippers hold
ABSORBED = "absorbed (both grippers hold)"


class KnockLog:
    """The knocks of one traversal (``knocks`` drawn from ``seed`` on the
    nominal robot ``plant``) and their rows."""

    def __init__(self, knocks: Knocks, plant, seed: int):
        self.clock = KnockClock(knocks, plant, seed)
        self.catch = CATCH_SHARE * robot_scales(plant)[0]
        self.rows: list[dict] = []

    def record(self) -> dict:
        """The knocks' rule, their size on this robot and one row each."""
        clock = self.clock
        return clock.knocks.as_dict() | {
            "torque_hold_Nm": clock.size[0], "torque_elbow_Nm": clock.size[1],
            "duration_s": clock.duration, "catch_s": self.catch, "rows": self.rows}

    def _log(self, k: Knock, phase: str, outcome: str) -> None:
        self.rows.append({"t_s": k.t, "phase": phase, "tau1_Nm": k.torque[0],
                          "tau2_Nm": k.torque[1], "outcome": outcome})

    def absorb(self, t1: float, phase: str) -> int:
        """The knocks before ``t1`` meet the robot held by both grippers;
        how many there were."""
        got = self.clock.take(t1)
        for k in got:
            self._log(k, phase, ABSORBED)
        return len(got)

    def first(self, t0: float, t1: float) -> Knock | None:
        """The next knock if it comes before ``t1`` (not handed out)."""
        got = self.clock.upcoming(t0, t1)
        return got[0] if got else None

    def pulses(self, t0: float, horizon: float):
        """The pulses of the knocks in a simulation of at most ``horizon``
        s from the run's ``t0`` (:func:`~..model.knock.pulses_from`)."""
        return pulses_from(self.clock.upcoming(t0, t0 + horizon), t0)

    def met(self, t0: float, duration: float, phase: str, outcome: str,
            arrived: bool = False) -> None:
        """The knocks a simulation from ``t0`` met in its ``duration`` s, in
        ``phase`` (the last :data:`CATCH_SHARE` of a swing that arrived
        meets the catch), the simulation's ``outcome``."""
        for k in self.clock.take(t0 + duration):
            here = phase
            if arrived and phase in ("swing", "pump", "retry") and k.t >= t0 + duration - self.catch:
                here = "catch"
            self._log(k, here, outcome)


def knock_totals(tr, dist: float) -> dict:
    """The knock columns of a traversal's totals: knocks met and by phase,
    whether it fell and why, falls the interlock caused, the uptime
    (``dist``: the distance it crossed, m)."""
    rows = tr.knocks.rows if tr.knocks is not None else []
    passed = tr.outcome == "passed"
    whole = tr.line.length - tr.params.gripper.width / 2 - tr.line.start
    out = {"knocks": len(rows), "fall": not passed, "fall_cause": "" if passed else _cause(tr),
           "interlock_fall": bool(tr.fixed_open),
           "uptime": 1.0 if passed else min(max(dist / whole, 0.0), 1.0) if whole > 0 else 0.0}
    for phase in PHASES:
        out[f"knocks_{phase}"] = sum(1 for r in rows if r["phase"] == phase)
    return out


def _cause(tr) -> str:
    """Why a traversal fell: its outcome, or what ended the recovery after
    its last swing (the swing could not be damped, no plan from hanging)."""
    last = tr.rows[-1] if tr.rows else None
    if last is not None and last.kind == "recover" and last.outcome in RECOVERY_ENDS:
        return last.outcome
    return tr.outcome


def knocks_or_none(knocks: Knocks | None) -> Knocks | None:
    """``knocks`` when they knock at all, else None."""
    return knocks if knocks is not None and knocks.active else None


__all__ = ["KnockLog", "knock_totals", "knocks_or_none", "CATCH_SHARE", "PHASES", "ABSORBED"]
