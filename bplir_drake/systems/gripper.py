"""Gripper interlock: the fixed gripper may only open once the free gripper
holds the line.

A small state machine updated every ``period`` (the controller's tick) from
the *true* plant state -- in the robot this is the gripper's contact/proximity
sensing, not the estimator.  Outcomes (docs/concepts.md, "Conventions"):

* ``captured``: first arrival -- after the vertical has been passed, the free
  gripper comes within ``capture_distance`` of the line (or crosses it
  between two updates) at least ``min_travel_fraction * D`` along the line
  from where it started -- at a speed ``<= capture_speed``;
* ``crash``: that first arrival is faster;
* ``timeout``: no arrival within ``max_time``;
* ``fault``: the driver's i^2 t interlock tripped (torque limit held longer
  than the driver allows), or the estimate or the applied torque became
  non-finite, before the arrival.

Only ``captured`` sets ``fixed_gripper_open``; the update that decides ends
the simulation (:func:`bplir_drake.simulate.run_until_outcome`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from pydrake.common.containers import namedview
from pydrake.systems.framework import EventStatus

from .pysystem import PySystem
from ..params import GripperParams, ScenarioParams
from .schedule import declare_store
from .state import Q1, Q1D, Q2, Q2D

OUTCOMES = ("swinging", "captured", "crash", "timeout", "fault")

#: the interlock's discrete state, in order: the status it outputs (the mode,
#: an index into :data:`OUTCOMES`; whether the fixed gripper is open; the
#: event's time; the speed, distance and travel at arrival; the closest
#: distance), then what its arrival search carries from tick to tick
#: (whether the vertical is passed, the last normal distance, the last state)
STATE_FIELDS = ("mode", "fixed_open", "event_time", "speed", "distance", "travel", "closest",
                "passed", "last_normal", "q1", "q2", "q1d", "q2d")
(MODE, FIXED_OPEN, EVENT_TIME, SPEED, DISTANCE, TRAVEL, CLOSEST, PASSED, LAST_NORMAL,
 LAST_STATE) = range(10)
#: the geometry array the compiled search reads: link lengths, incline, spacing
GEO_L1, GEO_L2, GEO_ALPHA, GEO_SPACING = range(4)


@dataclass(frozen=True)
class LineGeometry:
    """The true geometry the interlock judges: link lengths (m), line incline (rad) and grip
    spacing (m)."""
    l1: float
    l2: float
    alpha: float
    grip_spacing: float


def line_metrics(x, g: LineGeometry):
    """(distance to the line, signed; along-line position; travel from the
    start; gripper speed) of the free gripper at state ``x``."""
    return _metrics(float(x[Q1]), float(x[Q2]), float(x[Q1D]), float(x[Q2D]), g.l1, g.l2,
                    g.alpha, g.grip_spacing)


@njit(cache=True)
def _metrics(q1, q2, w1, w2, l1, l2, alpha, spacing):
    s1, c1, s12, c12 = math.sin(q1), math.cos(q1), math.sin(q1 + q2), math.cos(q1 + q2)
    px, py = l1 * s1 + l2 * s12, -l1 * c1 - l2 * c12   # (A.3)
    vx = l1 * c1 * w1 + l2 * c12 * (w1 + w2)
    vy = l1 * s1 * w1 + l2 * s12 * (w1 + w2)
    ca, sa = math.cos(alpha), math.sin(alpha)
    along = px * ca + py * sa
    normal = -px * sa + py * ca
    return normal, along, along + spacing, math.hypot(vx, vy)


@njit(cache=True)
def _state_metrics(x, geo):
    """:func:`_metrics` of the state ``x`` on the geometry array ``geo``."""
    return _metrics(x[Q1], x[Q2], x[Q1D], x[Q2D], geo[GEO_L1], geo[GEO_L2], geo[GEO_ALPHA],
                    geo[GEO_SPACING])


@njit(cache=True)
def hermite_state(x0, x1, T, s):
    """The state at ``t0 + s T`` between two ticks: cubic Hermite on the
    angles (their rates at both ends), its derivative for the rates."""
    s2, s3 = s * s, s * s * s
    h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, (s3 - 2 * s2 + s) * T, -2 * s3 + 3 * s2, \
        (s3 - s2) * T
    d00, d10, d01, d11 = (6 * s2 - 6 * s) / T, 3 * s2 - 4 * s + 1, (-6 * s2 + 6 * s) / T, \
        3 * s2 - 2 * s
    out = np.empty(4)
    for i in range(2):
        out[i] = h00 * x0[i] + h10 * x0[i + 2] + h01 * x1[i] + h11 * x1[i + 2]
        out[i + 2] = d00 * x0[i] + d10 * x0[i + 2] + d01 * x1[i] + d11 * x1[i + 2]
    return out


@njit(cache=True)
def _arrives(x0, x1, T, s, geo, band, travel_min, passed, last_normal):
    x = hermite_state(x0, x1, T, s)
    normal, _, travel, _ = _state_metrics(x, geo)
    passed = passed or (x[Q1] - geo[GEO_ALPHA]) > 0.0
    hit = passed and travel >= travel_min and (
        abs(normal) <= band or last_normal < 0.0 <= normal)
    return hit, x, passed, normal, travel


@njit(cache=True)
def arrival(x0, x1, T, geo, band, travel_min, passed, last_normal, substeps, bisections):
    """:func:`first_arrival` on arrays: ``geo`` = (l1, l2, alpha, spacing),
    ``band`` the capture distance, ``travel_min`` the least travel; returns
    ``(found, s, x, passed, normal, closest)``."""
    n1, _, travel1, v1 = _state_metrics(x1, geo)
    n0, _, _, v0 = _state_metrics(x0, geo)
    reach = 2.0 * T * max(v0, v1) + band
    if min(abs(n0), abs(n1)) > reach and n0 * n1 > 0.0:
        passed = passed or (x1[Q1] - geo[GEO_ALPHA]) > 0.0
        closest = abs(n1) if passed and travel1 > 0.0 else math.inf
        return False, 0.0, x1, passed, n1, closest
    closest = math.inf
    s_prev = 0.0
    x = x1
    for j in range(1, substeps + 1):
        s = j / substeps
        hit, x, passed_j, normal, travel = _arrives(x0, x1, T, s, geo, band, travel_min, passed,
                                                    last_normal)
        if passed_j and travel > 0.0:
            closest = min(closest, abs(normal))
        if hit:
            lo, hi = s_prev, s
            for _ in range(bisections):
                mid = 0.5 * (lo + hi)
                if _arrives(x0, x1, T, mid, geo, band, travel_min, passed, last_normal)[0]:
                    hi = mid
                else:
                    lo = mid
            _, x, _, normal, _ = _arrives(x0, x1, T, hi, geo, band, travel_min, passed,
                                          last_normal)
            return True, hi, x, True, normal, min(closest, abs(normal))
        passed, last_normal, s_prev = passed_j, normal, s
    return False, 0.0, x, passed, last_normal, closest


@njit(cache=True)
def interlock_update(d, x, t, period, geo, band, travel_min, tripped, estimate, torque,
                     max_time, fault, timeout):
    """One update of the interlock's state ``d`` (its :data:`GripperInterlock.State`,
    changed in place) to the true state ``x`` at ``t``, but for the figures of
    an arrival: the closest distance, whether the vertical is passed, the last
    normal distance and the state are stored; with no arrival in the tick, the
    mode is set to ``fault`` (the driver ``tripped``, or the ``estimate`` or the
    ``torque`` not finite) or ``timeout`` (``t`` at ``max_time``), at ``t``.
    Returns ``(found, s, x)`` of :func:`arrival`."""
    found, s, xa, passed, normal, closest = arrival(
        d[LAST_STATE:LAST_STATE + 4], x, period, geo, band, travel_min, d[PASSED] > 0.5,
        d[LAST_NORMAL], 8, 30)
    if closest < d[CLOSEST]:
        d[CLOSEST] = closest
    d[PASSED] = 1.0 if passed else 0.0
    if not found:
        finite = math.isfinite(torque)
        for v in estimate:
            finite = finite and math.isfinite(v)
        if tripped > 0.5 or not finite:
            d[MODE], d[EVENT_TIME] = fault, t
        elif t >= max_time - 1e-9:
            d[MODE], d[EVENT_TIME] = timeout, t
    d[LAST_NORMAL] = normal
    for j in range(4):
        d[LAST_STATE + j] = x[j]
    return found, s, xa


def first_arrival(x0, x1, T: float, g: LineGeometry, sc: ScenarioParams, passed: bool,
                  last_normal: float, substeps: int = 8, bisections: int = 30, *,
                  gripper: GripperParams | None = None):
    """The first arrival between two ticks, if any.

    Scans the Hermite interpolant between the tick states ``x0`` and ``x1``
    at ``substeps`` points; an arrival is the first point after the vertical
    (``passed``), at least ``min_travel_fraction * D`` along the line, within
    ``gripper.capture_distance`` of it (default :class:`GripperParams`) or
    across it since the previous point; its
    time is then refined by bisection.  The scan is skipped when the gripper
    cannot come near the line between the ticks (its distance at both ticks
    exceeds the band by more than twice the distance it can travel at the
    faster of its two speeds).  Returns ``(s, x, passed, normal, closest)``:
    ``s`` in (0, 1] (None without an arrival), the state there, the updated
    flags, and the closest distance seen after the vertical (compiled:
    :func:`arrival`)."""
    found, s, x, passed, normal, closest = arrival(
        np.asarray(x0, dtype=float), np.asarray(x1, dtype=float), T,
        np.array([g.l1, g.l2, g.alpha, g.grip_spacing]),
        (gripper or GripperParams()).capture_distance, sc.min_travel_fraction * sc.grip_spacing,
        passed, last_normal, substeps, bisections)
    return (s if found else None), x, passed, normal, closest


class GripperInterlock(PySystem):
    """Inputs ``state`` (true plant state), ``tripped`` (driver interlock),
    ``estimate`` (the filter's relative state) and ``torque`` (applied).
    Output ``status`` = the first :attr:`N` entries of :attr:`State`: mode
    index (:data:`OUTCOMES`), fixed gripper open, event time (s), speed at
    arrival (m/s), distance at arrival (m), travel at arrival (m), closest
    distance (m).

    Decides at every tick ``t_k`` (``period``, the controller rate) from the
    true state at ``t_{k-1}`` and ``t_k``: the first arrival in between is
    located on the cubic Hermite interpolant of the two states
    (:func:`first_arrival`), so its time and speed do not depend on the
    tick.  Once decided, the update ends the simulation
    (``EventStatus.ReachedTermination``)."""

    #: the discrete state, by name; the first ``N`` entries are the status
    State = namedview("InterlockState", STATE_FIELDS)
    N = PASSED

    def __init__(self, geometry: LineGeometry, scenario: ScenarioParams, period: float = 0.01,
                 gripper: GripperParams | None = None):
        super().__init__()
        self.geometry, self.scenario, self.period = geometry, scenario, period
        self.gripper = gripper or GripperParams()   # its capture criterion
        self._geo = np.array([geometry.l1, geometry.l2, geometry.alpha, geometry.grip_spacing])
        self._travel_min = scenario.min_travel_fraction * scenario.grip_spacing
        self._band = float(self.gripper.capture_distance)
        self._max_time = float(scenario.max_time)
        self._fault, self._timeout = float(OUTCOMES.index("fault")), float(OUTCOMES.index("timeout"))
        self.state_port = self.DeclareVectorInputPort("state", 4)
        self.tripped_port = self.DeclareVectorInputPort("tripped", 1)
        self.estimate_port = self.DeclareVectorInputPort("estimate", 4)
        self.torque_port = self.DeclareVectorInputPort("torque", 1)
        start = self.State(np.zeros(len(self.State._fields)))
        start.event_time = start.speed = start.distance = start.travel = math.nan
        start.closest, start.last_normal = math.inf, -math.inf
        self._xd = self.DeclareDiscreteState(start[:])
        self.DeclareInitializationDiscreteUpdateEvent(self._start)
        declare_store(self, period, self._update)
        self.status_port = self.DeclareVectorOutputPort("status", self.N, self._out,
                                                        {self.xd_ticket()})

    def _stored(self, context):
        return self.State(context.get_discrete_state(self._xd).get_value().copy())

    def _start(self, context, discrete_state):
        d = self._stored(context)
        d[LAST_STATE:LAST_STATE + 4] = self.state_port.Eval(context)   # at t_0
        discrete_state.get_mutable_vector(self._xd).SetFromVector(d[:])

    def _update(self, context, discrete_state):
        d = context.get_discrete_state(self._xd).get_value()
        if d[MODE] != 0:   # decided
            return EventStatus.ReachedTermination(self, "swing ended")
        d = d.copy()
        t = context.get_time()
        found, s, xa = interlock_update(
            d, self.state_port.Eval(context), t, self.period, self._geo, self._band,
            self._travel_min, self.tripped_port.Eval(context)[0],
            self.estimate_port.Eval(context), self.torque_port.Eval(context)[0],
            self._max_time, self._fault, self._timeout)
        if found:
            _, _, travel, speed = line_metrics(xa, self.geometry)
            ok = speed <= self.gripper.capture_speed
            d[MODE:CLOSEST] = (OUTCOMES.index("captured" if ok else "crash"), 1.0 if ok else 0.0,
                               t - self.period + s * self.period, speed, abs(d[LAST_NORMAL]),
                               travel)
        discrete_state.set_value(self._xd, d)
        if d[MODE] != 0:
            return EventStatus.ReachedTermination(self, "swing ended")
        return EventStatus.Succeeded()

    def _out(self, context, out):
        out.SetFromVector(context.get_discrete_state(self._xd).get_value()[:self.N])

    def outcome(self, context) -> str:
        """The outcome so far in ``context`` (root): one of
        :data:`OUTCOMES`."""
        return OUTCOMES[int(self._stored(self.GetMyContextFromRoot(context)).mode)]

    def status(self, context) -> dict:
        """The decision in ``context`` (root) with its figures (s, m/s, m)."""
        d = self._stored(self.GetMyContextFromRoot(context))
        return {"outcome": OUTCOMES[int(d.mode)], "fixed_gripper_open": bool(d.fixed_open > 0.5),
                "event_time_s": float(d.event_time), "capture_speed_mps": float(d.speed),
                "capture_distance_m": float(d.distance), "travel_m": float(d.travel),
                "closest_distance_m": float(d.closest)}
