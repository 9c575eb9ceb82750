"""Plant families for QFT: a linear plant with its frequency response, a family of them, the dissertation's published family and the one linearised from the diagram across the swing's states."""
from __future__ import annotations

import math
from dataclasses import dataclass
import numpy as np
from .qft_error import QftError
from dataclasses import replace
from ...diagrams import build_cpfl_plant
from ...systems.controller import cpfl_terms


@dataclass
class Plant:
    """One plant of a family: a transfer function from v to q2 and an input delay (s); calling it
    at frequencies w (rad/s) gives the complex response."""
    tf: control.TransferFunction
    delay: float = 0.0
    label: str = ""

    def __call__(self, w) -> np.ndarray:
        w = np.asarray(w, dtype=float)
        return np.asarray(self.tf(1j * w)) * np.exp(-1j * w * self.delay)

    def rational(self, pade_order: int = 6) -> control.TransferFunction:
        """The plant with its delay replaced by a Pade approximation."""
        import control   # python-control where it is used: calibration needs the plants alone

        if self.delay <= 0:
            return self.tf
        num, den = control.pade(self.delay, pade_order)
        return self.tf * control.tf(num, den)


@dataclass
class PlantFamily:
    """The plants a QFT design must hold for, with the index of the nominal one."""
    plants: list[Plant]
    name: str = "family"
    nominal: int = 0

    def __post_init__(self):
        if not self.plants:
            raise QftError(f"plant family '{self.name}' is empty; it needs at least one plant")
        if not 0 <= self.nominal < len(self.plants):
            raise QftError(f"nominal index {self.nominal} out of range [0, {len(self.plants) - 1}]")

    def __len__(self):
        return len(self.plants)

    def response(self, w) -> np.ndarray:
        """(n_plants, n_w) complex frequency responses."""
        return np.array([p(w) for p in self.plants])


def _check_omegas(omegas) -> np.ndarray:
    w = np.atleast_1d(np.asarray(omegas, dtype=float))
    if w.size == 0 or not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise QftError(f"design frequencies must be finite and positive, got {w.tolist()}")
    return w


