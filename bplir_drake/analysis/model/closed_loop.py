"""The plan tracker's loop linearised at frozen times.

The swing diagram itself cannot be linearised: it is hybrid (the plant's
continuous state, the onboard computer's and the driver's discrete state,
the tracker's zero-order hold), and Drake's ``Linearize`` stops the process
on it.  What can be linearised is the loop the tracker's gains were made
for: the nominal plant with its friction (the LQR's model,
:func:`~bplir_drake.planning.solve.plan_model`) under the law
``u = u0(t) - K(t) (x - x0(t)) - k0(t)`` with the time frozen at ``t``:
``x' = (A(t) - B(t) K(t)) dx + B(t) w``, where ``A, B`` are the plant's
Jacobians at ``x0(t)`` and the law's torque there, ``u0(t) - k0(t)``, and
``w`` is a torque added at the elbow.
Its poles along the plan say how fast the tracker pulls an error back at
each moment (a frozen-time picture: a time-varying loop's stability is not
its frozen poles')."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...io import Result
from ...params import BplirParams
from ...planning.solve import plan_model, tracking_plan
from .model_plots import plot_closed_loop_poles

#: the closed loop's state and input names
STATES, INPUTS = ("q1", "q2", "q1d", "q2d"), ("elbow_torque",)


def _plant_at(params: BplirParams):
    """(the LQR's model, a context of it, the tracking gains) of ``params``'s plan."""
    plan, gains = tracking_plan(params)
    model, _ = plan_model(params)
    return model, model.CreateDefaultContext(), gains, plan


def _law(gains, t: float):
    """(x0, u0, K, k0) of the tracker's law at ``t``."""
    return (np.asarray(gains.x0.value(t)).ravel(), float(np.asarray(gains.u0.value(t)).ravel()[0]),
            np.asarray(gains.K.value(t)).reshape(1, 4),
            float(np.asarray(gains.k0.value(t)).ravel()[0]))


def _jacobians(model, context, x0, u0):
    """(A, B): Drake's first-order Taylor approximation of ``model`` at (x0, u0)."""
    from pydrake.systems.primitives import FirstOrderTaylorApproximation

    model.get_input_port(0).FixValue(context, [u0])
    context.SetContinuousState(x0)
    lin = FirstOrderTaylorApproximation(model, context)
    return np.array(lin.A()), np.array(lin.B())


def linearize_closed_loop(params: BplirParams, t: float):
    """The tracker's loop at the frozen time ``t`` (s) of the plan of
    ``params`` as a python-control ``StateSpace``: ``A - B K`` with input
    the elbow torque added to the law's (N m) and the state as output
    (deviations from the plan's ``x0(t)``)."""
    import control

    model, context, gains, plan = _plant_at(params)
    if not 0.0 <= t <= plan.duration:
        raise ValueError(f"t = {t:g} s is outside the plan; allowed [0, {plan.duration:g}] s")
    x0, u0, K, k0 = _law(gains, t)
    A, B = _jacobians(model, context, x0, u0 - k0)   # the torque the law gives on the plan
    return control.ss(A - B @ K, B, np.eye(4), np.zeros((4, 1)), states=list(STATES),
                      inputs=list(INPUTS), outputs=list(STATES), name=f"tracker_loop_at_{round(t * 1000)}_ms")


def closed_loop_derivative(params: BplirParams, t: float, x) -> np.ndarray:
    """The frozen-time closed loop's state derivative at ``x``: the LQR's
    model driven by the tracker's law of time ``t`` (no saturation), by
    Drake's ``CalcTimeDerivatives`` -- what a finite difference of the loop
    differentiates."""
    model, context, gains, _ = _plant_at(params)
    x0, u0, K, k0 = _law(gains, t)
    x = np.asarray(x, dtype=float)
    model.get_input_port(0).FixValue(context, [u0 - float((K @ (x - x0))[0]) - k0])
    context.SetContinuousState(x)
    return np.array(model.EvalTimeDerivatives(context).CopyToVector())


@dataclass
class ClosedLoopPoles(Result):
    """The frozen-time poles of the tracker's loop along a plan: times (s),
    poles (n, 4) complex (1/s), and the plan's duration (s)."""

    times: np.ndarray
    poles: np.ndarray
    duration: float

    def summary(self) -> dict:
        """The slowest pole's real part along the plan and where it is."""
        slowest = self.poles.real.max(axis=1)
        k = int(np.argmax(slowest))
        return {"samples": int(len(self.times)), "duration_s": self.duration,
                "slowest_real_per_s": float(slowest[k]), "slowest_at_s": float(self.times[k]),
                "fastest_real_per_s": float(self.poles.real.min())}

    def table(self) -> dict:
        """A column of times and one each for the poles' real and imaginary parts."""
        out = {"t_s": self.times}
        for i in range(self.poles.shape[1]):
            out[f"pole{i + 1}_real"] = self.poles[:, i].real
            out[f"pole{i + 1}_imag"] = self.poles[:, i].imag
        return out

    def plot(self, axes=None):
        """The poles' real parts and their frequencies against time."""
        return plot_closed_loop_poles(self, axes)


def closed_loop_poles(params: BplirParams, samples: int = 41) -> ClosedLoopPoles:
    """The frozen-time poles of the tracker's loop at ``samples`` times
    evenly over the plan of ``params`` (each sorted by real part)."""
    model, context, gains, plan = _plant_at(params)
    times = np.linspace(0.0, plan.duration, int(samples))
    poles = []
    for t in times:
        x0, u0, K, k0 = _law(gains, float(t))
        A, B = _jacobians(model, context, x0, u0 - k0)
        lam = np.linalg.eigvals(A - B @ K)
        poles.append(lam[np.lexsort((lam.imag, lam.real))])
    return ClosedLoopPoles(times, np.array(poles), float(plan.duration))
