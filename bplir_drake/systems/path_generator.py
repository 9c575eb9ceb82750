"""The path generator as a Drake system (chapter 7): the reference, its
feed-forward and the adapted blend end on the controller's ticks, with the
online calibration of link 1's damping; the path's geometry and dynamics are
in :mod:`.path`."""
from __future__ import annotations

import math
import sys

import numpy as np
from pydrake.autodiffutils import AutoDiffXd
from pydrake.common.containers import namedview
from pydrake.systems.framework import LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem

from ..params import PathParams, PlantParams
from .path import (PathGeometry, constraint_acceleration, path_derivatives, predict_rate_squared,
                   projected_rate, step_blend_end)
from .pysystem import quick_template_scopes, weak_callback
from .schedule import declare_store, declare_tick_result
from .state import RobotState


def calibrate_damping(x, s, w, s_e, cal_s, cal_Y, fv, g: PathGeometry, pp: PathParams,
                      plant: PlantParams):
    """Online calibration in the RTS half: the effective link-1 damping that
    makes the nominal reduced dynamics reproduce the measured on-path energy
    between two points of the swing; (start s0, its squared rate Y0 -- -1
    once used --, damping N m s/rad)."""
    if math.isnan(cal_s):
        if w > pp.calibrate_start:
            wp = projected_rate(x, s_e, g, pp, plant)
            return s, wp * wp, fv
        return cal_s, cal_Y, fv
    if cal_Y < 0 or s < -pp.calibrate_at * g.s_f or w <= 0:
        return cal_s, cal_Y, fv
    wp = projected_rate(x, s_e, g, pp, plant)
    target = wp * wp

    def err(c):
        return predict_rate_squared(cal_s, math.sqrt(cal_Y), s, g, pp.blend_exponent,
                                    pp.pump_gain, plant, c) - target

    lo, hi = -2.0, 4.0
    elo, ehi = err(lo), err(hi)
    if elo * ehi > 0:  # no bracket: keep the nominal damping
        return cal_s, -1.0, fv
    for _ in range(20):
        mid = 0.5 * (lo + hi)
        if err(mid) * elo > 0:
            lo, elo = mid, err(mid)
        else:
            hi = mid
    return cal_s, -1.0, 0.5 * (lo + hi)


def next_path_state(x, st, g: PathGeometry, pp: PathParams, plant: PlantParams,
                    period: float) -> np.ndarray:
    """One tick of the path state (:data:`PATH_STATE` ``st``) at the estimate
    ``x``: the calibration, the latch and its ramp, the adapted blend end."""
    s_e, floor, latched = st.blend_end, st.blend_floor, st.latched
    cal_s, cal_Y, fv = st.calibration_s0, st.calibration_Y0, st.link1_damping
    x = RobotState(x)
    s, w = x.q1 - g.alpha, x.q1d
    if pp.mode == "adaptive" and pp.calibrate and s < 0:
        cal_s, cal_Y, fv = calibrate_damping(x, s, w, s_e, cal_s, cal_Y, fv, g, pp, plant)
    if latched > 0.5:
        if floor <= 0.0:  # start the ramp from the current blend weight
            floor = min(max(s / s_e, 0.0), 1.0) ** pp.blend_exponent
        floor = min(1.0, floor + pp.latch_ramp * period)
    if latched < 0.5 and pp.mode == "adaptive" and w > 0:
        if -pp.adapt_window * g.s_f < s < pp.adapt_stop * s_e:
            wp = projected_rate(x, s_e, g, pp, plant)
            s_e = step_blend_end(s_e, s, wp, g, pp, plant, fv, pp.adapt_rate * period)
        if s > pp.latch_fraction * s_e and w < pp.latch_rate:
            latched = 1.0
    return np.array([s_e, floor, latched, cal_s, cal_Y, fv])


def path_at(x, st, g: PathGeometry, pp: PathParams):
    """(x, s, q2_ref, dq2/dq1, d2q2/dq1^2) of the path at the estimate ``x``
    with this tick's path state ``st``."""
    s_e, floor, latched = st.blend_end, st.blend_floor, st.latched
    x = RobotState(x)
    s = x.q1 - g.alpha + x.q1d * pp.lead_time
    if pp.mode == "lab":
        k = pp.lab_gain * g.k_f
        return x, s, k * s, k, 0.0 * s
    lam = pp.pump_gain
    if pp.mode != "adaptive":
        s_e = g.s_f
    lift = pp.latch_lift if latched > 0.5 else 0.0
    phi, d1, d2 = path_derivatives(s, s_e, g, pp.blend_exponent, lam, floor, lift=lift)
    return x, s, phi, d1, d2


