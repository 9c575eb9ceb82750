"""The robot's computer as one system: the IMU sampler, the EKF, the delay
identifier, the delay predictor and the plan tracker of one tick, fused.

Each part stays its own system and tested unit
(:class:`~bplir_drake.systems.imu.ImuSampler`,
:class:`~bplir_drake.systems.ekf.KinematicEkf`,
:class:`~bplir_drake.systems.delay_id.DelayIdentifier`,
:class:`~bplir_drake.systems.predictor.DelayPredictor`,
:class:`~bplir_drake.systems.plan_tracker.PlanTracker`); this system runs
their tick functions on one state vector in one event a tick, so a swing
crosses from C++ into Python once a tick for the whole chain rather than
once a part; without a line sensor the sample, the filter step, the
prediction and a time-indexed tracker's tick (but where its terminal law
runs) are one call into compiled code
(:func:`~bplir_drake.systems.onboard_kernel.tick`).  At ``t_k`` it takes
IMU sample ``k`` and runs the tick on it at once, holding the results it
gives out until ``t_{k+1}`` in its state (the command, the estimate and
the logged signals are C++ state output ports): what the parts wired one
by one give out during ``[t_k, t_{k+1})``
(:mod:`bplir_drake.systems.schedule`).  So it computes the same numbers,
bit for bit, as the parts wired one by one; a line sensor is read as the
sample it takes at ``t_k`` (its ``line_gap_now``).
"""
from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import EventStatus

from . import onboard_kernel
from .onboard_kernel import REC_COMMAND, REC_REFERENCE
from .pysystem import PySystem
from .schedule import declare_sample
from .state import (ACCEL1_X, ACCEL1_Y, ACCEL2_X, ACCEL2_Y, GYRO1_Z, GYRO2_Z, OMEGA1, OMEGA2,
                    THETA1, THETA2)




