"""The landing laws of plan tracking: reaching for the line, the aim landing and the apex shot, the line servo that holds the gripper on it, and the choice among them."""
from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
import numpy as np
from ..params.blocks import number_or
from . import nominal_kernel
from .plant import bias_term, gravity_vector, mass_matrix


class _LineServo:
    """What the terminal laws share: built from the ``landing`` block's fields
    named ``<prefix>_<field>``, and the gripper's distance to the line."""

    _prefix = ""

    @classmethod
    def from_params(cls, plant, alpha: float, landing):
        """The law of the ``landing`` block
        (:class:`~bplir_drake.params.LandingParams`, its ``<prefix>_*``
        fields) on the nominal ``plant`` for a line inclined by ``alpha``
        (rad)."""
        names = [f.name for f in fields(cls) if f.name not in ("plant", "alpha")]
        return cls(plant, alpha, **{n: number_or(getattr(landing, f"{cls._prefix}_{n}"))
                                    for n in names})

    def height(self, x) -> float:
        """The gripper's distance to the line (m, negative below it)."""
        return height_rates(self.plant, self.alpha, x)[0]


@dataclass(frozen=True)
class Reach(_LineServo):
    """The terminal reach: once the gripper is ``depth`` from the line in
    the plan's second half (or the plan has ended), the elbow servoes the
    gripper's distance to the line ``h`` instead of tracking the plan.

    Persistent torque errors (wind, wrong inertia) change the swing's
    energy, and a clock-indexed plan that ends at rest just inside the
    capture band then either falls short or arrives fast.  The reach makes
    the last centimetres a feedback task: ``h'`` follows the profile
    ``sqrt(speed^2 + 2 brake |aim - h|)`` toward ``aim`` (``lift``; while the
    gripper slides along the line faster than ``tangent`` the aim is
    ``hold``, outside the band, so that it enters the band slowly in both
    directions).  The elbow torque comes from partial feedback linearisation
    of the output ``h`` on the nominal model (``h'' = rate_gain (h'_cmd -
    h')``, link 1 passive), clipped by the tracker."""

    plant: object
    alpha: float
    speed: float
    depth: float
    lift: float
    brake: float
    tangent: float
    hold: float
    rate_gain: float
    _prefix = "reach"

    def takes_over(self, x) -> bool:
        """Whether the reach takes over (in the plan's final forward swing)."""
        return self.height(x) > -self.depth

    def torque(self, x) -> float:
        """The elbow torque of the reach at the relative state ``x``."""
        p = self.plant
        h, hd, along = height_rates(p, self.alpha, x)
        aim = self.hold if self.tangent > 0 and abs(along) > self.tangent else self.lift
        e = aim - h
        hd_cmd = np.sign(e) * np.sqrt(self.speed ** 2 * (e > 0) + 2.0 * self.brake * abs(e))
        return height_torque(p, self.alpha, x, self.rate_gain * (hd_cmd - hd))


