"""External disturbances of a swing and a command delay line.

:func:`disturbance_schedule` turns the scenario's disturbance fields into one
zero-order-hold schedule of generalized forces on (joint 1, joint 2):

* ``wind_torque1/2``: constant torques on both joints;
* ``gust_torque`` / ``gust_rate`` / ``gust_duration``: random torque pulses
  (gusts) arriving as a Poisson process, each a rectangle of the given
  duration with an amplitude uniform in ``[-gust_torque, gust_torque]`` on
  each joint independently;
* ``torque_noise``: white noise (standard deviation, N m) on the elbow torque,
  held over each controller period (actuator noise).

Every random draw comes from ``numpy.random.default_rng([seed, 2, 0])`` (the
gusts) and ``[seed, 2, 1]`` (the torque noise), so a swing's disturbances
are reproducible from its seed.  :class:`CommandDelay` delays a discrete
command by a whole number of periods (actuation delay).
"""
from __future__ import annotations

import math

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector

from .pysystem import PySystem
from ..params import ScenarioParams
from .schedule import declare_sample, declare_store


def has_disturbance(sc: ScenarioParams) -> bool:
    """The scenario has wind, gusts or torque noise."""
    return bool(sc.wind_torque1 or sc.wind_torque2 or sc.torque_noise
                or (sc.gust_torque and sc.gust_rate))


def disturbance_schedule(sc: ScenarioParams, seed: int, period: float,
                         duration: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(times (N,), torques (N, 2)): torque[i] holds from times[i] to times[i+1]."""
    duration = sc.max_time + 1.0 if duration is None else duration
    n = int(math.ceil(duration / period)) + 1
    times = np.arange(n) * period
    torque = np.zeros((n, 2))
    torque[:, 0] += sc.wind_torque1
    torque[:, 1] += sc.wind_torque2
    if sc.gust_torque and sc.gust_rate:
        rng = np.random.default_rng([seed, 2, 0])
        t = rng.exponential(1.0 / sc.gust_rate)
        while t < duration:
            amp = rng.uniform(-sc.gust_torque, sc.gust_torque, 2)
            # the ticks from t to t + gust_duration (times ascend: two bisections)
            first, end = np.searchsorted(times, (t - 1e-12, t + sc.gust_duration - 1e-12))
            if first < end:
                torque[first:end] += amp
            else:   # a gust shorter than a period still acts for one period
                torque[min(int(t / period), n - 1)] += amp
            t += rng.exponential(1.0 / sc.gust_rate)
    if sc.torque_noise:
        rng = np.random.default_rng([seed, 2, 1])
        torque[:, 1] += sc.torque_noise * rng.standard_normal(n)
    return times, torque


def add_pulses(torques, period: float, pulses) -> np.ndarray:
    """``torques`` (N, 2), one row per tick of ``period``, with the
    rectangular ``pulses`` ``[(start s, (tau1, tau2) N m, duration s)]``
    added on the ticks from their start to their end (a pulse shorter than
    a tick acts for one tick; pulses before 0 or after the last tick are
    left out)."""
    out = np.array(torques, dtype=float).reshape(-1, 2)
    n = len(out)
    for start, amp, duration in pulses:
        first = int(math.ceil(start / period - 1e-9))
        end = max(int(math.ceil((start + duration) / period - 1e-9)), first + 1)
        if end <= 0 or first >= n:
            continue
        out[max(first, 0):min(end, n)] += np.asarray(amp, dtype=float)
    return out


class DisturbanceSource(PySystem):
    """The generalized forces of a :func:`disturbance_schedule`, held over
    each tick (output ``generalized_force`` (2), N m on joint 1 and 2).

    The schedule's torques are an abstract parameter of the context (default
    the constructor's), so one built diagram serves the wind and gusts of
    other Monte Carlo samples (:meth:`set_schedule`).  At ``t_k`` the torque
    of tick ``k`` is stored in the discrete state (the last row holds on),
    and the output is that state (a C++ state output port: no Python call
    while the integrator steps).
    """

    def __init__(self, torques, period: float):
        super().__init__()
        self.period = period
        self._schedule = self.DeclareAbstractParameter(
            AbstractValue.Make(self._checked(torques)))
        self._xd = self.DeclareDiscreteState(2)
        declare_sample(self, period, self._update)
        self.force_port = self.DeclareStateOutputPort("generalized_force", self._xd)

    @staticmethod
    def _checked(torques) -> np.ndarray:
        torques = np.array(torques, dtype=float).reshape(-1, 2)
        if not len(torques):
            raise ValueError("a disturbance schedule needs at least one row")
        return torques

    def set_schedule(self, context, torques) -> None:
        """The torques (N, 2) of tick ``k = 0 .. N-1`` in ``context`` (root)."""
        own = self.GetMyMutableContextFromRoot(context)
        own.get_mutable_abstract_parameter(self._schedule).set_value(self._checked(torques))

    def _update(self, context, discrete_state):
        torques = context.get_abstract_parameter(self._schedule).get_value()
        k = min(int(round(context.get_time() / self.period)), len(torques) - 1)
        discrete_state.get_mutable_vector(self._xd).SetFromVector(torques[k])


def delay_steps(delay: float, period: float) -> int:
    """Whole controller periods of an actuation delay (rounded to nearest)."""
    return int(round(delay / period))


class CommandDelay(PySystem):
    """Delays a sampled signal by ``steps`` periods on the tick schedule
    (:mod:`bplir_drake.systems.schedule`): at ``t_k`` it stores the tick
    ``k - 1`` value of its input in a FIFO of ``steps`` values and outputs
    the oldest, so the command of tick ``k`` acts during tick ``k + steps``
    (zero before)."""

    def __init__(self, size: int, period: float, steps: int):
        super().__init__()
        if steps < 1:
            raise ValueError("CommandDelay needs steps >= 1")
        self.size, self.steps = size, steps
        self.DeclareVectorInputPort("u", size)
        # [u_{k-steps}, ..., u_{k-1}] during tick k; the output is the first
        self._xd = self.DeclareDiscreteState(size * steps)
        declare_store(self, period, self._update)
        self.DeclareVectorOutputPort("y", size, self._out, {self.xd_ticket()})

    def _update(self, context, discrete_state):
        buf = context.get_discrete_state(self._xd).get_value()
        u = self.get_input_port(0).Eval(context)
        discrete_state.get_mutable_vector(self._xd).SetFromVector(
            np.concatenate([buf[self.size:], u]))

    def _out(self, context, out: BasicVector):
        out.SetFromVector(context.get_discrete_state(self._xd).get_value()[:self.size])
