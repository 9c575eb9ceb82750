"""The robot's computer as one system: the IMU sampler, the EKF, the delay
identifier, the delay predictor and the plan tracker of one tick, fused.

Each part stays its own system and tested unit
(:class:`~bplir_drake.systems.imu.ImuSampler`,
:class:`~bplir_drake.systems.ekf.KinematicEkf`,
:class:`~bplir_drake.systems.delay_id.DelayIdentifier`,
:class:`~bplir_drake.systems.predictor.DelayPredictor`,
:class:`~bplir_drake.systems.plan_tracker.PlanTracker`); this system runs
their tick functions on one state vector, with one event and one cached
result a tick, so a swing crosses from C++ into Python once a tick for the
whole chain rather than once a part.  It keeps the parts' tick schedule
(:mod:`bplir_drake.systems.schedule`) and so computes the same numbers,
bit for bit, as the parts wired one by one.
"""
from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import EventStatus

from .base import PySystem
from .imu import pack
from .schedule import declare_tick_result


def _default_state(unit, *groups) -> list[np.ndarray]:
    """The default values of discrete state ``groups`` of a unit system."""
    ctx = unit.CreateDefaultContext()
    return [ctx.get_discrete_state(g).CopyToVector() for g in groups]


class OnboardComputer(PySystem):
    """Inputs ``imu_readings`` (12: the ideal IMU readings gyro1, gyro2,
    accel1, accel2, 3 each, the sampler's four inputs in one; a C++
    ``Multiplexer`` gathers them) and, when the EKF fuses a line sensor,
    ``line_gap``.  Outputs, as the parts': ``imu``, ``estimate``,
    ``estimate_relative``, ``covariance_diagonal``, ``gyro_bias``,
    ``predicted`` (with a predictor), ``torque``, ``reference`` and, with
    an identifier, ``delay_steps`` and ``fit``; and ``record``, the tick's
    signals in one vector (:data:`RECORD`).

    ``sampler``, ``ekf``, ``tracker`` and the optional ``identifier`` and
    ``predictor`` are the parts, built as for a diagram of their own and
    not added to one; the tracker reads the predictor's state (the
    estimate's when there is none) and the identifier's delay when either
    is adaptive, as :func:`~bplir_drake.diagrams.swing_controller.add_swing_controller`
    wires them.  The parts must tick at one period."""

    def __init__(self, sampler, ekf, tracker, identifier=None, predictor=None):
        super().__init__()
        self.sampler, self.ekf, self.tracker = sampler, ekf, tracker
        self.identifier, self.predictor = identifier, predictor
        self.period = tracker.period
        # the state, in the order the store writes it (the EKF's x first)
        parts = [("ekf_x", ekf, ekf._x), ("ekf_P", ekf, ekf._P), ("ekf_u", ekf, ekf._u),
                 ("ekf_first", ekf, ekf._first), ("tracker", tracker, tracker._xd)]
        if predictor is not None:
            parts.append(("predictor", predictor, predictor._xd))
        if identifier is not None:
            parts.append(("identifier", identifier, identifier._xd))
        parts.append(("imu", sampler, sampler._state))
        values, self.slices, at = [], {}, 0
        for name, unit, group in parts:
            [v] = _default_state(unit, group)
            self.slices[name] = slice(at, at + len(v))
            values.append(v)
            at += len(v)
        self._imu = self.slices["imu"]
        self._steps_at = (self.slices["identifier"].start + 3 * identifier.window + 1
                          if identifier is not None else None)
        self.readings_port = self.DeclareVectorInputPort("imu_readings", 12)
        self.line_port = (self.DeclareVectorInputPort("line_gap", 2)
                          if ekf.line_port is not None else None)
        ctx = sampler.CreateDefaultContext()
        self._sensor = self.DeclareAbstractParameter(AbstractValue.Make(
            ctx.get_abstract_parameter(sampler._sensor).get_value()))
        ctx = ekf.CreateDefaultContext()
        self._calibration = self.DeclareAbstractParameter(AbstractValue.Make(
            ctx.get_abstract_parameter(ekf._calibration).get_value()))
        self._xd = self.DeclareDiscreteState(np.concatenate(values))
        prerequisites = {self.xd_ticket()}
        if self.line_port is not None:
            prerequisites.add(self.line_port.ticket())
        self._tick = declare_tick_result(self, self._result, prerequisites)
        self.DeclareInitializationDiscreteUpdateEvent(self._first_sample)
        self.DeclarePeriodicDiscreteUpdateEvent(self.period, 0.0, self._store)
        self._declare_outputs()

    def _declare_outputs(self) -> None:
        xd, dep = {self.xd_ticket()}, {self._tick.ticket()}
        s = self.slices
        out = self.DeclareVectorOutputPort
        out("imu", 6, lambda c, o: o.SetFromVector(c.get_discrete_state(self._xd).get_value()[
            s["imu"]][:6]), xd)
        out("estimate", 4, lambda c, o: o.SetFromVector(self._tick.Eval(c)[0][:4]), dep)
        out("estimate_relative", 4, lambda c, o: o.SetFromVector(self._tick.Eval(c)[3]), dep)
        out("covariance_diagonal", self.ekf.n, lambda c, o: o.SetFromVector(
            np.diag(self._tick.Eval(c)[1])), dep)
        bias = self.ekf._bias
        out("gyro_bias", 2, lambda c, o: o.SetFromVector(
            self._tick.Eval(c)[0][bias] if bias is not None else [0.0, 0.0]), dep)
        if self.predictor is not None:
            out("predicted", 4, lambda c, o: o.SetFromVector(self._tick.Eval(c)[4]), dep)
        out("torque", 1, lambda c, o: o.SetAtIndex(0, self._tick.Eval(c)[5][0]), dep)
        out("reference", 1, lambda c, o: o.SetAtIndex(0, self._tick.Eval(c)[5][1]), dep)
        out("record", 14, self._record, {self.xd_ticket(), self._tick.ticket()})
        if self.identifier is not None:
            n = 3 * self.identifier.window + 1
            out("delay_steps", 1, lambda c, o: o.SetAtIndex(0, c.get_discrete_state(
                self._xd).get_value()[s["identifier"]][n]), xd)
            out("fit", 2, lambda c, o: o.SetFromVector(self.identifier.fit(
                c.get_discrete_state(self._xd).get_value()[s["identifier"]])), xd)

    #: the signals of the ``record`` output (one logger records the tick's
    #: signals), by the swing's log names: the estimate (relative), the
    #: command, the planned q2, the IMU sample and the delay fit (zeros
    #: without an identifier)
    RECORD = {"estimate": slice(0, 4), "command": slice(4, 5), "reference": slice(5, 6),
              "imu": slice(6, 12), "delay_fit": slice(12, 14)}

    def record_columns(self) -> dict[str, slice]:
        """:data:`RECORD` for this computer (no ``delay_fit`` without an
        identifier)."""
        return {k: v for k, v in self.RECORD.items()
                if k != "delay_fit" or self.identifier is not None}

    def _record(self, context, out):
        r = self._tick.Eval(context)
        xd = context.get_discrete_state(self._xd).get_value()
        fit = (self.identifier.fit(xd[self.slices["identifier"]])
               if self.identifier is not None else (0.0, 0.0))
        out.SetFromVector(np.concatenate((r[3], r[5][:2], xd[self._imu][:6], fit)))

    # ------------------------------------------------------------ the tick
    def _result(self, context):
        """The tick's results from the stored state: (the EKF's posterior x,
        P and accelerometer input of the held sample, the relative estimate,
        the predicted state, the tracker's (torque, planned q2, phase, tick
        count, reach))."""
        xd, s = context.get_discrete_state(self._xd).get_value(), self.slices
        post, u = self.ekf.posterior(
            xd[s["ekf_x"]], xd[s["ekf_P"]], xd[s["ekf_u"]], xd[s["ekf_first"]][0] > 0.5,
            xd[self._imu][:6], context.get_time(),
            context.get_abstract_parameter(self._calibration).get_value(),
            self.line_port.Eval(context) if self.line_port is not None else None)
        x = post.x
        relative = np.array([x[0], x[1] - x[0], x[2], x[3] - x[2]])
        steps = xd[self._steps_at] if self._steps_at is not None else None
        state = relative
        if self.predictor is not None:
            state = self.predictor.prediction(xd[s["predictor"]], relative,
                                              steps if self.predictor.steps_port is not None
                                              else None)
        tracked = self.tracker.tick(state, xd[s["tracker"]],
                                    steps if self.tracker.steps_port is not None else None)
        return x, post.P, u, relative, state, tracked

    def _sample(self, context, imu):
        """The IMU part of the state after the sample of this instant."""
        r = self.readings_port.Eval(context)
        return self.sampler.next_state(imu, r[0:3], r[3:6], r[6:9], r[9:12],
                                       context.get_abstract_parameter(self._sensor).get_value())

    def _first_sample(self, context, discrete_state):
        xd = context.get_discrete_state(self._xd).CopyToVector()
        xd[self._imu] = self._sample(context, xd[self._imu])
        discrete_state.get_mutable_vector(self._xd).SetFromVector(xd)

    def _store(self, context, discrete_state):
        """At ``t_k``, ``k >= 1``: store every part's tick ``k - 1`` result
        and take sample ``k`` (a no-op at ``t_0``, sampled by the
        initialization event)."""
        if context.get_time() < 0.5 * self.period:
            return EventStatus.DidNothing()
        x, P, u, _, _, tracked = self._tick.Eval(context)
        xd, s = context.get_discrete_state(self._xd).get_value(), self.slices
        command = tracked[0]
        new = [x, P.ravel(), u, (0.0,), tracked[2:]]
        if self.predictor is not None:
            new.append(xd[s["predictor"]][1:])
            new.append((command,))
        if self.identifier is not None:
            held = xd[self._imu][:2].copy()
            new.append(self.identifier.stored(xd[s["identifier"]], lambda: command,
                                              lambda: held))
        new.append(self._sample(context, xd[self._imu]))
        discrete_state.get_mutable_vector(self._xd).SetFromVector(np.concatenate(new))

    # ------------------------------------------------- a Monte Carlo sample
    def set_sensor(self, context, params, seed: int) -> None:
        """As :meth:`ImuSampler.set_sensor`."""
        if params.period != self.sampler.params.period:
            raise ValueError(f"imu.rate_hz = {params.rate_hz:g} differs from the built "
                             f"sampler's {self.sampler.params.rate_hz:g} Hz")
        own = self.GetMyMutableContextFromRoot(context)
        own.get_mutable_abstract_parameter(self._sensor).set_value(
            (params, int(seed), pack(params)))

    def set_calibration(self, context, calibration) -> None:
        """As :meth:`KinematicEkf.set_calibration`."""
        own = self.GetMyMutableContextFromRoot(context)
        own.get_mutable_abstract_parameter(self._calibration).set_value(
            self.ekf._compiled(calibration))
        xd = own.get_mutable_discrete_state(self._xd)
        v, s = xd.CopyToVector(), self.slices
        v[s["ekf_x"]], v[s["ekf_P"]] = self.ekf.calibrated_start(v[s["ekf_x"]], v[s["ekf_P"]],
                                                                 calibration)
        xd.SetFromVector(v)
