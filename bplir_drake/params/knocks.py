"""Knocks: what pushes a robot at random moments of a run (``bplir
traverse --knocks``, a study's ``--knocks``, the benchmark's knockdown
category).

A knock is a torque pulse on a joint whose size is stated by its effect on
the robot left alone: a knock of severity ``s`` on a joint, acting on the
robot hanging at rest from gripper 1 with its motor off (no friction),
would swing the free link (link 2) ``s`` x :data:`SEVERITY_SWING_DEG` away
from hanging at its peak.  It lasts :data:`DURATION_SHARE` of the robot's
time unit ``sqrt(L/g)`` (``L`` its reach), so one rule serves every robot.
Knocks arrive ``60 / rate`` s apart on average, each gap drawn uniformly
within :data:`GAP_SPREAD` of its mean.  These are the conditions a run
faces, not the robot's parameters: the block is not part of
:class:`~bplir_drake.params.BplirParams`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from .blocks import ParameterError, _Block, _p

#: the free link's peak swing from hanging (deg) a knock of severity 1 gives
#: the robot hanging at rest, motor off
SEVERITY_SWING_DEG = 30.0

#: a knock's duration as a share of the robot's time unit sqrt(L/g)
DURATION_SHARE = 0.2

#: each gap between knocks is drawn uniformly within this share of the mean
#: gap either side (RealAIGym's knocks: 3.75 s apart, +/-1 s)
GAP_SPREAD = 1.0 / 3.75

#: the joints a knock pushes: one drawn at random, the elbow, the holding
#: gripper's joint, or both at once
KNOCK_JOINTS = ("either", "elbow", "hold", "both")

#: a benchmark swing's one knock falls this many of the robot's time units
#: sqrt(L/g) from its start at most: within the swing (the default robot's
#: swing from the line arrives after 2.9 of them)
SWING_KNOCK_WINDOW = 2.5

#: the severity of ``--knocks RATE`` without one: a knock that alone would
#: swing the free link 30 deg
STANDARD_SEVERITY = 1.0


@dataclass(frozen=True)
class Knocks(_Block):
    """The knocks of a run: how often, how hard, on which joints."""

    _name = "knocks"
    rate: float = _p(0.0, "1/min", 0, 600, doc="knocks a minute (0: none)")
    severity: float = _p(STANDARD_SEVERITY, "", 0, 4, doc="how hard: the free link's swing from rest, motor off, in units of 30 deg")
    joints: str = field(default="either", metadata=dict(doc="the joints a knock pushes: either (one drawn at random), elbow, hold (the holding gripper's) or both", allowed=", ".join(KNOCK_JOINTS)))

    def _check(self) -> None:
        self._one_of("joints", KNOCK_JOINTS)

    @property
    def active(self) -> bool:
        """Whether the run is knocked at all."""
        return self.rate > 0 and self.severity > 0

    def label(self) -> str:
        """``RATE:SEVERITY`` as the command line takes it."""
        return f"{self.rate:g}:{self.severity:g}"


def parse_knocks(text: str) -> Knocks:
    """``RATE[:SEVERITY[:JOINTS]]`` (knocks a minute, severity, joints) as
    :class:`Knocks`; a malformed text raises :class:`ParameterError` naming
    the allowed form."""
    parts = str(text).split(":")
    if not 1 <= len(parts) <= 3 or not all(p.strip() for p in parts):
        raise ParameterError(f"--knocks {text!r} must be RATE[:SEVERITY[:JOINTS]], e.g. 15 or "
                             "15:1.0 (knocks a minute in [0, 600], severity in [0, 4])")
    values = {}
    for name, part in zip(("rate", "severity"), parts[:2]):
        try:
            values[name] = float(part)
        except ValueError:
            raise ParameterError(f"--knocks {text!r}: {name} {part!r} is not a number; "
                                 "allowed RATE[:SEVERITY[:JOINTS]], rate in [0, 600] a "
                                 "minute, severity in [0, 4]") from None
    if len(parts) == 3:
        values["joints"] = parts[2].strip()
    return Knocks(**values)


__all__ = ["Knocks", "parse_knocks", "SEVERITY_SWING_DEG", "DURATION_SHARE", "GAP_SPREAD",
           "KNOCK_JOINTS", "STANDARD_SEVERITY", "SWING_KNOCK_WINDOW"]
