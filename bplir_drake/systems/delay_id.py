"""Identifying the actuation delay at the start of every swing.

A robot's actuation delay (the firmware's command pipeline, the driver)
is not what the nominal model says to within a controller period, and the
delay compensation of :class:`~bplir_drake.systems.predictor.DelayPredictor`
helps only when it assumes the right one: the realistic study's misses
gather where the true delay is two periods and the tracker assumes one.

The smooth part of a swing's command cannot tell the delay apart from a
model error (a ramp that acts 10 ms late looks like a slightly heavier
link), so the controller makes the delay visible: a *probe*, two opposite
doublets (``+A, +A, -A, -A, -A, -A, +A, +A``: zero net impulse and zero net
displacement; the elbow moves by under 0.01 rad and comes back) on top of
the first eight ticks' commands
(:class:`~bplir_drake.systems.plan_tracker.PlanTracker` adds it).  The two
gyros see the doublets' triangles in the link rates ``delay`` ticks
late.  :class:`DelayIdentifier` records the first
``window`` ticks' commands and gyro samples, predicts the gyro rates for
every candidate delay ``0 .. max_steps`` ticks on the nominal model (plant,
friction and the driver's current loop, :func:`probe_rates`), removes each
gyro's mean error (the gyro biases, a steady model error) and keeps the
candidate with the least squared error -- if the runner-up's error is at
least ``min_ratio`` times it; a fit that cannot tell the candidates apart
(sensors far noisier than the study's) keeps the nominal delay."""
from __future__ import annotations


import numpy as np
from pydrake.systems.framework import EventStatus

from .pysystem import PySystem
from ..params import FrictionParams, MotorParams, PlantParams
from . import nominal_kernel
from .schedule import declare_store

#: the probe's torque pattern, in units of its amplitude, from tick 0: two
#: opposite doublets (zero net impulse and zero net displacement)
PROBE_PATTERN = (1.0, 1.0, -1.0, -1.0, -1.0, -1.0, 1.0, 1.0)


def probe_torques(amplitude: float) -> tuple[float, ...]:
    """The probe's torques (N m) of ticks 0, 1, ...: the doublet
    :data:`PROBE_PATTERN` of ``amplitude`` (empty for 0)."""
    return tuple(amplitude * s for s in PROBE_PATTERN) if amplitude else ()


def planned_probe(path, plan, controller) -> tuple[float, ...]:
    """The probe's torques (N m, ticks 0, 1, ...) that the plan tracker of
    the ``path``, ``plan`` and ``controller`` blocks adds: none unless it
    tracks a plan (``path.mode = "plan"``) without a delay set in
    ``controller.delay_compensation``."""
    if path.mode != "plan" or controller.delay_compensation:
        return ()
    return probe_torques(plan.delay_probe)


def probe_rates(q0, commands, steps: int, period: float, latency: float, plant: PlantParams,
                friction: FrictionParams, motor: MotorParams, substeps: int = 10,
                constants=None) -> np.ndarray:
    """The absolute link rates (gyro 1, gyro 2; rad/s) at ticks 1 .. N of
    the nominal model started at rest at the relative angles ``q0`` when
    the command of tick k (``commands``, N values, N m) reaches the driver
    ``steps`` ticks and ``latency`` s later; the driver's dead-band and
    torque limit apply and its current follows with ``motor.tau_current``
    (exactly, over each substep).  RK4 on the plant, ``substeps`` per tick
    (compiled: :func:`~bplir_drake.systems.nominal_kernel.probe_rates`;
    ``constants``: the model's :func:`~bplir_drake.systems.nominal_kernel.pack`)."""
    c = nominal_kernel.pack(plant, friction) if constants is None else constants
    return nominal_kernel.probe_rates(
        c, float(q0[0]), float(q0[1]), np.asarray(commands, dtype=float).ravel(), int(steps),
        float(period), float(latency),
        np.array([motor.torque_limit, motor.deadband, motor.tau_current]), int(substeps))


def delay_fit(q0, commands, gyros, max_steps: int, period: float, latency: float,
              plant: PlantParams, friction: FrictionParams, motor: MotorParams) -> np.ndarray:
    """The squared gyro error (rad^2/s^2) of every candidate delay ``0 ..
    max_steps`` ticks: the gyro samples ``gyros`` of ticks 1 .. N (N x 2)
    against :func:`probe_rates` of ``commands`` (ticks 0 .. N-1), each
    gyro's mean error removed."""
    gyros = np.asarray(gyros, dtype=float)
    c = nominal_kernel.pack(plant, friction)
    sse = []
    for steps in range(max_steps + 1):
        e = gyros - probe_rates(q0, commands, steps, period, latency, plant, friction, motor,
                                constants=c)
        e -= e.mean(axis=0)
        sse.append(float((e ** 2).sum()))
    return np.array(sse)


