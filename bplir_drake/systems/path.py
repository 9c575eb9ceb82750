"""Online path generator (chapter 7): time-independent, driven by the
(estimated) state, never the clock.

Coordinates: ``s = q1 - alpha`` is link 1's angle from the normal of a line
inclined by ``alpha`` (0 for a horizontal line).  The swing starts at
``s0 = -s_f`` and the mirror target (7.1) is at ``s_f``; ``k_f = q2_f/s_f``.

* Reverse-time-symmetric path (7.6)-(7.7): ``q2 = k_f s`` while ``s <= 0``.
  For an uphill line the first half pumps energy ((7.14)-(7.15), (7.25)):
  ``q2 = k_f s (1 + (lam - 1)(1 - (s/s_f)^2))`` amplifies the elbow swing by
  up to ``lam`` near the vertical while keeping the start pose.
* Line-seeking path (7.18), derived for an inclined line: the gripper's
  distance to the line ``y' = -l1 cos(q1 - alpha) - l2 cos(q1 + q2 - alpha)``
  vanishes for ``q2_T(s) = arccos(-(l1/l2) cos s) - s`` (erratum: (7.26)-
  (7.27) use l1 for both links and put q_line inside the arccos).
* Blend (7.20)-(7.21) after the vertical: ``q2 = (1 - F) q2_sym,e + F q2_T``
  with ``F = clip(s/s_e, 0, 1)^n``.  ``q2_sym,e`` is the RTS path re-targeted
  to reach the line at ``s_e`` (slope blended smoothly from ``k_f`` to
  ``q2_T(s_e)/s_e``), so the path meets the line-seeking path tangentially.
  Erratum: with the printed linear blend (n = 1) the early pull toward the
  line-seeking path (q2_T(0) = 2.39 rad) breaks the reverse-time symmetry and
  pumps energy; ``n = 2`` keeps the RTS character through the vertical.
* Adaptation (ours): ``s_e`` is steered, from shortly before the vertical
  until the robot is close to it, by the reduced dynamics of the virtual
  constraint ``q2 = phi(q1)`` (nominal model):
  ``alpha(q1) q1'' + beta(q1) q1'^2 + gamma(q1) = -f1`` is integrated in q1 to
  predict ``q1'`` on reaching ``s_e``, starting from the on-path rate with
  the measured mechanical energy; ``s_e`` moves (rate-limited, so the path
  never jumps) toward the value with a slow arrival.  The path latches to
  the pure line-seeking path once ``q1'`` is small near ``s_e`` ("hang
  time").

The system that runs this on the controller's ticks is
:mod:`.path_generator`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pydrake.math as dmath

from ..params import PathParams, PlantParams
from .plant import gravity_vector, initial_configuration, mass_matrix, bias_term
from .plant import kinetic_energy, potential_energy


@dataclass(frozen=True)
class PathGeometry:
    """The path's geometry on the nominal model: link lengths (m), line incline alpha (rad), the
    target s_f (rad) and elbow angle q2_f (rad), and the capture band (m)."""
    l1: float
    l2: float
    alpha: float      # line incline (rad)
    s_f: float        # target s (> 0)
    q2_f: float       # target elbow angle
    band: float = 0.02  # capture distance the arrival is aimed at (m)

    @property
    def s_reach(self) -> float:
        """Smallest ``s`` at which the line-seeking path exists: 0 when link 2
        is the longer one, ``acos(l2/l1)`` otherwise (the swapped robot)."""
        return math.acos(self.l2 / self.l1) if self.l1 > self.l2 else 0.0

    @property
    def k_f(self) -> float:
        """Ratio q2_f / s_f of the straight path."""
        return self.q2_f / self.s_f

    @classmethod
    def from_scenario(cls, plant: PlantParams, grip_spacing: float, incline: float,
                      band: float = 0.02):
        """The geometry of a swing on a line inclined by ``incline`` (rad) with grippers
        ``grip_spacing`` (m) apart."""
        q0 = initial_configuration(grip_spacing, plant, 0.0)
        return cls(plant.l1, plant.l2, incline, -q0[0], -q0[1], band)


# ----------------------------------------------------------- path functions

def q2_line_seeking(s, l1: float, l2: float, lift: float = 0.0):
    """(7.18) for a line inclined by alpha, in ``s = q1 - alpha``: the elbow
    angle that puts the gripper on the line (``lift`` above it).  Where the
    line is out of the gripper's reach (a link 1 longer than link 2 near the
    vertical, the swapped robot) it is the elbow angle that brings the
    gripper closest to it (straight down, ``acos`` argument clipped at 1)."""
    if isinstance(s, float):  # fast path for plain numbers (the predictor)
        return math.acos(max(-1.0, min(1.0, -(l1 * math.cos(s) + lift) / l2))) - s
    u = -(l1 * dmath.cos(s) + lift) / l2
    return dmath.acos(u) - s


def smoothstep(x):
    """3 x^2 - 2 x^3 (0 at 0, 1 at 1, flat at both ends)."""
    return 3.0 * x * x - 2.0 * x * x * x


def path_q2(s, s_e: float, g: PathGeometry, n: float, lam: float = 1.0, floor: float = 0.0,
            lift: float = 0.0):
    """The blended path value ``q2_ref(s)`` for a given blend end ``s_e``;
    ``floor`` is a lower bound of the blend weight F (the soft latch) and
    ``lift`` raises the line-seeking target above the line (after the latch)."""
    if s <= 0 and floor <= 0:
        # RTS (7.6); lam > 1 amplifies the elbow swing in the first half
        # (energy pumping, (7.14)-(7.15)) while keeping q2(-s_f) = q2_0, q2(0) = 0
        return g.k_f * s * (1.0 + (lam - 1.0) * (1.0 - (s / g.s_f) ** 2))
    x = s / s_e
    if x >= 1.0 or floor >= 1.0:
        return q2_line_seeking(s, g.l1, g.l2, lift)
    # (the blend below is evaluated for 0 < s < s_e)
    k_e = q2_line_seeking(s_e, g.l1, g.l2) / s_e
    k = lam * g.k_f + (k_e - lam * g.k_f) * smoothstep(x)
    sym = k * s
    F = x ** n if x > 0 else 0.0 * x
    if F < floor:
        F = 0.0 * F + floor
    return sym + F * (q2_line_seeking(s, g.l1, g.l2, lift) - sym)


def path_derivatives(s, s_e: float, g: PathGeometry, n: float, lam: float = 1.0,
                     floor: float = 0.0, h: float = 1e-4, lift: float = 0.0):
    """(phi, phi', phi'') by finite differences (any scalar type).  The path
    changes branch at the vertical (s = 0) and at the blend end (s = s_e),
    where its curvature jumps: next to them the stencil is one-sided, on the
    side of ``s``."""
    f = lambda x: path_q2(x, s_e, g, n, lam, floor, lift)  # noqa: E731
    b = f(s)
    if floor < 1.0 and ((s <= 0 < s + h) or (s < s_e <= s + h)):
        b1, b2, b3 = f(s - h), f(s - 2 * h), f(s - 3 * h)   # backward
        return b, (3 * b - 4 * b1 + b2) / (2 * h), (2 * b - 5 * b1 + 4 * b2 - b3) / (h * h)
    if floor < 1.0 and ((s - h <= 0 < s) or (s - h < s_e <= s)):
        b1, b2, b3 = f(s + h), f(s + 2 * h), f(s + 3 * h)   # forward
        return b, (-3 * b + 4 * b1 - b2) / (2 * h), (2 * b - 5 * b1 + 4 * b2 - b3) / (h * h)
    a, c = f(s - h), f(s + h)
    return b, (c - a) / (2 * h), (c - 2 * b + a) / (h * h)


def constraint_acceleration(q, qd1, d1, d2, p: PlantParams):
    """q1'' and the feed-forward q2'' of the exact virtual constraint
    ``q2 = phi(q1)`` on the nominal model (friction-free)."""
    M = mass_matrix(q, p)
    v = [qd1, d1 * qd1]
    h = bias_term(q, v, p)
    gv = gravity_vector(q, p)
    q1dd = -(M[0, 1] * d2 * qd1 * qd1 + h[0] + gv[0]) / (M[0, 0] + M[0, 1] * d1)
    return q1dd, d1 * q1dd + d2 * qd1 * qd1


class PathShape:
    """The path ``q2 = phi(s)`` for one blend end ``s_e`` (no latch floor),
    with its first two derivatives in closed form, for plain floats or numpy
    arrays within one branch: the hot loop of the arrival predictor.  Agrees
    with :func:`path_q2` and :func:`path_derivatives` (tested)."""

    __slots__ = ("s_e", "n", "lam", "kf", "s_f", "l1", "l2", "lift", "k_e")

    def __init__(self, s_e: float, g: PathGeometry, n: float, lam: float = 1.0,
                 lift: float = 0.0):
        self.s_e, self.n, self.lam, self.kf, self.s_f = s_e, n, lam, g.k_f, g.s_f
        self.l1, self.l2, self.lift = g.l1, g.l2, lift
        self.k_e = q2_line_seeking(float(s_e), g.l1, g.l2) / s_e

    def line_seeking(self, s):
        """(7.18) and its two derivatives in ``s``."""
        u = np.clip(-(self.l1 * np.cos(s) + self.lift) / self.l2, -1.0 + 1e-9, 1.0 - 1e-9)
        du, ddu = self.l1 * np.sin(s) / self.l2, self.l1 * np.cos(s) / self.l2
        r2 = 1.0 - u * u
        r = np.sqrt(r2)
        return np.arccos(u) - s, -du / r - 1.0, -ddu / r - u * du * du / (r2 * r)

    def rts(self, s):
        """The first half (7.6), amplified by ``lam`` (7.14)-(7.15)."""
        lam, kf, c = self.lam, self.kf, (self.lam - 1.0) / (self.s_f * self.s_f)
        return kf * (lam * s - c * s ** 3), kf * (lam - 3.0 * c * s * s) + 0.0 * s, \
            -6.0 * kf * c * s

    def blend(self, s):
        """The blend (7.20)-(7.21) for ``0 < s < s_e``."""
        se, n = self.s_e, self.n
        x = s / se
        lk = self.lam * self.kf
        dk = self.k_e - lk
        k = lk + dk * (3.0 * x * x - 2.0 * x ** 3)
        k1 = dk * (6.0 * x - 6.0 * x * x) / se
        k2 = dk * (6.0 - 12.0 * x) / (se * se)
        sym, sym1, sym2 = k * s, k1 * s + k, k2 * s + 2.0 * k1
        F, F1, F2 = x ** n, n * x ** (n - 1.0) / se, n * (n - 1.0) * x ** (n - 2.0) / (se * se)
        T0, T1, T2 = self.line_seeking(s)
        return (sym + F * (T0 - sym), sym1 + F1 * (T0 - sym) + F * (T1 - sym1),
                sym2 + F2 * (T0 - sym) + 2.0 * F1 * (T1 - sym1) + F * (T2 - sym2))

    def derivs(self, s: float):
        """(phi, phi', phi'') at ``s``; at the branch points (the vertical and
        ``s_e``) the values of the branch that ends there."""
        if s <= 0.0:
            return self.rts(s)
        return self.blend(s) if s < self.s_e else self.line_seeking(s)

    def value(self, s: float) -> float:
        """phi(s) alone (plain floats)."""
        if s <= 0.0:
            return self.kf * s * (1.0 + (self.lam - 1.0) * (1.0 - (s / self.s_f) ** 2))
        u = -(self.l1 * math.cos(s) + self.lift) / self.l2
        T0 = math.acos(max(-1.0, min(1.0, u))) - s
        if s >= self.s_e:
            return T0
        x = s / self.s_e
        lk = self.lam * self.kf
        sym = (lk + (self.k_e - lk) * (3.0 * x * x - 2.0 * x * x * x)) * s
        return sym + x ** self.n * (T0 - sym)

    def height(self, s: float) -> float:
        """Normal distance of the gripper to the line on the path."""
        return -self.l1 * math.cos(s) - self.l2 * math.cos(s + self.value(s))


class ReducedDynamics:
    """``d(q1'^2)/ds = P(s) Y + Q(s) + R(s) sqrt(Y)`` for ``Y = q1'^2`` under
    the virtual constraint of a :class:`PathShape` on the nominal model with
    viscous link-1 friction ``fv1``: ``alpha(s) q1'' + beta(s) q1'^2 +
    gamma(s) = -fv1 q1'`` (vectorised over ``s``)."""

    __slots__ = ("shape", "alpha", "fv1", "m11c", "a", "m2l1lc2", "g1", "g2", "p1", "d2")

    def __init__(self, shape: PathShape, alpha: float, p: PlantParams, fv1: float):
        self.shape, self.alpha, self.fv1 = shape, alpha, fv1
        self.a = p.I2 + p.m2 * p.rc2 ** 2
        self.m11c = p.m1 * p.rc1 ** 2 + p.I1 + p.m2 * p.l1 ** 2 + self.a
        self.m2l1lc2 = p.m2 * p.l1 * p.rc2
        self.g1, self.p1 = p.gravity_link1()
        self.g2, self.d2 = p.g * p.m2 * p.rc2, p.dc2

    def coefficients(self, s, branch):
        """(P, Q, R) at the points ``s`` of one branch (``shape.rts`` ...)."""
        phi, d1, d2 = branch(s)
        q1 = s + self.alpha
        c2, s2 = np.cos(phi + self.d2), np.sin(phi + self.d2)
        m12 = self.a + self.m2l1lc2 * c2
        A = self.m11c + 2.0 * self.m2l1lc2 * c2 + m12 * d1
        B = m12 * d2 - self.m2l1lc2 * s2 * (2.0 * d1 + d1 * d1)
        gam = self.g1 * np.sin(q1 + self.p1) + self.g2 * np.sin(q1 + phi + self.d2)
        return -2.0 * B / A, -2.0 * gam / A, -2.0 * self.fv1 / A


def _rk4_segment(Y: float, a: float, b: float, dyn: ReducedDynamics, branch,
                 step: float) -> float:
    """Y = q1'^2 carried from ``a`` to ``b`` by RK4 in ``m = ceil((b-a)/step)``
    equal steps on one branch of the path (its one-sided limits at the ends:
    at the vertical the path's curvature jumps); the coefficients at every
    stage point come from one vectorised pass, the steps are plain float
    arithmetic."""
    m = max(1, int(math.ceil((b - a) / step)))
    hh = (b - a) / m
    x = a + 0.5 * hh * np.arange(2 * m + 1)
    P, Q, R = (np.broadcast_to(c, x.shape).tolist() for c in dyn.coefficients(x, branch))
    sqrt = math.sqrt
    h2, h6 = 0.5 * hh, hh / 6.0
    for i in range(0, 2 * m, 2):
        k1 = P[i] * Y + Q[i] + R[i] * sqrt(Y if Y > 0.0 else 0.0)
        y = Y + h2 * k1
        k2 = P[i + 1] * y + Q[i + 1] + R[i + 1] * sqrt(y if y > 0.0 else 0.0)
        y = Y + h2 * k2
        k3 = P[i + 1] * y + Q[i + 1] + R[i + 1] * sqrt(y if y > 0.0 else 0.0)
        y = Y + hh * k3
        k4 = P[i + 2] * y + Q[i + 2] + R[i + 2] * sqrt(y if y > 0.0 else 0.0)
        Y += h6 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return Y


def predict_rate_squared(s, qd1, s_e, g, n, lam, p: PlantParams, fv1: float = 0.0,
                         step: float = 0.01, at_vertical: float | None = None) -> float:
    """Predicted q1'^2 on reaching ``s_e`` from (s, q1') under the path with
    blend end ``s_e``: RK4 in s on :class:`ReducedDynamics`, split at the
    vertical, where the path's curvature jumps, to keep fourth order.
    ``at_vertical``: q1'^2 at the vertical when already known (the first half
    of the path does not depend on ``s_e``: :func:`rate_squared_at_vertical`)."""
    dyn = ReducedDynamics(PathShape(s_e, g, n, lam), g.alpha, p, fv1)
    end = s_e - 1e-9  # the left limit: the path branches at s_e
    if end <= 0.0:
        return _rk4_segment(qd1 * qd1, s, end, dyn, dyn.shape.rts, step)
    if s < 0.0:
        Y = (_rk4_segment(qd1 * qd1, s, 0.0, dyn, dyn.shape.rts, step)
             if at_vertical is None else at_vertical)
        return _rk4_segment(Y, 0.0, end, dyn, dyn.shape.blend, step)
    return _rk4_segment(qd1 * qd1, s, end, dyn, dyn.shape.blend, step)


def rate_squared_at_vertical(s, qd1, g, n, lam, p: PlantParams, fv1: float = 0.0,
                             step: float = 0.01) -> float:
    """q1'^2 predicted at the vertical from (s < 0, q1') on the first half of
    the path (which does not depend on the blend end)."""
    dyn = ReducedDynamics(PathShape(g.s_f, g, n, lam), g.alpha, p, fv1)
    return _rk4_segment(qd1 * qd1, s, 0.0, dyn, dyn.shape.rts, step)


def projected_rate(x, s_e, g: PathGeometry, pp: PathParams, p: PlantParams) -> float:
    """q1' of the state on the path with the same mechanical energy as ``x``
    (the elbow carries much of the kinetic energy, so small tracking errors
    move energy between the links; the energy is the robust quantity)."""

    s = x[0] - g.alpha
    phi, d1, _ = path_derivatives(s, s_e, g, pp.blend_exponent, pp.pump_gain)
    E = kinetic_energy(x[:2], x[2:4], p) + potential_energy(x[:2], p)
    qm = [x[0], phi]
    M = mass_matrix(qm, p)
    m = M[0, 0] + 2 * M[0, 1] * d1 + M[1, 1] * d1 * d1
    return math.copysign(math.sqrt(max(0.0, 2.0 * (E - potential_energy(qm, p)) / m)), x[2])


def band_entry(s_from, s_e, g: PathGeometry, n: float, lam: float = 1.0) -> float:
    """First s in (s_from, s_e] where the path's gripper is within ``g.band``
    of the line (bisection on the rising height; ``s_e`` if never)."""
    shape = PathShape(s_e, g, n, lam)
    lo, hi = max(s_from, 0.0), s_e
    if shape.height(lo) >= -g.band:
        return lo
    for _ in range(16):
        mid = 0.5 * (lo + hi)
        if shape.height(mid) >= -g.band:
            hi = mid
        else:
            lo = mid
    return hi


def arrival_gap(e, s, qd1, g: PathGeometry, pp: PathParams, p: PlantParams, fv1: float = 0.0,
                step: float | None = None, at_vertical: float | None = None) -> float:
    """Predicted q1'^2 where the gripper enters the capture band, minus the
    aimed ``arrival_rate^2`` (decreasing in the blend end ``e``);
    ``at_vertical`` as in :func:`predict_rate_squared`."""
    s_b = band_entry(s, e, g, pp.blend_exponent)
    if s_b <= s:
        return qd1 * qd1 - pp.arrival_rate ** 2
    step = pp.predict_step if step is None else step
    # (the prediction runs on the path whose blend ends at the band entry)
    return predict_rate_squared(s, qd1, s_b, g, pp.blend_exponent, 1.0, p, fv1, step,
                                at_vertical) - pp.arrival_rate ** 2


def step_blend_end(s_e, s, qd1, g: PathGeometry, pp: PathParams, p: PlantParams,
                   fv1: float, max_step: float) -> float:
    """Move ``s_e`` toward the root of :func:`arrival_gap` by one secant step,
    at most ``max_step``, within the allowed bracket."""
    lo = max(max(s, 0.0) + 0.02, pp.blend_end_min * g.s_f, g.s_reach + 0.02)
    hi = pp.blend_end_max * g.s_f
    e0 = min(max(s_e, lo), hi)
    d = 0.005
    # both predictions share the first half of the path, up to the vertical
    Yv = (rate_squared_at_vertical(s, qd1, g, pp.blend_exponent, 1.0, p, fv1, pp.predict_step)
          if s < 0.0 else None)
    g0 = arrival_gap(e0, s, qd1, g, pp, p, fv1, at_vertical=Yv)
    g1 = arrival_gap(e0 + d, s, qd1, g, pp, p, fv1, at_vertical=Yv)
    slope = (g1 - g0) / d
    delta = -g0 / slope if slope < 0 else (max_step if g0 > 0 else -max_step)
    return min(max(e0 + min(max(delta, -max_step), max_step), lo), hi)