class OnboardComputer(PySystem):
    """Inputs ``imu_readings`` (12: the ideal IMU readings gyro1, gyro2,
    accel1, accel2, 3 each, the sampler's four inputs in one; a C++
    ``Multiplexer`` gathers them) and, when the EKF fuses a line sensor,
    ``line_gap`` (the sensor's ``line_gap_now``).  Outputs, as the parts':
    ``imu``, ``estimate``, ``estimate_relative``, ``covariance_diagonal``,
    ``gyro_bias``, ``predicted`` (with a predictor), ``torque``,
    ``reference`` and, with an identifier, ``delay_steps`` and ``fit``; and
    ``record``, the tick's signals in one vector (:data:`RECORD`).  The
    command, the estimate and the record are its state (C++ output ports).

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
        defaults = {id(unit): unit.AllocateDiscreteVariables() for _, unit, _ in parts}
        for name, unit, group in parts:
            v = defaults[id(unit)].get_vector(group).CopyToVector()
            self.slices[name] = slice(at, at + len(v))
            values.append(v)
            at += len(v)
        self._imu = self.slices["imu"]
        self._at = np.array([self.slices[name].start for name in onboard_kernel.AT[:5]]
                            + [ekf.n, *((self.slices["predictor"].start, predictor.steps)
                                        if predictor is not None else (-1, 0))],
                            dtype=np.int64)
        self._pred_c = predictor._constants if predictor is not None else np.zeros(1)
        # the identifier's count of stored ticks (it is done past ``window``; the
        # front copies its part unchanged) and its identified delay
        self._ticks_at = (self.slices["identifier"].start + 3 * identifier.window
                          if identifier is not None else None)
        self._steps_at = self._ticks_at + 1 if identifier is not None else None
        self._calibrate_after = ekf.params.calibrate_after
        # what the tick reads every time, looked up once
        self._tracker_at = self.slices["tracker"]
        self._tracker_steps = tracker.steps_port is not None
        self._last_command = (self.slices["predictor"].stop - 1 if predictor is not None
                              else None)
        self._compiled_tracker = tracker.indexing == "time"
        self.readings_port = self.DeclareVectorInputPort("imu_readings", 12)
        self.line_port = (self.DeclareVectorInputPort("line_gap", 2)
                          if ekf.line_port is not None else None)
        # the sensors' and the calibration's parameters (the sampler's and the
        # EKF's), one abstract parameter read once a tick
        self._own = self.DeclareAbstractParameter(AbstractValue.Make(
            (sampler.sensor, ekf.compiled_calibration)))
        self._xd = self.DeclareDiscreteState(np.concatenate(values))
        # the tick's results, held until the next tick: C++ output ports
        self._estimate = self.DeclareDiscreteState(4)
        self._command = self.DeclareDiscreteState(1)
        self._record = self.DeclareDiscreteState(onboard_kernel.RECORD_SIZE)
        self._rec = np.empty(onboard_kernel.RECORD_SIZE)
        self._front = self._front_parts if self.line_port is not None else self._front_compiled
        declare_sample(self, self.period, self._tick)   # t_0 by initialization, then each t_k
        self._declare_outputs()

    #: the tick's signals in the ``record`` output, by name (one logger
    #: records them): :data:`~bplir_drake.systems.onboard_kernel.RECORD_FIELDS`
    RECORD = onboard_kernel.record_slices()

    def record_columns(self) -> dict[str, slice]:
        """The logged signals of :data:`RECORD` (the swing's log names): no
        ``delay_fit`` without an identifier; the predicted state and the
        delay are outputs of their own, not logged."""
        return {k: v for k, v in self.RECORD.items()
                if k not in ("predicted", "delay_steps")
                and (k != "delay_fit" or self.identifier is not None)}

    def _declare_outputs(self) -> None:
        s, rec = self.slices, self.RECORD
        self.DeclareStateOutputPort("estimate_relative", self._estimate)
        self.DeclareStateOutputPort("torque", self._command)
        self.DeclareStateOutputPort("record", self._record)
        xd = {self.xd_ticket()}
        out = self.DeclareVectorOutputPort

        def parts(c):
            return c.get_discrete_state(self._xd).get_value()

        def recorded(c, name):
            return c.get_discrete_state(self._record).get_value()[rec[name]]

        out("imu", 6, lambda c, o: o.SetFromVector(parts(c)[self._imu][:6]), xd)
        out("estimate", 4, lambda c, o: o.SetFromVector(parts(c)[s["ekf_x"]][:4]), xd)
        n = self.ekf.n
        out("covariance_diagonal", n, lambda c, o: o.SetFromVector(
            np.diag(parts(c)[s["ekf_P"]].reshape(n, n))), xd)
        bias = self.ekf._bias
        out("gyro_bias", 2, lambda c, o: o.SetFromVector(
            parts(c)[s["ekf_x"]][bias] if bias is not None else [0.0, 0.0]), xd)
        if self.predictor is not None:
            out("predicted", 4, lambda c, o: o.SetFromVector(recorded(c, "predicted")), xd)
        out("reference", 1, lambda c, o: o.SetFromVector(recorded(c, "reference")), xd)
        if self.identifier is not None:
            out("delay_steps", 1, lambda c, o: o.SetFromVector(recorded(c, "delay_steps")), xd)
            out("fit", 2, lambda c, o: o.SetFromVector(recorded(c, "delay_fit")), xd)

    # ------------------------------------------------------------ the tick
    def _tick(self, context, discrete_state):
        """At ``t_k``: take IMU sample ``k``, run every part's tick on it
        (from the parts' state after tick ``k - 1``) and hold their state
        after tick ``k`` and the tick's results until ``t_{k+1}`` -- what the
        parts wired one by one give out during ``[t_k, t_{k+1})`` and store
        at ``t_{k+1}``."""
        xd = context.get_discrete_state(self._xd).get_value()
        steps = xd[self._steps_at] if self._steps_at is not None else 0.0
        rec = self._rec   # RECORD's layout (set_value copies it)
        new, ticked, relative, state = self._front(context, xd, steps, rec)
        if not ticked:   # the terminal law's tick (or the tracker's, not compiled)
            tracked = self.tracker.tick(state, xd[self._tracker_at],
                                        steps if self._tracker_steps else None)
            new[self._tracker_at] = tracked[2:]
            if self._last_command is not None:
                new[self._last_command] = tracked[0]
            rec[REC_COMMAND], rec[REC_REFERENCE] = tracked[0], tracked[1]
        if self.identifier is not None:
            self._identify(xd, new, rec)
        discrete_state.set_value(self._xd, new)
        discrete_state.set_value(self._estimate, relative)
        discrete_state.set_value(self._command, rec[REC_COMMAND:REC_COMMAND + 1])
        discrete_state.set_value(self._record, rec)
        return EventStatus.Succeeded()

    def _identify(self, xd, new, rec) -> None:
        """The delay identifier's part of the tick: its fit into the record
        and, until it has identified, the tick's command and gyro sample
        stored."""
        s = self.slices
        held = xd[s["identifier"]]
        rec[self.RECORD["delay_fit"]] = self.identifier.fit(held)
        if xd[self._ticks_at] < self.identifier.window + 0.5:   # still storing
            imu = new[self._imu]
            new[s["identifier"]] = self.identifier.stored(held, lambda: rec[REC_COMMAND],
                                                          lambda: imu[:2])

    def _front_compiled(self, context, xd, steps, rec):
        """(the state after the tick -- the identifier's part still the
        stored one, and the tracker's and the predictor's last command's too
        where the tracker has not ticked --, whether it has, the estimate
        relative, the state the tracker reads), ``rec`` set as
        :func:`~bplir_drake.systems.onboard_kernel.tick` sets it: the
        sample, filter step, prediction and the tracker's time-indexed tick
        in one call."""
        (_, seed, imu_c), (_, ekf_c, walk, cal, held) = context.get_abstract_parameter(
            self._own).get_value()
        k, draws = self.sampler.sample_draws(xd[self._imu], seed)
        p = self.predictor
        new = np.empty(len(xd))
        ticked, relative, state = onboard_kernel.tick(
            xd, self.readings_port.Eval(context), draws, k, imu_c,
            context.get_time() < self._calibrate_after, held, ekf_c, walk, cal, self._pred_c,
            self._at, self.period,
            p.taken(steps if p.steps_port is not None else None) if p is not None else 0, new,
            rec, steps, self._compiled_tracker, self._tracker_at.start,
            *self.tracker.compiled_tick(steps if self._tracker_steps else None))
        return new, ticked, relative, state

    def _front_parts(self, context, xd, steps, rec):
        """As :meth:`_front_compiled`, through the parts' own tick functions
        (with a line sensor, whose update the compiled front does not make),
        the tracker left to the caller."""
        s, r = self.slices, self.readings_port.Eval(context)
        sensor, compiled = context.get_abstract_parameter(self._own).get_value()
        new = np.array(xd)
        imu = self.sampler.next_state(xd[self._imu], r[GYRO1_Z], r[GYRO2_Z], r[ACCEL1_X],
                                      r[ACCEL1_Y], r[ACCEL2_X], r[ACCEL2_Y], sensor)
        post, u = self.ekf.posterior(
            xd[s["ekf_x"]], xd[s["ekf_P"]], xd[s["ekf_u"]], xd[s["ekf_first"]][0] > 0.5,
            imu[:6], context.get_time(), compiled,
            self.line_port.Eval(context) if self.line_port is not None else None)
        x = post.x
        relative = np.array([x[THETA1], x[THETA2] - x[THETA1], x[OMEGA1], x[OMEGA2] - x[OMEGA1]])
        state = relative
        if self.predictor is not None:
            state = self.predictor.prediction(xd[s["predictor"]], relative,
                                              steps if self.predictor.steps_port is not None
                                              else None)
            p = s["predictor"]
            new[p.start:p.stop - 1] = xd[p.start + 1:p.stop]
        new[s["ekf_x"]], new[s["ekf_P"]], new[s["ekf_u"]] = x, post.P.ravel(), u
        new[s["ekf_first"]] = 0.0
        new[self._imu] = imu
        R = self.RECORD
        rec[R["estimate"]], rec[R["imu"]], rec[R["delay_fit"]] = relative, imu[:6], 0.0
        rec[R["predicted"]], rec[R["delay_steps"]] = state, steps
        return new, False, relative, state

    # ------------------------------------------------- a Monte Carlo sample
    def set_sensor(self, context, params, seed: int) -> None:
        """As :meth:`ImuSampler.set_sensor`."""
        own = self.GetMyMutableContextFromRoot(context)
        value = own.get_mutable_abstract_parameter(self._own)
        value.set_value((self.sampler.sensor_of(params, seed), value.get_value()[1]))

    def set_calibration(self, context, calibration) -> None:
        """As :meth:`KinematicEkf.set_calibration`."""
        own = self.GetMyMutableContextFromRoot(context)
        value = own.get_mutable_abstract_parameter(self._own)
        value.set_value((value.get_value()[0], self.ekf._compiled(calibration)))
        xd = own.get_mutable_discrete_state(self._xd)
        v, s = xd.CopyToVector(), self.slices
        v[s["ekf_x"]], v[s["ekf_P"]] = self.ekf.calibrated_start(v[s["ekf_x"]], v[s["ekf_P"]],
                                                                 calibration)
        xd.SetFromVector(v)
