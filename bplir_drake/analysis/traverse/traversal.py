"""Crossing a stretch of line: ride, set up, swing, swing, ride on.

:func:`run_traverse` carries the robot's physical state from manoeuvre to
manoeuvre: where each gripper is, the elbow driver's i^2 t integral and trip
flag (the swing's driver starts where the last one ended; riding and resting
let it fall at ``i_cont^2``), elapsed time and energy.  Each swing is a full
closed-loop swing (:class:`~bplir_drake.analysis.swing.swing_runner.SwingRunner`) of
the robot holding with the gripper in front of it: the original robot when
gripper 1 (link 1's) holds, the swapped robot (:func:`bplir_drake.params.
swapped`) when gripper 2 holds; its estimator starts from the known pose on
the line (both grippers clamped) as every swing does.

Swings track trajectory-optimised plans (``traverse.swing_mode = "plan"``,
``path.mode = "plan"``) by default: the path generator crashes where the
swinging link is the heavy one and times out on inclined lines; ``"params"`` uses the swing controller of the parameters as
given.

The interlock of chapter 4 in software: a swing opens its swinging gripper
only while the other one is clamped, and the traversal goes on only after
the interlock has confirmed the capture (outcome ``captured``, the arriving
gripper closed); then the landing is checked against the obstacles.
"""
from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from ...params import BplirParams, Manoeuvre
from ...params.derive import raises_aim
from ...planning import retry as retry_plan
from ...systems.drive import ride
from ...systems.motor import i2t_after_rest, rest_for
from .line import Line
from .route import hold_position, plan_route
from .recovery import can_retry, damp, damping_drive
from .step_setup import swing_chord, budgeted_currents, capture_impulse, step_manoeuvre
from .traverse_result import OUTCOMES, ROW_FIELDS, MotionLog, Segment, TraverseResult
from .ledger import Ledger, _seg
from .knocked import KnockLog, knocks_or_none
from .tables import traverse_totals
from ..swing.swing_runner import SwingRunner, draw_true_friction
from .isolated import IsolatedRunners
from ..live import Following
from .traverse_plots import line_scene
from ...planning.solve import tracking_plan
from ...progress import progress_bar