@dataclass(frozen=True)
class Landing(_LineServo):
    """The apex landing: in the plan's last forward swing of link 1, once
    the gripper is ``depth`` from the line or link 1 has slowed below
    ``take_rate`` while decelerating, the elbow places the gripper so that
    it reaches the line when link 1 comes to rest, wherever that is.

    A wrong model or a steady wind changes the swing's energy; link 1 then
    turns back before or after the plan's end, and a plan followed by the
    clock is below the line there (a timeout) or still fast (a crash).  The
    landing reads the energy left from link 1's rate instead: the gripper's
    aimed distance to the line is ``h* = -margin - lead q1'`` (never above
    the line), so it rises as link 1 slows and is ``margin`` below the line,
    inside the capture band, when link 1 stops.  ``h`` follows ``h*`` by
    ``h'_cmd = lead a + gain (h* - h)`` (``lead a``: the rate of ``h*`` with
    link 1 decelerating at ``a``, its deceleration on the nominal model with
    the elbow held), through a partial feedback linearisation of ``h``
    (``h'' = rate_gain (h'_cmd - h')``, link 1 passive, nominal model)."""

    plant: object
    alpha: float
    lead: float
    depth: float
    margin: float
    take_rate: float
    gain: float
    rate_gain: float
    min_decel: float
    _prefix = "landing"

    @classmethod
    def from_params(cls, plant, alpha: float, landing):
        """The law of ``landing`` (its ``landing_*`` fields), its margin less
        ``landing.landing_bias`` (never above the line)."""
        law = super().from_params(plant, alpha, landing)
        return replace(law, margin=max(0.0, law.margin - landing.landing_bias))

    def deceleration(self, x) -> float:
        """Link 1's deceleration ``b1 / M11`` on the nominal model with the
        elbow held (rad/s^2; negative while gravity speeds it up): the first
        rows of :func:`~bplir_drake.systems.plant.bias_term`,
        :func:`~bplir_drake.systems.plant.gravity_vector` and
        :func:`~bplir_drake.systems.plant.mass_matrix`, in the same
        arithmetic, their constants worked out once (it runs every tick)."""
        dc1, dc2, m11_0, m11_c, h_0, g1, g2, l1, rc2 = self.decel_constants()
        q0, q1, v0, v1 = float(x[0]), float(x[1]), float(x[2]), float(x[3])
        h = h_0 * math.sin(q1 + dc2)
        b0 = -h * (2.0 * v0 * v1 + v1 ** 2) + (
            g1 * math.sin(q0 + dc1) + g2 * (l1 * math.sin(q0) + rc2 * math.sin(q0 + q1 + dc2)))
        return b0 / (m11_0 + m11_c * math.cos(q1 + dc2))

    def decel_constants(self) -> tuple:
        """The constants of :meth:`deceleration`, worked out once: (dc1, dc2,
        M11's constant part and its cos(q2 + dc2) factor, the Coriolis
        factor, the two gravity factors, l1, rc2)."""
        c = self.__dict__.get("_decel")
        if c is None:
            p = self.plant
            r1, r2 = p.rc1, p.rc2
            a = p.I2 + p.m2 * r2 ** 2
            c = (p.dc1, p.dc2, p.m1 * r1 ** 2 + p.I1 + p.m2 * p.l1 ** 2 + a,
                 2.0 * p.m2 * p.l1 * r2, p.m2 * p.l1 * p.rc2, p.m1 * p.g * p.rc1, p.m2 * p.g,
                 p.l1, p.rc2)
            object.__setattr__(self, "_decel", c)
        return c

    def takes_over(self, x) -> bool:
        """Whether the landing takes over (asked in the plan's last forward
        swing of link 1 only)."""
        return self.height(x) > -self.depth or (
            self.deceleration(x) >= self.min_decel and 0.0 <= x[2] < self.take_rate)

    def aim(self, x) -> tuple[float, float]:
        """(h*, its rate): the aimed distance of the gripper to the line (m)
        and how fast it rises (m/s)."""
        aim = -self.margin - self.lead * float(x[2])
        if aim >= 0.0:
            return 0.0, 0.0
        return aim, self.lead * max(self.deceleration(x), 0.0)

    def torque(self, x) -> float:
        """The elbow torque of the landing at the relative state ``x``."""
        h, hd, _ = height_rates(self.plant, self.alpha, x)
        aim, rate = self.aim(x)
        hd_cmd = rate + self.gain * (aim - h)
        return height_torque(self.plant, self.alpha, x, self.rate_gain * (hd_cmd - hd))


