"""A traversal's ledger: its rows, the motion the figures draw and the
driver's i^2 t along it (:class:`Ledger`, the base of the traversal's state)."""
from __future__ import annotations

import math

import numpy as np

from ...systems.motor import i2t_after_rest, i2t_trace
from ...systems.plant import (gripper_position, initial_configuration, swapped_state,
                              target_configuration)
from .traverse_result import ROW_FIELDS, Segment, TraverseRow


class Ledger:
    """What a traversal writes down as it goes (its state is the
    traversal's: ``rows``, ``motion``, ``clamps``, ``pos``, ``line``,
    ``params``, ``robot``, the driver's ``h`` and ``tripped``, ``t``)."""

    # -------------------------------------------------------------- rows
    def _row(self, kind: str, duration: float, **kw) -> TraverseRow:
        row = TraverseRow({k: math.nan for k in ROW_FIELDS} | {
            "index": len(self.rows), "kind": kind, "t_start_s": self.t, "duration_s": duration,
            "obstacle": "", "holding_gripper": "both", "robot": "", "outcome": "",
            "i2t_start_A2s": self.h, "seed": ""})
        row.update(kw)
        self.rows.append(row)
        return row

    def _still(self, t0: float, t1: float, q, base0, base1, h0: float) -> None:
        """A segment without elbow torque: ride (base moves) or rest."""
        n = max(2, int(math.ceil((t1 - t0) / 0.05)) + 1)
        t = np.linspace(t0, t1, n)
        w = (t - t0) / max(t1 - t0, 1e-12)
        base = np.outer(1 - w, base0) + np.outer(w, base1)
        qq = np.repeat(np.atleast_2d(q), n, axis=0)
        h = np.array([i2t_after_rest(h0, tk - t0, self.params.motor) for tk in t])
        self.motion.append(_seg(t, qq, base, np.zeros(n), np.zeros(n), h))

    def _pose_both(self, spacing: float, incline: float):
        """Joint angles of the original robot with both grippers on the line."""
        if self.pos[1] >= self.pos[2]:   # gripper 1 in front: gripper 2 behind it
            return initial_configuration(spacing, self.robot, incline)
        return target_configuration(spacing, self.robot, incline)

    def _unclamp(self, g: int, t: float) -> None:
        """Gripper ``g`` leaves its place at ``t`` (rides, swings or the end)."""
        if self.clamp.get(g) is not None:
            s, since = self.clamp[g]
            if t > since:
                self.clamps.append((g, s, since, t))
            self.clamp[g] = None

    def _base(self, s: float) -> np.ndarray:
        x, y = self.line.point(s)
        return np.array([x, y, 0.0])

    def _pose_track(self, states, hold: float, hold_g: int, sim_p):
        """(q, base) for the figures of a motion of the robot holding with
        gripper ``hold_g`` at ``hold``: the original robot's angles and
        gripper 1's pose."""
        hb = self._base(hold)
        states = np.atleast_2d(states)
        if hold_g == 1:
            return states[:, :2], np.repeat(hb[None, :], len(states), axis=0)
        q = np.array([swapped_state(x[:2]) for x in states])
        gp = np.array([gripper_position(x[:2], sim_p.l1, sim_p.l2) for x in states])
        return q, hb[None, :] + np.column_stack([gp, np.zeros(len(states))])

    def _i2t_along(self, t, current):
        """The driver's rule (:func:`i2t_trace`) on its own ticks from the
        carried state, for the current ``current`` (A) logged at ``t`` (s):
        (i^2 t at ``t``, i^2 t and trip flag at the end)."""
        motor = self.params.motor
        ticks = np.arange(0.0, t[-1] + 1e-12, motor.driver_period)
        h, tripped = i2t_trace(self.h, np.interp(ticks, t, current), motor, self.tripped)
        h_log = np.interp(t, np.r_[0.0, ticks + motor.driver_period], np.r_[self.h, h])
        return h_log, float(h[-1]), bool(tripped[-1])

    def _record_motion(self, res, p, hold: float, hold_g: int):
        """Add a swing's motion (in the original robot's angles), current and
        i^2 t trace to the figures' segments and its energy to the totals;
        (times, electrical energy J, standby energy J, duration s)."""
        st = res.logs["state"]
        motor = self.params.motor
        t = self.t + st.t
        q, base = self._pose_track(st.data, hold, hold_g, p.simulated_plant)
        cur = res.logs["current"].at(st.t)[:, 0]
        # for the figures (the swing's own driver state is what the traversal carries)
        h_log = self._i2t_along(st.t, cur)[0]
        self.motion.append(_seg(t, q, base, res.logs["torque"].at(st.t)[:, 0], cur, h_log))
        power = res.logs["power"].data[:, 0]
        work = float(np.trapezoid(np.maximum(power, 0.0), res.logs["power"].t))
        elec = work / (motor.eta_g * motor.eta_m)
        duration = float(st.t[-1])
        standby = self.params.drive.standby_power * duration
        self.energy["swing"] += elec
        self.energy["standby"] += standby
        return t, elec, standby, duration


def _seg(t, q, base, torque, current, i2t) -> Segment:
    return Segment(np.asarray(t, float), np.asarray(q, float), np.asarray(base, float),
                   np.asarray(torque, float), np.asarray(current, float), np.asarray(i2t, float))