#: the path generator's discrete state, by name
PATH_STATE = namedview("PathState", ["blend_end", "blend_floor", "latched", "calibration_s0",
                                     "calibration_Y0", "link1_damping"])


@TemplateSystem.define("PathGenerator_", T_list=(float, AutoDiffXd),
                       scope=sys.modules[__name__])
def PathGenerator_(T):
    """The path generator (chapter 7), scalar-templated (double, AutoDiffXd)."""
    class Impl(LeafSystem_[T]):
        """Input ``state`` (q1, q2, q1d, q2d: estimated, relative).  Outputs
        ``reference`` (q2_ref), ``feedforward`` (q2'' of the constraint,
        rad/s^2) and ``blend_end`` (s_e, blend floor).

        On the tick schedule (:mod:`bplir_drake.systems.schedule`): the
        tick's path state (:meth:`_advance`: blend end, blend floor, latch,
        calibration) is computed once from the stored state and the input,
        the outputs are evaluated on it, and it is stored at the next tick.
        Discrete state :data:`PATH_STATE`: the blend end ``s_e`` (rad), the
        blend floor, the latch flag, the calibration's start ``s0`` (rad) and
        ``Y0`` (its squared rate, nan until recorded, -1 once used) and the
        effective link-1 damping (N m s/rad)."""

        def _construct(self, plant: PlantParams, path: PathParams, geometry: PathGeometry,
                       period: float, fv1: float = 0.0, converter=None):
            """``fv1``: nominal viscous friction of joint 1 used by the predictor."""
            LeafSystem_[T].__init__(self, converter)
            self.plant_params, self.path, self.geometry = plant, path, geometry
            self.period, self.fv1 = period, fv1
            self.state_port = self.DeclareVectorInputPort("state", 4)
            self._xd = self.DeclareDiscreteState(
                np.array([geometry.s_f, 0.0, 0.0, np.nan, np.nan, fv1]))  # PATH_STATE
            self._next = declare_tick_result(self, self._advance,
                                             {self.xd_ticket(), self.all_input_ports_ticket()})
            # the path and its derivatives at the estimate, once per tick for both outputs
            self._path_at = declare_tick_result(
                self, self._phi, {self._next.ticket(), self.all_input_ports_ticket()})
            declare_store(self, period, self._store)
            dep = {self._next.ticket()}
            at = {self._path_at.ticket()}
            self.reference_port = self.DeclareVectorOutputPort(
                "reference", 1, weak_callback(self, self._out_ref), at)
            self.feedforward_port = self.DeclareVectorOutputPort(
                "feedforward", 1, weak_callback(self, self._out_ff), at)
            self.blend_end_port = self.DeclareVectorOutputPort(
                "blend_end", 2, weak_callback(self, self._out_blend), dep)

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.plant_params, other.path, other.geometry, other.period,
                            other.fv1, converter=converter)

        def _phi(self, context):
            return path_at(self.state_port.Eval(context), PATH_STATE(self._next.Eval(context)),
                           self.geometry, self.path)

        def _out_ref(self, context, out):
            out.SetAtIndex(0, self._path_at.Eval(context)[2])

        def _out_ff(self, context, out):
            x, s, phi, d1, d2 = self._path_at.Eval(context)
            if self.path.mode == "lab":
                out.SetAtIndex(0, 0.0 * s)
                return
            x = RobotState(x)
            _, ff = constraint_acceleration([x.q1, x.q2], x.q1d, d1, d2, self.plant_params)
            out.SetAtIndex(0, ff)

        def _out_blend(self, context, out):
            out.SetFromVector(self._next.Eval(context)[:2])

        def _advance(self, context):
            """This tick's path state from the stored one and the estimate."""
            x = np.array([float(_value(v)) for v in self.state_port.Eval(context)])
            st = PATH_STATE(np.array([float(_value(v))
                                      for v in context.get_discrete_state(self._xd).CopyToVector()]))
            return next_path_state(x, st, self.geometry, self.path, self.plant_params,
                                   self.period)

        def _store(self, context, discrete_state):
            discrete_state.get_mutable_vector(self._xd).SetFromVector(self._next.Eval(context))

    return Impl


def _value(v):
    return v.value() if hasattr(v, "value") else v


with quick_template_scopes():
    PathGenerator = PathGenerator_[None]