@dataclass(frozen=True)
class ApexShot:
    """The shooting landing: from ``depth`` below the line, every tick it
    solves on the nominal model (with its friction) for the time ``T`` at
    which link 1 stops and the elbow angle ``q2f`` that puts the gripper
    ``height`` from the line then (negative: inside the capture band), the
    elbow following the quartic from its present angle and rate to ``q2f``
    at rest with zero acceleration (Newton on ``(T, q2f)``, link 1
    passive), and commands the quartic's first acceleration through the
    elbow's computed torque.  With less than ``min_time`` to go, or link 1
    slower than ``min_rate``, ``T`` is held at ``min_time`` and only
    ``q2f`` is solved for, if the gripper is within ``hold_depth`` of the
    aimed height (a held shot far below it asks for absurd accelerations).
    Where no solution is found it falls back to the apex landing
    ``landing``.

    It corrects the swing's energy while the elbow still has leverage on
    the gripper's height: where the free link ends near upright (a long
    holding link and a short free one, :func:`~bplir_drake.params.robot.line_pose`),
    the elbow moves the gripper along the line rather than up at the end,
    and the aim law, which acts only then, lags."""

    landing: Landing
    friction: object
    height: float
    depth: float
    min_time: float
    min_rate: float
    hold_depth: float = 0.03
    give_up_rate: float = 0.0
    brake_ratio: float = 0.0
    rate_cap: float = 0.0
    steps: int = 12

    @classmethod
    def from_params(cls, plant, friction, alpha: float, landing):
        """The law of ``landing`` (its ``shoot_*`` fields, the aim raised by
        ``landing_bias``; the fallback from its ``landing_*`` fields) on the
        nominal ``plant`` and ``friction``."""
        height = min(0.0, landing.shoot_height + landing.landing_bias)
        return cls(Landing.from_params(plant, alpha, landing), friction, height,
                   landing.shoot_depth, landing.shoot_min_time, landing.shoot_min_rate,
                   landing.shoot_hold_depth, number_or(landing.shoot_give_up_rate),
                   number_or(landing.shoot_brake_ratio), number_or(landing.shoot_rate_cap))

    def takes_over(self, x) -> bool:
        """Whether the law takes over (asked in the plan's last forward
        swing of link 1 only): ``depth`` from the line, or the landing's
        rule."""
        return self.landing.height(x) > -self.depth or self.landing.takes_over(x)

    def __post_init__(self):
        # the nominal model's constants, folded once (the law runs every tick)
        object.__setattr__(self, "constants", nominal_kernel.pack(self.landing.plant,
                                                                  self.friction))

    def solve(self, x):
        """(the elbow's acceleration now, ``T``) or None: Newton on
        ``(T, q2f)``, from link 1 stopping at its present deceleration
        (compiled: :func:`~bplir_drake.systems.nominal_kernel.solve_shot`)."""
        found, acc, T = nominal_kernel.solve_shot(
            self.constants, np.asarray(x, dtype=float), self.steps, self.landing.alpha,
            self.height, self.min_rate, self.min_time, self.hold_depth)
        return (acc, T) if found else None

    def gives_up(self, x) -> bool:
        """Whether the shot has missed: link 1 swings back faster than
        ``give_up_rate`` with the gripper still below the aimed height.
        Chasing the line then slides the gripper along it as link 1 falls
        back (crashes at 1-2 m/s); giving up leaves a timeout, the robot
        still hanging from its holding gripper (0: never gives up)."""
        return (self.give_up_rate > 0.0 and x[2] < -self.give_up_rate
                and self.landing.height(x) < self.height)

    def torque(self, x, window=None) -> float:
        """The elbow torque at the relative state ``x``: the computed torque
        of the solved elbow acceleration (the landing's where none; the
        elbow braked to rest once the shot :meth:`gives_up`).  ``window``
        (lowest, highest torque the motor gives now, N m): with
        ``brake_ratio`` set, a shot asking for more than ``brake_ratio``
        times it to lift the gripper brakes the elbow instead -- a shot that
        far out of reach only flings the elbow into the line (link 1 stopped
        short of the plan), and a slower elbow arrives gentler or swings
        back to try again.  A shot folding the gripper away (the swing
        arrives too fast) is clipped instead: a braked elbow would let
        link 1 carry the gripper into the line."""
        x = [float(v) for v in x]
        if self.gives_up(x):
            return self._braked(x)
        sol = self.solve(x)
        u = self.landing.torque(x) if sol is None else self._computed(x, sol[0])
        if window is not None and self.brake_ratio > 0.0 and not (
                self.brake_ratio * window[0] <= u <= self.brake_ratio * window[1]) \
                and (sol is None or self._lifts(x, sol[0])):
            return self._braked(x)
        return self._capped(x, u)

    def _lifts(self, x, a2: float) -> bool:
        """Whether the elbow at ``a2`` moves the gripper towards the line."""
        return height_rates(self.landing.plant, self.landing.alpha, (x[0], x[1], 0.0, a2))[1] > 0

    def _capped(self, x, u: float) -> float:
        """``u``, or where the gripper is within ``hold_depth`` of the aimed
        height with the elbow faster than ``rate_cap`` and ``u`` would turn
        it faster still, the torque that brakes the elbow back to the cap:
        the elbow's rate near the line is most of the gripper's speed at
        capture, and a shot that link 1 left short flings it in."""
        v2 = x[3]
        if self.rate_cap <= 0.0 or abs(v2) <= self.rate_cap or \
                self.landing.height(x) <= self.height - self.hold_depth:
            return u
        s = math.copysign(1.0, v2)
        ub = self._braked(x, s * self.rate_cap)
        return ub if (u - ub) * s > 0.0 else u

    def _braked(self, x, rate: float = 0.0) -> float:
        """The torque that brakes the elbow towards ``rate`` (rest by
        default): ``-landing.rate_gain * (q2' - rate)``."""
        return self._computed(x, -self.landing.rate_gain * (x[3] - rate))

    def _computed(self, x, a2: float) -> float:
        """The elbow torque that gives the elbow acceleration ``a2`` at ``x``
        (link 1 passive; nominal model and friction)."""
        return nominal_kernel.elbow_torque(self.constants, *x, a2)


