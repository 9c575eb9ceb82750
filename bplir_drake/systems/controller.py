"""CPFL inner loop + outer loop K, prefilter F, saturation and anti-windup.

Collocated partial feedback linearisation (6.7)-(6.8) from the *nominal*
model: ``tau = a(q) v + b(q, qd)`` with ``a = det(M)/M11`` and
``b = h2 + g2 (+ f2) - (M21/M11)(h1 + g1 (+ f1))`` makes ``q2'' = v`` on the
nominal plant.  The outer loop is Fig. 6.1: ``v = K(F(r) - y) + v_ff`` with
``y = q2``; ``K`` and ``F`` are transfer functions from
:data:`bplir_drake.params.OUTER_LOOP_DESIGNS`, discretised at ``Ts`` with the
bilinear transform (6.21)-(6.22) (python-control ``sample_system``), or kept
continuous (``continuous=True``) so the loop can be linearised.

Saturation and conventional anti-windup (Kothare et al., Fig. 6.7): the
torque is limited to ``min(torque_limit, torque_available)`` where
``torque_available`` is an input (the motor/driver model's deliverable
torque: its peak-current or interlocked continuous-current limit).  The
outer-loop value the saturated torque realises is ``v_hat = (tau_hat -
b)/a``; K is driven by ``e_tilde = e - X (v - v_hat)``.  With a direct
feedthrough ``D`` in K the algebraic loop is solved in closed form.

Errata: ``K = -216`` is negative to match the sign of the *measured* plant
(4.16).  After CPFL the simulated plant is ``q2'' = v`` (positive); with
``sign_correct`` (default) a K with negative gain is negated before use.
The scalar-templated system converts to AutoDiffXd (for ``Linearize``); it
is not offered as symbolic ``Expression`` because saturation needs
comparisons.
"""
from __future__ import annotations

import sys
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from pydrake.autodiffutils import AutoDiffXd
from pydrake.systems.framework import LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem

from ..params import ControllerParams, FrictionParams, PlantParams
from .friction import friction_torques
from .motor import torque_window
from .plant import bias_term, gravity_vector, mass_matrix
from .pysystem import PySystem, quick_template_scopes, weak_callback
from .schedule import declare_store, declare_tick_result
from .state import Q1, Q1D, Q2, Q2D, RobotState


# ----------------------------------------------------------- pure functions

def cpfl_terms(q, qd, p: PlantParams, friction: FrictionParams | None = None):
    """(a, b) with ``tau = a v + b`` giving ``q2'' = v`` on the model (6.8)."""
    M = mass_matrix(q, p)
    h = bias_term(q, qd, p)
    g = gravity_vector(q, p)
    r1, r2 = h[0] + g[0], h[1] + g[1]
    if friction is not None:
        f = friction_torques(qd, friction)
        r1, r2 = r1 + f[0], r2 + f[1]
    det = M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]
    return det / M[0, 0], r2 - M[1, 0] / M[0, 0] * r1


def cpfl_torque(q, qd, v, p: PlantParams, friction: FrictionParams | None = None):
    """The elbow torque (N m) that makes q2'' = v (rad/s^2) on the nominal model (4.13)."""
    a, b = cpfl_terms(q, qd, p, friction)
    return a * v + b


@dataclass(frozen=True)
class StateSpace:
    """A state-space realisation (A, B, C, D) of a SISO filter."""
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray

    @property
    def n(self) -> int:
        """Number of states."""
        return self.A.shape[0]