def dissertation_family(k=(0.013, 0.035), a=(0.19, 0.22), td=(0.15, 0.3), n: int = 3,
                        sign: float = -1.0) -> PlantFamily:
    """(4.16): ``-k e^{-s Td}/(a s + 1)`` on an n x n x n grid (Td = 0 if
    ``td`` is None)."""
    import control

    ks = np.linspace(*k, n)
    as_ = np.linspace(*a, n)
    tds = np.linspace(*td, n) if td is not None else [0.0]
    plants = [Plant(control.tf([sign * kk], [aa, 1.0]), float(dd), f"k={kk:.4g} a={aa:.3g} Td={dd:.3g}")
              for kk in ks for aa in as_ for dd in tds]
    # nominal: the middle plant
    return PlantFamily(plants, "dissertation (4.16)" + ("" if td is not None else " without delay"),
                       nominal=len(plants) // 2)


def _s():
    import control

    return control.tf("s")


def perturbed(params, rng, friction_spread: float = 0.2, mass_spread: float = 0.1):
    """Parameters whose *simulated* plant differs from the nominal one: each
    friction coefficient within +/- friction_spread, masses and inertias
    within +/- mass_spread (uniform)."""

    f, p = params.friction, params.plant
    u = rng.uniform(1 - friction_spread, 1 + friction_spread, 4)
    m = rng.uniform(1 - mass_spread, 1 + mass_spread, 4)
    tf_ = f.with_factors(u)
    tp = replace(p, m1=p.m1 * m[0], m2=p.m2 * m[1], I1=p.I1 * m[2], I2=p.I2 * m[3])
    return params.with_(true_plant=tp, true_friction=tf_)


STATE_BOX = ((-math.pi / 2, math.pi / 2), (-math.pi, math.pi), (-4.0, 4.0), (-4.0, 4.0))


#: states a brachiation swing visits (D = 1.2 m, inclines to +/-20 deg, with
#: margin): the default region of the diagram family
SWING_BOX = ((-0.8, 0.8), (-2.6, 2.6), (-1.6, 1.6), (-5.0, 5.0))


def linearized_cpfl_plant(params, x0) -> control.TransferFunction:
    """Elbow channel q2/v of the nominal-CPFL loop around
    ``params.simulated_plant`` at x0.

    The loop is linearised with Drake (``FirstOrderTaylorApproximation``; x0
    need not be an equilibrium).  Its q2'' row is ``b_v v + a_s q2 + a_d q2'
    + (coupling to q1, q1')``; the family keeps the elbow channel
    ``b_v/(s^2 - a_d s - a_s)`` and treats the coupling through the passive
    link as a disturbance: the q1 modes of the full 4-state model are the
    zero dynamics (Figs 6.2-6.3), which the outer loop neither can nor should
    act on (at non-equilibrium points their local Jacobian can be unstable,
    e.g. with link 1 falling near the horizontal)."""
    import control
    from pydrake.systems.primitives import FirstOrderTaylorApproximation

    built = build_cpfl_plant(params)
    ctx = built.diagram.CreateDefaultContext()
    built.diagram.get_input_port(0).FixValue(ctx, [0.0])
    ctx.SetContinuousState(np.asarray(x0, dtype=float))
    lin = FirstOrderTaylorApproximation(built.diagram, ctx)
    A, B = np.asarray(lin.A()), np.asarray(lin.B())
    return control.tf([B[3, 0]], [1.0, -A[3, 3], -A[3, 1]])


def diagram_family(params, n_samples: int = 60, seed: int = 0, *, friction_spread: float = 0.2,
                   mass_spread: float = 0.1, min_elbow_rate: float | None = None,
                   actuator: bool = True, box=SWING_BOX) -> PlantFamily:
    """Plant family of the simulated CPFL loop: ``n_samples`` plants, each
    with its own perturbed true plant (friction +/-20 %, masses and inertias
    +/-10 %) linearised at a random operating point of ``box`` (default: the
    states a swing visits, :data:`SWING_BOX`; :data:`STATE_BOX` is the wider
    box of 6.3).
    Points with ``|q2d| < min_elbow_rate`` (default 20 b = 0.2 rad/s) are
    skipped: there the slope of the *smoothed* Coulomb law (4.11),
    ``2 fc/(pi b)/(1 + (qd/b)^2)`` (49 N m s at rest, still 1.9 N m s at
    5 b), is an artefact of the smoothing -- the discontinuous law (4.10) has
    no slope -- and the friction acts as stiction, an input disturbance the
    integrator of K handles, not as damping of the plant.  With
    ``actuator`` the motor's current lag and the half-sample delay of the
    zero-order hold (6.21) are appended."""
    import control

    if n_samples < 1:
        raise QftError(f"n_samples = {n_samples} must be at least 1")
    rng = np.random.default_rng(seed)
    min_rate = 20 * params.friction.b if min_elbow_rate is None else min_elbow_rate
    lag = control.tf([1.0], [params.motor.tau_current, 1.0]) if actuator else 1
    delay = params.controller.period / 2 if actuator else 0.0
    plants = []
    while len(plants) < n_samples:
        pp = perturbed(params, rng, friction_spread, mass_spread)
        x0 = np.array([rng.uniform(*b) for b in box])
        if abs(x0[3]) < min_rate:
            continue
        G = linearized_cpfl_plant(pp, x0)
        plants.append(Plant(G * lag, delay, f"x0=({', '.join(f'{v:.2f}' for v in x0)})"))
    # nominal: 1/s^2 with the same actuator
    nominal = Plant(control.tf([1.0], [1.0, 0.0, 0.0]) * lag, delay, "nominal 1/s^2")
    return PlantFamily([nominal] + plants, f"diagram CPFL loop ({n_samples} sampled plants)", 0)


def v_max_over_box(params, n: int = 9, torque_limit: float | None = None) -> dict:
    """(6.19): the outer-loop signal the torque limit allows,
    ``|v| = |(tau_max - b)/a|`` (nominal model with its friction, as (6.19)
    includes f), over a grid of the state box of 6.3.  Returns the largest
    |v| reachable anywhere (the dissertation's "|v_max| <= 220"; we get
    less) and the smallest |v| guaranteed in both directions at every state
    (zero: in parts of the box 20 N m is not even enough to hold the elbow
    against b(q, qd))."""

    tmax = params.controller.torque_limit if torque_limit is None else torque_limit
    grids = [np.linspace(lo, hi, n) for lo, hi in STATE_BOX]
    worst, best = math.inf, 0.0
    for q1 in grids[0]:
        for q2 in grids[1]:
            for w1 in grids[2]:
                for w2 in grids[3]:
                    a, b = cpfl_terms([q1, q2], [w1, w2], params.plant, params.friction)
                    vp, vm = (tmax - b) / a, (-tmax - b) / a
                    worst = min(worst, max(0.0, min(vp, -vm)))
                    best = max(best, abs(vp), abs(vm))
    return {"v_max_guaranteed": float(worst), "v_max_largest": float(best), "torque_limit_Nm": tmax,
            "grid_points_per_axis": n}