class _Traversal(Ledger):
    """The state carried from manoeuvre to manoeuvre."""

    def __init__(self, line: Line, params: BplirParams, seed: int, runners=None, adjust=None,
                 motion=None, live=None, knocks=None):

        self.line, self.params, self.seed = line, params, seed
        self.adjust = adjust
        self.runners = runners if runners is not None else {1: SwingRunner(), 2: SwingRunner()}
        self.t = 0.0
        self.h, self.tripped = 0.0, False
        self.energy = {"ride": 0.0, "swing": 0.0, "standby": 0.0}
        self.rows, self.clamps, self.holds = [], [], []
        self.motion = MotionLog(motion)
        self.outcome = "passed"
        self.live = live   # a LiveView the swings are drawn in
        tp = params.traverse
        self.front, self.rear = line.start, line.start - tp.grip_spacing
        self.front_gripper = 1    # gripper 1 (link 1's) leads
        # a gripper holds the line (closed around it) from ``closed[g]``; it is
        # clamped in place at ``clamp[g] = (s, since)`` while it does not ride
        self.closed = {1: 0.0, 2: 0.0}
        self.pos = {1: self.front, 2: self.rear}
        self.clamp = {g: (self.pos[g], 0.0) for g in (1, 2)}
        self.swings = 0
        # the landing height errors of the captures so far, per holding gripper
        self.landing_errors = {1: [], 2: []}
        self.est_err, self.fixed_open = math.nan, False
        self.robot = params.simulated_plant
        self.mass = self.robot.m1 + self.robot.m2
        # the knocks the run meets (drawn on the nominal robot: the world's, not the plant's)
        self.knocks = None if knocks is None else KnockLog(knocks, params.plant, seed)
        self.hung_still = 0.0   # standstill samples gathered hanging before a knock (s)

    # -------------------------------------------------------------- steps
    def move(self, kind: str, new_front: float, new_rear: float, obstacle: str = "") -> None:
        """Ride both grippers (``ride``) or one wheel (``adjust``) to new grips."""
        d_front, d_rear = new_front - self.front, new_rear - self.rear
        dist = max(abs(d_front), abs(d_rear))
        if dist < 1e-9:
            return
        fg = self.front_gripper
        rg = 3 - fg
        y0 = self.line.point(self.front)[1]
        y1 = self.line.point(new_front)[1]
        speed = self.params.drive.adjust_speed if kind == "adjust" else None
        time, energy, peak = ride(dist, float(y1 - y0), self.mass, self.params.drive, speed)
        h0 = self.h
        old_spacing, old_inc = self.line.chord(self.rear, self.front)
        b0 = self._base(self.pos[1])
        for g, d in ((fg, d_front), (rg, d_rear)):
            if abs(d) > 1e-9:
                self._unclamp(g, self.t)
                self.clamp[g] = (new_front if g == fg else new_rear, self.t + time)
        self.pos[fg], self.pos[rg] = new_front, new_rear
        self.front, self.rear = new_front, new_rear
        spacing, inc = self.line.chord(self.rear, self.front)
        self._still(self.t, self.t + time, self._pose_both(spacing, inc), b0,
                    self._base(self.pos[1]), h0)
        self.h = i2t_after_rest(self.h, time, self.params.motor)
        self.tripped = self.tripped and self.h > 0.0
        standby = self.params.drive.standby_power * time
        self.energy["ride"] += energy
        self.energy["standby"] += standby
        self._row(kind, time, obstacle=obstacle, from_m=self.rear, to_m=self.front,
                  hold_m=math.nan, incline_deg=math.degrees(inc), peak_power_W=peak,
                  energy_J=energy + standby, i2t_start_A2s=h0, i2t_end_A2s=self.h,
                  outcome="done")
        if self.knocks is not None:
            self.knocks.absorb(self.t + time, kind)
        self.t += time

    def rest(self, duration: float, obstacle: str, kind: str = "rest", pose=None,
             holding: str = "both"):
        """Stay still while the driver's i^2 t falls (``kind``: ``rest``, or
        ``calibrate`` for the IMUs' standstill): clamped with both grippers
        (a knock is absorbed), or in ``pose`` = (q, gripper 1's pose)
        holding with ``holding``, until a knock sets the robot swinging (the
        knock, returned; else None)."""
        if duration <= 0.0:
            return None
        knock = None
        if self.knocks is not None and pose is not None:
            knock = self.knocks.first(self.t, self.t + duration)
            duration = duration if knock is None else knock.t - self.t
        elif self.knocks is not None:
            self.knocks.absorb(self.t + duration, kind)
        if pose is None:
            spacing, inc = self.line.chord(self.rear, self.front)
            pose = (self._pose_both(spacing, inc), self._base(self.pos[1]))
        h0 = self.h
        self._still(self.t, self.t + duration, pose[0], pose[1], pose[1], self.h)
        self.h = i2t_after_rest(self.h, duration, self.params.motor)
        self.tripped = self.tripped and self.h > 0.0
        standby = self.params.drive.standby_power * duration
        self.energy["standby"] += standby
        self._row(kind, duration, obstacle=obstacle, holding_gripper=holding, energy_J=standby,
                  i2t_start_A2s=h0, i2t_end_A2s=self.h,
                  outcome="done" if knock is None else "knocked")
        self.t += duration
        return knock

    def _rest_before(self, p, obstacle: str, pose=None, holding: str = "both"):
        """Rest before a swing when the planned swing would eat into the i^2 t
        margin (nominal plan only; a tripped driver first resets), then
        calibrate the IMUs standing still: clamped with both grippers, or in
        ``pose`` holding with ``holding`` (as :meth:`rest`: the knock that set
        the hanging robot swinging, or None; the standstill samples gathered
        hanging before it, ``hung_still`` s, are kept)."""

        tp = self.params.traverse
        # the standstill calibration of the IMUs (estimator.standstill_samples)
        # holds still on the line before the swing: it counts as rest too
        motor = self.params.motor
        calib = p.estimator.standstill_samples * p.imu.period
        need = 0.0
        if tp.rest and p.path.mode == "plan":
            plan = tracking_plan(p)[0]   # nominal model only
            need = rest_for(self.h, self.tripped, budgeted_currents(plan, p), motor,
                            tp.i2t_margin)
        elif tp.rest and self.tripped:
            need = self.h / motor.i_cont ** 2
        calib -= self.hung_still if pose is not None else 0.0
        knock = self.rest(need - calib, obstacle, pose=pose, holding=holding)
        if knock is None:
            t0 = self.t
            knock = self.rest(calib, obstacle, kind="calibrate", pose=pose, holding=holding)
            self.hung_still = self.hung_still + self.t - t0 if knock is not None else 0.0
        return knock

    def swing(self, obstacle: str, reach: float) -> bool:
        """The rear gripper swings past the front one to land about ``reach``
        ahead of it (the planned spacing); True when it landed clear; a pump
        or one swing (:func:`~.step_setup.step_manoeuvre`).  A swing that
        times out, crashes (arrives too fast for the interlock to close the
        gripper) or trips the driver's i^2 t interlock is tried again from
        hanging, after the robot has damped its swing
        (:mod:`.recovery`) and rested until the driver allows the new try, up
        to ``traverse.retries`` times."""
        tp = self.params.traverse
        hold_g = self.front_gripper
        hold, start = self.front, self.rear
        spacing, inc = swing_chord(self.line, start, hold, reach)
        m = Manoeuvre(gripper=hold_g, spacing=spacing, incline_deg=math.degrees(inc),
                      context="traverse", learnt=tuple(self.landing_errors[hold_g]))
        m, p = step_manoeuvre(self.params, m)
        self._rest_before(p, obstacle)
        x_start, attempt = None, 1
        while True:
            s, x_end = self._attempt(p, obstacle, attempt, x_start)
            if s.outcome not in ("timeout", "fault", "crash") or attempt > tp.retries:
                break
            m = dc.replace(m, raised=m.raised + raises_aim(p, s))
            retry = retry_plan.retry(self.params, m)
            if not can_retry(retry):
                self._row("recover", 0.0, obstacle=obstacle, holding_gripper=str(hold_g),
                          hold_m=hold, outcome="no plan from hanging")
                break
            p, attempt = retry, attempt + 1
            x_start = self._recover(p, obstacle, x_end)
            if x_start is None:
                break
        return self._land(s, obstacle, hold, spacing)

    def _attempt(self, p, obstacle: str, attempt: int, x_start):
        """One try of the swing ``p`` (from ``x_start``, the state after a
        recovery, or its start pose); (summary, last state)."""
        hold_g, hold, start = self.front_gripper, self.front, self.rear
        seed = int(np.random.SeedSequence([self.seed, self.swings]).generate_state(
            1, dtype=np.uint32)[0])
        run_p = p if self.adjust is None else self.adjust(self.swings, attempt, p)
        self.swings += 1
        follow = None if self.live is None else Following(
            self.live, lambda x: self._pose_track(x, hold, hold_g, run_p.simulated_plant), self.t)
        pulses = None if self.knocks is None else self.knocks.pulses(
            self.t, run_p.scenario.max_time + 1.0)
        res = self.runners[hold_g].run(run_p, seed=seed, driver_state=(self.h, self.tripped),
                                       start_state=x_start, live=follow, pulses=pulses)
        s = res.summary
        x_end = res.logs["state"].data[-1]
        sim_p = run_p.simulated_plant
        impulse, m_eff = (capture_impulse(x_end[:2], x_end[2:], sim_p) if s.success
                          else (math.nan, math.nan))
        t, elec, standby, duration = self._record_motion(res, run_p, hold, hold_g)
        h0 = self.h
        self.h, self.tripped = s.i2t_end_A2s, s.driver_tripped_end
        self.est_err = float(np.nanmax([self.est_err, s.max_estimation_error_rad]))
        self.fixed_open = self.fixed_open or (s.fixed_gripper_open and not s.success)
        spacing, _ = self.line.chord(start, hold)
        landed = hold + s.travel_m - spacing if s.success else math.nan
        self._row("swing", duration, obstacle=obstacle, holding_gripper=str(hold_g),
                  robot="original" if hold_g == 1 else "swapped", hold_m=hold,
                  from_m=start, to_m=landed, incline_deg=p.scenario.incline_deg,
                  outcome=s.outcome, capture_speed_mps=s.capture_speed_mps,
                  capture_impulse_Ns=impulse, effective_mass_kg=m_eff,
                  peak_torque_Nm=s.peak_torque_Nm, peak_power_W=s.peak_motor_power_W,
                  peak_voltage_V=s.peak_voltage_V,
                  energy_J=elec + standby, i2t_start_A2s=h0, i2t_end_A2s=self.h,
                  landing_bias_m=p.landing.landing_bias,
                  landing_height_error_m=s.landing_height_error_m, seed=seed,
                  attempt=attempt)
        if self.knocks is not None:
            phase = "retry" if attempt > 1 else (
                "pump" if run_p.scenario.manoeuvre == "pump" else "swing")
            self.knocks.met(self.t, duration, phase, s.outcome,
                            arrived=s.outcome in ("captured", "crash"))
        self.t += duration
        if attempt == 1:   # the swinging gripper opened at the start, closes at capture
            self.holds.append((3 - hold_g, self.closed[3 - hold_g], t[0]))
            self._unclamp(3 - hold_g, t[0])
        return s, x_end

    def _recover(self, p, obstacle: str, x_end):
        """Damp the swing hanging from the holding gripper, rest until the
        driver's i^2 t allows the try ``p`` (a tripped driver first resets),
        then calibrate the IMUs hanging at rest; a knock meanwhile sets it
        swinging, and it damps again; the state to try again from (None: the
        swing could not be damped)."""
        hold_g, hold = self.front_gripper, self.front
        phase, self.hung_still = "damp", 0.0
        while True:
            state = self._damp(p, obstacle, x_end, phase)
            if state is None:
                return None
            qh, bh = self._pose_track(state, hold, hold_g, p.simulated_plant)
            knock = self._rest_before(p, obstacle, pose=(qh[0], bh[0]),
                                      holding=str(hold_g))   # hanging at rest
            if knock is None:
                return state
            x_end, phase = state, "hanging"

    def _damp(self, p, obstacle: str, x_end, phase: str):
        """One damping from ``x_end`` (knocked in ``phase`` when it starts
        at a knock); the state it came to rest in, or None."""
        hold_g, hold = self.front_gripper, self.front
        pulses = None if self.knocks is None else self.knocks.pulses(
            self.t, p.traverse.recover_limit)
        if phase == "hanging":   # the knock at its start met the robot hanging at rest
            self.knocks.met(self.t, 1e-9, "hanging", "damped again")
        d = damp(p, x_end, pulses or ())
        motor = self.params.motor
        q, base = self._pose_track(d.states, hold, hold_g, p.simulated_plant)
        h0 = self.h
        cur, elec = damping_drive(d, motor)
        h, self.h, self.tripped = self._i2t_along(d.t, cur)
        self.motion.append(_seg(self.t + d.t, q, base, d.torque, cur, h))
        standby = self.params.drive.standby_power * d.duration
        self.energy["swing"] += elec
        self.energy["standby"] += standby
        self._row("recover", d.duration, obstacle=obstacle, holding_gripper=str(hold_g),
                  hold_m=hold, outcome="damped" if d.damped else "not damped",
                  energy_J=elec + standby, i2t_start_A2s=h0, i2t_end_A2s=self.h)
        if self.knocks is not None:
            self.knocks.met(self.t, d.duration, "damp", "damped" if d.damped else "not damped")
        self.t += d.duration
        return d.state if d.damped else None

    def _land(self, s, obstacle: str, hold: float, spacing: float) -> bool:
        """After the last try: stop the traversal, or clamp the landed gripper."""
        swing_g = 3 - self.front_gripper
        row = self.rows[-1] if self.rows[-1].kind == "swing" else None
        if s.driver_tripped:
            self.outcome = "driver trip"
            return False
        if not s.success:
            self.outcome = f"swing {s['outcome']}"
            return False
        landed = hold + s.travel_m - spacing
        hit = self.line.obstacle_at(landed, self.params.gripper.width / 2)
        if hit is not None or landed > self.line.length:
            if row is not None:
                row.outcome = "landed on obstacle"
            self.outcome = "landed on obstacle"
            return False
        self.landing_errors[self.front_gripper].append(s.landing_height_error_m)
        self.closed[swing_g] = self.t
        self.clamp[swing_g] = (landed, self.t)
        self.pos[swing_g] = landed
        self.front_gripper = swing_g
        self.front, self.rear = landed, hold
        return True

    def finish(self) -> dict:
        """Close the holds and clamps still on and total up."""
        stopped = self.outcome != "passed"
        for g in (1, 2):
            if not (stopped and g != self.front_gripper):   # a failed swing's gripper stays open
                self.holds.append((g, self.closed[g], math.inf))
                self._unclamp(g, math.inf)
        return traverse_totals(self)