def tf_to_ss(num, den, period: float = 0.0) -> StateSpace:
    """SISO transfer function -> state space; discretised (Tustin) when
    ``period > 0``.

    The realisation python-control gives (``control.tf2ss`` without
    slycot, i.e. scipy's controller canonical form, then
    ``sample_system(..., "tustin")``: scipy's generalised bilinear
    transform with alpha = 1/2), written out in numpy: importing
    python-control (and with it scipy.signal) took 1.5-4 s of every swing
    process, more than the swing.  Tested equal to python-control's
    matrices for every shipped design."""
    num = np.atleast_1d(np.asarray(num, dtype=float))
    den = np.atleast_1d(np.asarray(den, dtype=float))
    if not np.any(den):
        raise ValueError("the denominator of a transfer function must not be zero")
    den = np.trim_zeros(den, "f")
    num, den = num / den[0], den / den[0]
    nonzero = np.flatnonzero(np.abs(num) > 1e-14)   # leading zeros trimmed, one kept
    num = num[nonzero[0] if nonzero.size else -1:]
    K = len(den)
    if len(num) > K:
        raise ValueError("improper transfer function: the numerator is longer than the "
                         "denominator")
    if K == 1:  # static gain
        return StateSpace(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)),
                          np.array([[num[0]]]))
    num = np.concatenate([np.zeros(K - len(num)), num])
    A = np.vstack([-den[1:][None, :], np.eye(K - 2, K - 1)])
    B = np.eye(K - 1, 1)
    C = (num[1:] - num[0] * den[1:])[None, :]
    D = np.array([[num[0]]])
    if period > 0:   # Tustin: the generalised bilinear transform, alpha = 1/2
        ima = np.eye(K - 1) - 0.5 * period * A
        Bd = np.linalg.solve(ima, period * B)
        A, C, D = (np.linalg.solve(ima, np.eye(K - 1) + 0.5 * period * A),
                   np.linalg.solve(ima.T, C.T).T, D + 0.5 * C @ Bd)
        B = Bd
    return StateSpace(A, B, C, D)


@lru_cache(maxsize=64)
def outer_loop(ctrl: ControllerParams, period: float = 0.0):
    """(K, F) state-space realisations of the configured design."""
    d = ctrl.design
    return (tf_to_ss(outer_loop_numerator(ctrl), d["k_den"], period),
            tf_to_ss(d["f_num"], d["f_den"], period))


def outer_loop_numerator(ctrl: ControllerParams) -> np.ndarray:
    """The numerator of K as the controller uses it: the configured one,
    negated when ``sign_correct`` is set and its leading coefficient is
    negative (the published K = -216 matches the measured plant's sign,
    the simulated CPFL plant ``q2'' = v`` is positive; README errata)."""
    k_num = np.asarray(ctrl.design["k_num"], dtype=float)
    if ctrl.sign_correct and k_num[np.nonzero(k_num)[0][0]] < 0:
        k_num = -k_num
    return k_num


def saturate_with_antiwindup(e, xK, K: StateSpace, a, b, limit, X: float):
    """Kothare's conventional anti-windup for one evaluation.

    Returns (tau_hat, v, v_hat, e_tilde, tau_unsat).  ``v`` excludes the
    feed-forward; ``b`` must already include it (``b + a v_ff``).
    ``limit``: the symmetric bound, or ``(lowest, highest)`` torque.
    """
    lo, hi = (-limit, limit) if np.ndim(limit) == 0 else limit
    CxK = (K.C @ xK)[0] if K.n else 0.0 * e
    D = K.D[0, 0]
    u0 = CxK + D * e
    tau0 = a * u0 + b
    if tau0 > hi:
        tau_hat = 0.0 * tau0 + hi
    elif tau0 < lo:
        tau_hat = 0.0 * tau0 + lo
    else:
        return tau0, u0, u0, e, tau0
    v_hat = (tau_hat - b) / a
    if X <= 0:
        return tau_hat, u0, v_hat, e, tau0
    # e~ = e - X (v - v_hat),  v = C x + D e~   ->  closed form
    v = (u0 + D * X * v_hat) / (1.0 + D * X)
    return tau_hat, v, v_hat, e - X * (v - v_hat), tau0


# ----------------------------------------------------------- the systems