def link1_share(p, alpha: float, states, depth: float) -> float:
    """The share of the planned gripper's rise rate that link 1's rotation
    makes (the rest: the elbow's) at the last moment the gripper of the
    planned swing (``states``, relative, in time order) is ``depth`` below
    a line inclined by ``alpha``: 1 where link 1 carries the gripper to the
    line, 0 where the elbow lifts it."""
    states = np.asarray(states, dtype=float)
    below = np.flatnonzero([height_rates(p, alpha, x)[0] < -depth for x in states])
    x = states[int(below[-1]) if below.size else 0]
    total = height_rates(p, alpha, x)[1]
    by_link1 = height_rates(p, alpha, (*x[:3], 0.0))[1]   # the elbow held
    return by_link1 / total if abs(total) > 1e-9 else 0.0


def resolved_landing(p, alpha: float, states, landing):
    """(law, landing): ``landing.landing_law`` with ``"auto"`` resolved on the
    planned swing (``states``, relative, in time order), and ``landing`` with
    the shot's hold time and aim of that swing.  Where link 1 makes at least
    ``landing.shoot_link1_share`` of the gripper's rise when it comes within
    ``landing.shoot_depth`` of the line, the shot held from
    ``landing.shoot_min_time``; where the elbow lifts the gripper (the end of
    the -20 degree plan: link 1 creeps while the elbow stops the gripper
    at the line, and a short hold asks for the torque limit both ways), the
    law ``landing.lift_law``: the aim law (the default, the robot without
    the line sensor), or the shot held from ``landing.shoot_lift_min_time``
    and aimed at ``landing.shoot_lift_height``."""
    if landing.landing_law != "auto":
        return landing.landing_law, landing
    if link1_share(p, alpha, states, landing.shoot_depth) >= landing.shoot_link1_share:
        return "shoot", landing
    if landing.lift_law == "shoot":
        return "shoot", replace(landing, shoot_min_time=landing.shoot_lift_min_time,
                                shoot_height=landing.shoot_lift_height)
    return "aim", landing