#: a traversal of more obstacles than this runs its swings in a worker
#: process replaced as it goes (:mod:`.isolated`: bounded memory)
ISOLATE_OBSTACLES = 20


def run_traverse(line: Line, params: BplirParams, *, seed: int = 0, progress: bool = False,
                 runners=None, adjust=None, motion=None, isolate=None,
                 live=None, knocks=None) -> TraverseResult:
    """Cross ``line`` with the robot of ``params``; stops at the first
    failure.  ``seed``: the simulated robot's friction (drawn once, within
    ``scenario.friction_uncertainty``, unless ``true_friction`` is set) and
    every swing's sensor noise and disturbances (a seed per swing, recorded
    in its row).  ``runners``: ``{1: SwingRunner, 2: SwingRunner}`` to reuse
    built diagrams across traversals.  ``adjust(swing, attempt, params)``
    returns the parameters one try of a swing runs with (``swing`` counts
    every try from 0, ``attempt`` from 1): a disturbance on one swing, say.
    ``motion``: where the motion is logged (:class:`~.result.MotionLog`:
    None in memory, a file path written as it goes, False not kept).
    ``live``: a :class:`~..live.LiveView` drawing the line and every swing
    as it is simulated (in this process).  ``isolate``: run the swings in a
    worker process replaced every 50 swings (:class:`~.isolated.IsolatedRunners`;
    default: on a line of more than :data:`ISOLATE_OBSTACLES` obstacles
    without ``runners``).  Raises :class:`~.line.LineError` when the line
    cannot be crossed (checked before any simulation).  ``knocks``: a
    :class:`~bplir_drake.params.knocks.Knocks` that knock the robot at
    random moments drawn from ``seed`` (:mod:`.knocked`; the totals score
    the run's uptime and falls)."""

    plan_route(line, params)   # the whole line is crossable on paper
    params = draw_true_friction(params, seed)   # one robot for the whole traversal
    if isolate is None:   # a live view is drawn from this process: its swings run here
        isolate = runners is None and live is None and len(line.obstacles) > ISOLATE_OBSTACLES
    if isolate:
        runners = IsolatedRunners()
    tr = _Traversal(line, params, seed, runners, adjust, motion, live, knocks_or_none(knocks))
    if live is not None:
        live.scene(line_scene(line, params))
    tp = params.traverse
    D = tp.grip_spacing

    bar = progress_bar(progress, total=len(line.obstacles), desc="obstacles", unit="obstacle")
    try:
        for k, ob in enumerate(line.obstacles):
            plan = hold_position(line, params, k, tr.front)
            tr.move("ride", plan.hold, plan.rear, ob.name)
            if not tr.swing(ob.name, plan.spacing1):
                break
            # the gripper that landed sets swing 2's spacing on its wheel
            tr.move("adjust", tr.rear + plan.spacing2, tr.rear, ob.name)
            if not tr.swing(ob.name, plan.spacing2):
                break
            bar.update(1)
        else:
            end = line.length - params.gripper.width / 2
            tr.move("ride", end, end - D, "")
    finally:
        bar.close()
        if isolate:
            runners.close()
        if live is not None:   # the swings drawn so far become the view's animation
            live.finish()
    totals = tr.finish()
    return TraverseResult(line, params, seed, tr.rows, totals, tr.motion, tr.clamps, tr.holds,
                          None if tr.knocks is None else tr.knocks.record())


__all__ = ["TraverseResult", "run_traverse", "budgeted_currents",
           "capture_impulse", "OUTCOMES", "ROW_FIELDS", "Segment"]