class _CpflLaw:
    """The control law shared by the discrete and the continuous controller:
    ports, filters and one evaluation of CPFL + outer loop + saturation."""

    def _setup(self, plant: PlantParams, ctrl: ControllerParams, friction, continuous: bool,
               use_prefilter: bool, motor=None):
        self.plant_params, self.ctrl, self.friction = plant, ctrl, friction
        self.motor = motor
        self.continuous, self.use_prefilter = continuous, use_prefilter
        self.K, self.F = outer_loop(ctrl, 0.0 if continuous else ctrl.period)
        if not use_prefilter:
            self.F = tf_to_ss((1.0,), (1.0,))
        self.nK, self.nF = self.K.n, self.F.n
        self.state_port = self.DeclareVectorInputPort("state", 4)
        self.reference_port = self.DeclareVectorInputPort("reference", 1)
        self.feedforward_port = self.DeclareVectorInputPort("feedforward", 1)
        self.available_port = self.DeclareVectorInputPort("torque_available", 1)

    def _law(self, context, xF, xK):
        x = RobotState(self.state_port.Eval(context))
        r = self.reference_port.Eval(context)[0]
        v_ff = self.feedforward_port.Eval(context)[0]
        avail = self.available_port.Eval(context)[0]
        F, K = self.F, self.K
        rf = ((F.C @ xF)[0] if self.nF else 0.0 * r) + F.D[0, 0] * r
        e = rf - x.q2
        a, b = cpfl_terms(x[Q1:Q2 + 1], x[Q1D:Q2D + 1], self.plant_params,
                          self.friction if self.ctrl.friction_compensation else None)
        limit = min(self.ctrl.torque_limit, avail) if avail > 0 else 0.0 * avail
        if self.motor is not None and self.motor.envelope and not self.continuous:
            limit = torque_window(float(x.q2d), self.motor, i_limit=np.inf, torque_limit=limit)
        tau_hat, v, v_hat, e_t, tau0 = saturate_with_antiwindup(
            e, xK, K, a, b + a * v_ff, limit, self.ctrl.aw_gain)
        q = self.ctrl.torque_quantum
        if q > 0:  # firmware: truncate to whole units toward zero
            tau_hat = np.trunc(tau_hat / q) * q
        return r, e_t, tau_hat, v_hat + v_ff, tau0

    def _split(self, vec):
        """(prefilter state xF, outer-loop state xK) of a state vector."""
        return vec[:self.nF], vec[self.nF:self.nF + self.nK]


class DiscreteCpflController(_CpflLaw, PySystem):
    """The controller at ``ctrl.period`` on the tick schedule
    (:mod:`bplir_drake.systems.schedule`): the tick's command is computed
    once from the stored filter states and the inputs, and the filter states
    are advanced and stored at the next tick; for ``ctrl.delay_samples = 1``
    the command is applied one sample later (the lab firmware).  Ports as
    :func:`CpflController`."""

    def __init__(self, plant: PlantParams, ctrl: ControllerParams,
                 friction: FrictionParams | None = None, use_prefilter: bool = True,
                 motor=None):
        PySystem.__init__(self)
        self._setup(plant, ctrl, friction, False, use_prefilter, motor)
        # the discrete state, one named group each: the prefilter's state xF,
        # the outer loop's xK and the command of the previous tick (applied
        # now with delay_samples = 1)
        self._xF = self.DeclareDiscreteState(self.nF)
        self._xK = self.DeclareDiscreteState(self.nK)
        self._previous = self.DeclareDiscreteState(1)
        self._tick = declare_tick_result(
            self, self._tick_law, {self.xd_ticket(), self.all_input_ports_ticket()})
        declare_store(self, ctrl.period, self._store)
        dep = {self._tick.ticket()}
        self.torque_port = self.DeclareVectorOutputPort("torque", 1, self._result(0), dep)
        self.v_port = self.DeclareVectorOutputPort("v", 1, self._result(1), dep)
        self.unsaturated_port = self.DeclareVectorOutputPort("torque_unsaturated", 1,
                                                             self._result(2), dep)

    def _tick_law(self, context):
        """(applied torque, v, unsaturated torque, next (xF, xK, command))."""
        state = context.get_discrete_state()
        xF = state.get_vector(self._xF).CopyToVector()
        xK = state.get_vector(self._xK).CopyToVector()
        r, e_t, tau_hat, v, tau0 = self._law(context, xF, xK)
        xF = self.F.A @ xF + self.F.B[:, 0] * r
        xK = self.K.A @ xK + self.K.B[:, 0] * e_t
        applied = state.get_vector(self._previous).GetAtIndex(0) if self.ctrl.delay_samples \
            else tau_hat
        return applied, v, tau0, (xF, xK, tau_hat)

    def _store(self, context, discrete_state):
        xF, xK, command = self._tick.Eval(context)[3]
        discrete_state.get_mutable_vector(self._xF).SetFromVector(xF)
        discrete_state.get_mutable_vector(self._xK).SetFromVector(xK)
        discrete_state.get_mutable_vector(self._previous).SetAtIndex(0, command)

    def _result(self, index):
        def calc(context, out):
            out.SetAtIndex(0, self._tick.Eval(context)[index])
        return calc