def landing_law(p, alpha: float, states, landing) -> str:
    """The law of :func:`resolved_landing`: ``"shoot"``, ``"aim"``,
    ``"reach"`` or ``"none"`` (``"auto"`` resolved)."""
    return resolved_landing(p, alpha, states, landing)[0]


def height_rates(p, alpha: float, x) -> tuple[float, float, float]:
    """(h, h', along): the gripper's distance to a line inclined by
    ``alpha`` (negative below it), its rate and the gripper's speed along
    the line at the relative state ``x`` of the plant ``p``."""
    s = float(x[0]) - alpha
    th = s + float(x[1])
    v0, v1, l1, l2 = float(x[2]), float(x[3]), p.l1, p.l2
    cs, ct, st = math.cos(s), math.cos(th), math.sin(th)   # a controller asks every tick
    h = -l1 * cs - l2 * ct
    hd = (l1 * math.sin(s) + l2 * st) * v0 + l2 * st * v1
    along = (l1 * cs + l2 * ct) * v0 + l2 * ct * v1
    return h, hd, along


def height_torque(p, alpha: float, x, hdd: float) -> float:
    """The elbow torque that gives the gripper's distance to the line the
    acceleration ``hdd`` with link 1 passive, by partial feedback
    linearisation on the plant ``p`` (friction left out)."""
    q, v = x[:2], x[2:4]
    s = q[0] - alpha
    th = s + q[1]
    J = np.array([p.l1 * np.sin(s) + p.l2 * np.sin(th), p.l2 * np.sin(th)])  # dh/dq
    jdv = p.l1 * np.cos(s) * v[0] ** 2 + p.l2 * np.cos(th) * (v[0] + v[1]) ** 2
    M = mass_matrix(q, p)
    b = bias_term(q, v, p) + gravity_vector(q, p)
    # h'' = J q'' + J' q' with q1'' = -(M12 q2'' + b1) / M11 (link 1 passive)
    q2dd = (hdd + J[0] * b[0] / M[0, 0] - jdv) / (J[1] - J[0] * M[0, 1] / M[0, 0])
    q1dd = -(M[0, 1] * q2dd + b[0]) / M[0, 0]
    return float(M[1, 0] * q1dd + M[1, 1] * q2dd + b[1])


def terminal_rule(reach) -> np.ndarray:
    """The terminal law as numbers, for
    :func:`~bplir_drake.systems.tracker_kernel.plan_tick`: its take-over
    test (its ``takes_over``: kind 0 none, 1 :class:`Reach`, 2
    :class:`Landing`, 3 :class:`ApexShot`; the line's incline, l1, l2 of
    the servo's plant; the law's depth; the landing's depth, least
    deceleration and take-over rate; the constants of
    :meth:`Landing.deceleration`) and the apex shot's numbers (its steps,
    aimed height, least rate and time, hold depth, give-up rate, brake
    ratio, rate cap; the landing's rate gain)."""
    if reach is None:
        return np.zeros(26)
    servo = reach.landing if isinstance(reach, ApexShot) else reach
    kind = 3 if isinstance(reach, ApexShot) else 2 if isinstance(reach, Landing) else 1
    own = [servo.depth, servo.min_decel, servo.take_rate, *servo.decel_constants()] \
        if kind > 1 else [0.0] * 12
    shot = [reach.steps, reach.height, reach.min_rate, reach.min_time, reach.hold_depth,
            reach.give_up_rate, reach.brake_ratio, reach.rate_cap, servo.rate_gain] \
        if kind == 3 else [0.0] * 9
    return np.array([kind, servo.alpha, servo.plant.l1, servo.plant.l2, reach.depth, *own,
                     *shot], dtype=float)
