"""Linearisation of diagrams with Drake's ``Linearize``."""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ...diagrams import build_plant_with_friction
from ...params import BplirParams


@dataclass(frozen=True)
class Linearization:
    """A linearised plant x' = A x + B u, y = C x + D u and its eigenvalues."""
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    eigenvalues: np.ndarray

    #: the state, input and output names of the plant with friction
    STATES = ("q1", "q2", "q1d", "q2d")
    INPUTS = ("elbow_torque",)

    def statespace(self):
        """The linearisation as a python-control ``StateSpace`` with named
        states (q1, q2, q1d, q2d: rad, rad/s), input (the elbow torque, N m)
        and outputs (the state).  A Taylor approximation away from an
        equilibrium has an affine term (Drake's ``f0``), which a
        ``StateSpace`` cannot hold: it describes deviations from the point."""
        import control

        return control.ss(self.A, self.B, self.C, self.D, states=list(self.STATES),
                          inputs=list(self.INPUTS), outputs=list(self.STATES),
                          name="plant_with_friction")

    @property
    def modes(self):
        """(natural frequency rad/s, damping ratio) of each eigenvalue."""
        lam = self.eigenvalues
        wn = np.abs(lam)
        zeta = np.where(wn > 0, -lam.real / np.where(wn > 0, wn, 1.0), 1.0)
        return wn, zeta


def linearize_plant(params: BplirParams, x0=(0.0, 0.0, 0.0, 0.0), u0=0.0, *,
                    nominal: bool = False, coulomb: bool = True) -> Linearization:
    """Linearise plant + friction (templated, so AutoDiff works) at the state
    ``x0`` (q1, q2, q1d, q2d) and elbow torque ``u0`` (N m): Drake's
    first-order Taylor approximation, so (x0, u0) need not be an equilibrium
    (a point of a swing); at an equilibrium it is ``Linearize``'s system.
    ``nominal`` linearises the controller's model instead of the simulated
    robot.  ``coulomb=False`` leaves the Coulomb friction out: at rest its
    smoothed slope ``2 fc/(pi b)`` locks a joint in the linear model
    (:func:`friction_poles`), which the real friction's stick does not
    linearise to; the viscous friction and the drag stay."""
    from pydrake.systems.primitives import FirstOrderTaylorApproximation

    if not coulomb:
        params = without_coulomb(params)
    built = build_plant_with_friction(params, nominal=nominal)
    ctx = built.diagram.CreateDefaultContext()
    built.diagram.get_input_port(0).FixValue(ctx, [float(u0)])
    ctx.SetContinuousState(np.asarray(x0, dtype=float))
    lin = FirstOrderTaylorApproximation(built.diagram, ctx)
    A = np.array(lin.A())
    return Linearization(A, np.array(lin.B()), np.array(lin.C()), np.array(lin.D()),
                         np.linalg.eigvals(A))


def without_coulomb(params: BplirParams) -> BplirParams:
    """``params`` with the Coulomb friction of both joints (``fc1``, ``fc2``)
    zero, in the model and in the simulated robot."""
    def off(f):
        return None if f is None else replace(f, fc1=0.0, fc2=0.0)

    return params.with_(friction=off(params.friction), true_friction=off(params.true_friction))


def friction_poles(params: BplirParams, lin: Linearization) -> str | None:
    """A note on the hanging linearisation's fast real poles (faster than ten
    times the robot's pendulum rate sqrt(g/l1)), or None when there are
    none: at rest the smoothed Coulomb friction ``fc 2/pi atan(q'/b)`` has
    the slope ``2 fc/(pi b)``, a stiff viscous term of the model (``b``:
    ``friction.b``), not a mode of the robot."""
    p, f = params.simulated_plant, params.simulated_friction
    fast = sorted(float(z.real) for z in lin.eigenvalues
                  if abs(z.imag) < 1e-9 and abs(z) > 10 * np.sqrt(p.g / p.l1))
    if not fast:
        return None
    slopes = [2 * fc / (np.pi * f.b) for fc in (f.fc1, f.fc2)]
    return (f"the real pole(s) {', '.join(f'{z:.4g}' for z in fast)} /s come from the smoothed "
            f"Coulomb friction: at rest its slope 2 fc/(pi b) is {slopes[0]:.3g} and "
            f"{slopes[1]:.3g} N m s/rad (friction.b = {f.b:g} rad/s), a stiffness of the "
            "model, not a mode of the robot")


def hanging_linearization(params: BplirParams) -> Linearization:
    """Plant + friction at the hanging rest state (0, 0, 0, 0)."""
    return linearize_plant(params)