@TemplateSystem.define("ContinuousCpflController_", T_list=(float, AutoDiffXd),
                       scope=sys.modules[__name__])
def ContinuousCpflController_(T):
    """The CPFL controller in continuous time, scalar-templated (double, AutoDiffXd) so a loop
    holding it linearises; ports as :func:`CpflController`."""
    class Impl(_CpflLaw, LeafSystem_[T]):
        """K and F in continuous time, so a loop containing the controller
        can be linearised (converts to AutoDiffXd).  Ports as
        :func:`CpflController`."""

        def _construct(self, plant: PlantParams, ctrl: ControllerParams,
                       friction: FrictionParams | None = None, use_prefilter: bool = True,
                       converter=None):
            LeafSystem_[T].__init__(self, converter)
            self._setup(plant, ctrl, friction, True, use_prefilter)
            if self.nF + self.nK:
                self.DeclareContinuousState(self.nF + self.nK)
            self.DeclareVectorOutputPort("torque", 1, weak_callback(self, self._out(2)))
            self.DeclareVectorOutputPort("v", 1, weak_callback(self, self._out(3)))
            self.DeclareVectorOutputPort("torque_unsaturated", 1,
                                         weak_callback(self, self._out(4)))

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.plant_params, other.ctrl, other.friction,
                            other.use_prefilter, converter=converter)

        def _xc(self, context):
            if self.nF + self.nK == 0:
                return np.zeros(0)
            return context.get_continuous_state_vector().CopyToVector()

        def DoCalcTimeDerivatives(self, context, derivatives):
            if self.nF + self.nK == 0:
                return
            xF, xK = self._split(self._xc(context))
            r, e_t, *_ = self._law(context, xF, xK)
            dF = self.F.A @ xF + self.F.B[:, 0] * r
            dK = self.K.A @ xK + self.K.B[:, 0] * e_t
            derivatives.get_mutable_vector().SetFromVector(np.concatenate([dF, dK]))

        def _out(self, index):
            def calc(context, out):
                xF, xK = self._split(self._xc(context))
                out.SetAtIndex(0, self._law(context, xF, xK)[index])
            return calc

    return Impl


with quick_template_scopes():
    ContinuousCpflController = ContinuousCpflController_[None]


def CpflController(plant: PlantParams, ctrl: ControllerParams,
                   friction: FrictionParams | None = None, continuous: bool = False,
                   use_prefilter: bool = True, motor=None):
    """The CPFL controller: inputs ``state`` (q1, q2, q1d, q2d: relative,
    estimated or true), ``reference`` (q2_ref), ``feedforward`` (v_ff,
    rad/s^2), ``torque_available`` (N m); outputs ``torque`` (saturated
    command), ``v`` (outer-loop signal realised), ``torque_unsaturated``.

    ``continuous=True``: K and F in continuous time (for linearisation,
    :class:`ContinuousCpflController`); otherwise discrete
    (:class:`DiscreteCpflController`).  ``use_prefilter=False`` bypasses F
    (path tracking: the smooth path comes with its own feed-forward; a step
    prefilter would only add lag).  ``motor`` (the nominal motor; discrete
    controller only): the saturation also holds the torque within the
    voltage envelope at the state input's elbow rate, and the anti-windup
    acts on that bound."""
    if continuous:
        return ContinuousCpflController(plant, ctrl, friction, use_prefilter)
    return DiscreteCpflController(plant, ctrl, friction, use_prefilter, motor)
