"""The tick schedule of the sampled chain, in one place.

The robot's computer runs at one rate (``T`` = 10 ms): sample the IMUs,
estimate, evaluate the path, compute the command.  In the diagram every
discrete event of that chain happens at the same instants ``t_k = k T``, so
the integrator stops once per tick, and the information still flows within
the tick, from the sample to the command, without a period of delay:

* **sample** (:func:`declare_sample`): the IMU sampler takes sample ``k`` at
  ``t_k`` (sample 0 by an initialization event, the others by a periodic
  event at ``t_k``, ``k >= 1``) and holds it in its discrete state.
* **compute** (Mealy outputs): the estimator, path generator and controller
  compute their tick-``k`` results as *outputs* of their stored state and
  their inputs -- the held sample, or the upstream results of the same
  tick.  Drake caches each result (:func:`declare_tick_result`); it is
  computed once, when first needed after ``t_k``, and the continuous
  integration in between only reads the cache.
* **store** (:func:`declare_store`): at ``t_{k+1}``, before anything else
  changes, each of these systems stores its tick-``k`` result (evaluated
  with the pre-update values, which are still those of tick ``k``) as its
  new state.  Drake applies all discrete updates of an instant
  simultaneously from the pre-update context, so the order of the systems
  does not matter.

A Drake logger publishing at ``t_k`` (before the updates of that instant)
sees the tick ``k - 1`` results; :class:`TickLogger` records them under
their tick time.  Nothing in this chain reads the clock except through the
tick count.
"""
from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import TriggerType, ValueProducer

from .pysystem import weak_callback


def _after_first_tick(period: float, update):
    """``update`` at the ticks ``t_k``, ``k >= 1`` (a no-op at ``t_0``)."""
    from pydrake.systems.framework import EventStatus

    def handler(context, discrete_state):
        if context.get_time() < 0.5 * period:
            return EventStatus.DidNothing()
        return update(context, discrete_state)

    return handler


def declare_sample(system, period: float, sample) -> None:
    """``sample(context, discrete_state)`` at ``t_k`` for every ``k >= 0``:
    by an initialization event at ``t_0`` (so the sample is there before
    anything reads it) and by the periodic tick event after that."""
    system.DeclareInitializationDiscreteUpdateEvent(sample)
    system.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, _after_first_tick(period, sample))


def declare_store(system, period: float, store) -> None:
    """``store(context, discrete_state)`` at ``t_k``, ``k >= 1``: store the
    tick ``k - 1`` result (the pre-update outputs).  Every tick event has the
    offset 0, so all of them (and Drake's loggers and zero-order holds of the
    same period) fall on bit-identical times."""
    system.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, _after_first_tick(period, store))


def declare_tick_result(system, calc, prerequisites):
    """A cache entry holding ``calc(context)`` (any Python object), computed
    once per change of its ``prerequisites`` (tickets of the inputs and the
    discrete state: once per tick)."""

    def producer(context, value):
        value.set_value(calc(context))

    return system.DeclareCacheEntry(
        "tick result", ValueProducer(allocate=lambda: AbstractValue.Make(None),
                                     calc=weak_callback(system, producer)),
        set(prerequisites))


class TickLogger:
    """A Drake ``VectorLogSink`` (C++) on a sampled signal, publishing at the
    ticks: the row published at ``t_k`` (``k >= 1``) is the tick ``k - 1``
    value, recorded under ``t_{k-1}``."""

    def __init__(self, builder, port, period: float):
        from pydrake.systems.primitives import LogVectorOutput

        self.period = period
        self.sink = LogVectorOutput(port, builder, {TriggerType.kPeriodic}, period)

    def arrays(self, context):
        """(t, data) with data of shape (N, size)."""
        log = self.sink.FindLog(context)
        t = np.array(log.sample_times())
        data = np.array(log.data()).T
        keep = t > 0.5 * self.period
        return t[keep] - self.period, data[keep]


class TickColumns:
    """Columns ``columns`` (a slice) of a :class:`TickLogger`'s log, read as
    a log of their own (one logger records several signals of a system)."""

    def __init__(self, logger: TickLogger, columns: slice):
        self.logger, self.columns, self.period = logger, columns, logger.period

    def arrays(self, context):
        """(t, data) with data of shape (N, the columns' count)."""
        t, data = self.logger.arrays(context)
        return t, data[:, self.columns].copy()