class DelayIdentifier(PySystem):
    """Inputs ``imu`` (the sample of the tick, ``IMU_COLUMNS`` order) and
    ``command`` (the controller's command of the tick, probe included);
    output ``delay_steps``: the delay (whole ticks) the controller should
    compensate -- ``nominal_steps`` until the first ``window`` ticks are
    in, then the candidate of :func:`delay_fit` with the least error,
    latched for the swing (``nominal_steps`` still if the runner-up's error
    is less than ``min_ratio`` times the winner's).  Output ``fit``: ``(delay_steps, the runner-up's
    error over the winner's)`` (0 until identified), a confidence for the
    record.  Discrete state: the commands of ticks 0 .. window-1, the gyro
    samples of ticks 1 .. window, the tick count and the result, stored at
    each tick (:mod:`bplir_drake.systems.schedule`)."""

    def __init__(self, q0, plant: PlantParams, friction: FrictionParams, motor: MotorParams,
                 period: float, latency: float, max_steps: int, nominal_steps: int,
                 window: int = 12, min_ratio: float = 1.25):
        super().__init__()
        if window < 2 or max_steps < 1:
            raise ValueError("DelayIdentifier needs window >= 2 and max_steps >= 1")
        self.q0 = (float(q0[0]), float(q0[1]))
        self.model = (plant, friction, motor)
        self.period, self.latency = float(period), float(latency)
        self.max_steps, self.window = int(max_steps), int(window)
        self.nominal_steps, self.min_ratio = int(nominal_steps), float(min_ratio)
        self.imu_port = self.DeclareVectorInputPort("imu", 6)
        self.command_port = self.DeclareVectorInputPort("command", 1)
        n = self.window
        # [commands 0..n-1, gyro1 1..n, gyro2 1..n, ticks stored, steps, ratio]
        self._xd = self.DeclareDiscreteState(
            np.concatenate([np.zeros(3 * n), [0.0, float(nominal_steps), 0.0]]))
        declare_store(self, period, self._store)
        xd = {self.xd_ticket()}
        self.DeclareVectorOutputPort("delay_steps", 1, lambda c, o: o.SetAtIndex(
            0, c.get_discrete_state(self._xd).GetAtIndex(3 * n + 1)), xd)
        self.DeclareVectorOutputPort("fit", 2, self._calc_fit, xd)

    def _calc_fit(self, context, out):
        out.SetFromVector(self.fit(context.get_discrete_state(self._xd).get_value()))

    def fit(self, x):
        """The ``fit`` output of the state ``x``."""
        n = self.window
        done = x[3 * n] > n
        return [x[3 * n + 1] if done else 0.0, x[3 * n + 2] if done else 0.0]

    def _store(self, context, discrete_state):
        """At ``t_{k+1}``: store tick k's command and gyro sample; once
        ticks 0 .. window are in, identify."""
        x = context.get_discrete_state(self._xd).get_value()
        if x[3 * self.window] > self.window + 0.5:
            return EventStatus.DidNothing()
        discrete_state.get_mutable_vector(self._xd).SetFromVector(self.stored(
            x, lambda: self.command_port.Eval(context)[0],
            lambda: self.imu_port.Eval(context)[:2]))

    def stored(self, x, command, gyro):
        """The state after storing a tick (``x`` itself once identified):
        ``command()`` and ``gyro()`` give the tick's command and its two gyro
        readings (read only when stored)."""
        n = self.window
        k = int(x[3 * n] + 0.5)   # a count held as a float
        if k > n:
            return x
        x = np.array(x, dtype=float)
        if k < n:
            x[k] = command()
        if k >= 1:
            x[n + k - 1], x[2 * n + k - 1] = gyro()
        x[3 * n] = k + 1
        if k == n:
            sse = delay_fit(self.q0, x[:n], np.column_stack([x[n:2 * n], x[2 * n:3 * n]]),
                            self.max_steps, self.period, self.latency, *self.model)
            best = int(np.argmin(sse))
            runner_up = np.min(np.delete(sse, best))
            ratio = runner_up / max(sse[best], 1e-300)
            x[3 * n + 1] = best if ratio >= self.min_ratio else self.nominal_steps
            x[3 * n + 2] = ratio
        return x
