"""One brachiation swing: simulate, summarise, export.

:func:`run_swing` builds the full closed loop (:func:`bplir_drake.diagrams.
build_swing`), draws the simulated robot's friction within
``+/- scenario.friction_uncertainty`` from the seed (unless ``true_friction``
is given), runs until the gripper interlock reports an outcome, and returns
the logs and a summary with the success criteria of docs/concepts.md and the
thresholds and seed used.
"""
from __future__ import annotations

import dataclasses as dc
import math
from dataclasses import dataclass

import numpy as np

from ...io import PLANNING, Result, dumps_strict, wall_clock_limit

from ...diagrams import build_swing, set_pulses, set_swing_sample, swing_geometry, swing_structure
from ...params import BplirParams, checked_seed, plugin_name, to_dict
from ...simulate import Log, logs, make_simulator, run_until_outcome
from .logs import log_table
from .summary import SwingSummary
from .swing_plots import plot_swing
from ...systems.landing import height_rates
from ...planning.solve import tracking_plan
from ...diagrams.swing_setup import start_state as plan_start_state


def draw_true_friction(params: BplirParams, seed: int) -> BplirParams:
    """Simulated friction: each coefficient uniform within +/- the scenario's
    friction uncertainty of nominal (as in 3.3), from ``seed``.  Kept as is
    when ``true_friction`` is already set."""
    if params.true_friction is not None or params.scenario.friction_uncertainty == 0:
        return params
    u = params.scenario.friction_uncertainty
    rng = np.random.default_rng([seed, 1])
    k = rng.uniform(1 - u, 1 + u, 4)
    f = params.friction
    return params.with_(true_friction=f.with_factors(k))


@dataclass
class SwingResult(Result):
    """One simulated swing.

    ``summary``: the outcome and its figures, a typed
    :class:`~.summary.SwingSummary` (``summary.capture_speed_mps``; units in
    ``SwingSummary.units()``) that reads like the dict of ``summary.json``
    too (``summary["capture_speed_mps"]``) and, called (``summary()``),
    gives that dict, as every result's ``summary()`` does;
    ``logs``: the logged signals by name (``state``, ``torque``, ``power``,
    ``estimate``, ``reference``, ``imu``, ...); ``params``: the parameters
    it ran with (the simulated friction drawn)."""

    summary: SwingSummary = dc.field()   # a field, not the protocol's method it shadows
    logs: dict[str, Log] = dc.field()
    params: BplirParams = dc.field()

    @property
    def success(self) -> bool:
        """The swing captured the line (the success criteria)."""
        return bool(self.summary.success)

    def to_dict(self) -> dict:
        """The summary with the parameters it ran with (``summary.json``)."""
        return summary_with_params(self)

    def to_json(self) -> str:
        """:meth:`to_dict` as strict JSON text (NaN and infinity as null)."""
        return dumps_strict(self.to_dict())

    def plot(self, axes=None, title=None, panel=None):
        """Six panels (3 x 2 axes) in the style of Fig. 7.6, or one panel on
        one axes (``panel``: angles, rates, torque, voltage, gripper,
        energy); returns the figure."""

        return plot_swing(self, axes, title, panel)

    def table(self) -> dict:
        """The logs on the state's time grid, column by column (the columns
        of ``swing_log.csv``, :data:`~.logs.LOG_COLUMNS`)."""
        cols, data = log_table(self)
        return {name: data[:, i] for i, name in enumerate(cols)}


#: integrator of a swing: error-controlled RK3 at this accuracy keeps a
#: study's outcomes and capture speeds (docs/results, the integrator's accuracy)
SWING_INTEGRATOR, SWING_ACCURACY = "runge_kutta3", 1e-3


def swing_diagram(params: BplirParams, **kwargs):
    """:func:`~bplir_drake.diagrams.build_swing` (the same keyword arguments)
    with the tracking gains of the planned swing when ``params`` track one
    (``path.mode`` resolves to ``"plan"``, the default of the ``plan``
    preset): the plan and its gains come from the nominal model and the
    scenario only, from the disk cache or solved
    (:func:`~.plan.tracking_plan`).  The simulated friction is drawn from
    the seed as :func:`run_swing` draws it, so the diagram's default
    context is that swing: ``Simulator(built.diagram)`` with the runner's
    integrator (error-controlled RK3 at ``SWING_ACCURACY``, steps of at most
    10 ms) simulates it."""
    seed = kwargs.get("seed")
    params = draw_true_friction(params, params.scenario.seed if seed is None else int(seed))
    if kwargs.get("controller") is None and "plan_gains" not in kwargs:
        resolved = params.resolved()
        if resolved.path.mode == "plan":

            kwargs["plan_gains"] = tracking_plan(resolved)[1]
    return build_swing(params, **kwargs)


class SwingRunner:
    """Runs swings, building a diagram only when the structure changes.

    Every sample whose parameters differ from the last built ones only in
    what a context carries (:data:`bplir_drake.diagrams.SAMPLE_FIELDS`:
    the simulated links' inertial parameters, friction, IMU errors, wind and
    gusts, seeds) runs through the same diagram, with the sample written into
    a fresh context (:func:`~bplir_drake.diagrams.set_swing_sample`).  The
    results are identical to a fresh build per swing (tested).  With
    ``onboard=False`` the robot's computer is built as its parts wired one
    by one (:func:`~bplir_drake.diagrams.build_swing`): the same numbers,
    each part's ports in the diagram."""

    def __init__(self, onboard: bool = True):
        self.built = None
        self.builds = 0
        self.onboard = onboard

    def release(self) -> None:
        """Let the diagram built last go (:meth:`~bplir_drake.diagrams.parts.
        Built.release`): the next swing builds its own."""
        if self.built is not None:
            self.built.release()
            self.built = None

    def diagram_for(self, params: BplirParams, seed: int, use_estimator: bool,
                    structure: str | None = None, forces: bool = False):
        """``(built swing, fresh)`` for ``params``: reused when the structure
        matches (``fresh`` False: the sample must be set in the context;
        ``structure``: their :func:`swing_structure`, when worked out;
        ``forces``: with a disturbance source whatever the scenario's)."""
        if structure is None:
            structure = swing_structure(params, use_estimator, forces)
        if self.built is None or self.built.structure != structure:
            self.release()
            self.built = swing_diagram(params, seed=seed, use_estimator=use_estimator,
                                       onboard=self.onboard, disturbance=forces)
            self.builds += 1
            return self.built, True
        return self.built, False

    def run(self, params: BplirParams, *, seed: int | None = None,
            use_estimator: bool | None = None, accuracy: float = SWING_ACCURACY,
            integrator: str = SWING_INTEGRATOR, driver_state=None,
            start_state=None, live=None, pulses=None) -> SwingResult:
        """One swing; the arguments are those of :func:`run_swing`;
        ``start_state`` (q1, q2, q1', q2'): the simulated robot starts there
        instead of at rest in its start pose (the robot still believes it
        starts at rest in :func:`~bplir_drake.diagrams.swing.believed_start`);
        ``pulses``: torque pulses on the joints ``[(start s, (tau1, tau2)
        N m, duration s)]`` added to the scenario's disturbance (knocks; a
        runner given pulses, even none, keeps a diagram with a disturbance
        source for them)."""
        params = params.resolved()   # path.mode "auto" made concrete
        sc = params.scenario
        seed = sc.seed if seed is None else checked_seed(seed)
        use_est = sc.use_estimator if use_estimator is None else use_estimator
        p = draw_true_friction(params, seed)
        forces = pulses is not None
        structure = swing_structure(p, use_est, forces)
        with wall_clock_limit(sc.wall_limit, f"planning the swing of seed {seed}", PLANNING):
            built, fresh = self.diagram_for(p, seed, use_est, structure, forces)
        # a fresh build's default context already holds this sample
        motor = built.systems["motor"]

        def set_context(ctx):
            if not fresh:
                set_swing_sample(built, ctx, p, seed, structure, pulses or ())
            elif pulses:
                set_pulses(built, ctx, p, seed, pulses)
            if driver_state is not None:
                motor.set_interlock_state(ctx, *driver_state)

        if start_state is None and sc.start == "plan":   # the plan's first state, moving
            start_state = plan_start_state(p)
        x0 = np.r_[built.q0, 0.0, 0.0] if start_state is None else np.asarray(start_state, float)
        sim = make_simulator(built, x0[:2], x0[2:], accuracy=accuracy, integrator=integrator,
                             set_context=set_context)
        h0 = motor.interlock_state(sim.get_context())
        if live is not None:
            live.attach(sim, built)
        run_until_outcome(sim, built, sc.max_time, sc.wall_limit, f"the swing of seed {seed}")
        if live is not None:
            live.finish()
        # record the state at the moment the interlock decided
        built.diagram.ForcedPublish(sim.get_context())
        status = built.systems["interlock"].status(sim.get_context())
        lg = logs(built, sim)
        h, tripped = motor.interlock_state(sim.get_context())
        summary = SwingSummary(**swing_summary(p, lg, status, seed, use_est),
                               i2t_start_A2s=h0[0], i2t_end_A2s=h, driver_tripped_end=tripped,
                               driver_tripped=bool(h0[1] or np.any(lg["tripped"].data > 0.5)))
        return SwingResult(summary, lg, p)


def run_swing(params: BplirParams, *, seed: int | None = None, use_estimator: bool | None = None,
              accuracy: float = SWING_ACCURACY, integrator: str = SWING_INTEGRATOR,
              driver_state=None, live=None, pulses=None) -> SwingResult:
    """One swing of ``params`` on a freshly built diagram, until the
    interlock decides (or the timeout).

    The simulated friction is drawn from ``seed`` (:func:`draw_true_friction`),
    the IMU noise and disturbances are seeded by it; ``use_estimator``
    overrides ``scenario.use_estimator``; ``accuracy`` and ``integrator``
    set Drake's error-controlled integrator.  Returns the logs and the
    summary (outcome, capture speed (m/s), swing time (s), peaks, energy,
    thresholds, seed, the driver's i^2 t state at the start and end and
    whether it tripped).  ``driver_state = (h A^2 s, tripped)`` starts the
    driver's i^2 t interlock there (work carried over; default fresh).
    ``live``: a :class:`~bplir_drake.analysis.live.LiveView` that shows the
    swing in Meshcat as it is simulated, at real time.  ``pulses``: torque
    pulses on the joints (knocks, :meth:`SwingRunner.run`).  Many swings:
    :class:`SwingRunner`."""
    runner = SwingRunner()
    try:
        return runner.run(params, seed=seed, use_estimator=use_estimator, accuracy=accuracy,
                          integrator=integrator, driver_state=driver_state, live=live,
                          pulses=pulses)
    finally:
        runner.release()


def arrival_height_error(p: BplirParams, est: Log, status: dict) -> float:
    """How far above the truth the robot's estimate put the gripper (m) at
    its arrival at the line (nan: no arrival).  At the arrival (the first
    time the gripper comes within ``gripper.capture_distance`` of the line,
    the moment its jaw senses the line) the gripper is that far below the
    line; the estimate's distance there (the nominal model; the last
    tick's estimate before the arrival carried to it at its own rate of
    approach: the arrival falls between ticks, and the gripper rises up to
    3 mm in one at 0.3 m/s) less that is its error.  No true state is read:
    what the robot itself can measure at each capture.  The log is the
    in-loop estimator's, which runs in a swing on the true state
    (``use_estimator=False``) too, unused: there this is its error."""

    t = status["event_time_s"]
    if status["outcome"] not in ("captured", "crash") or not np.isfinite(t) or not len(est.t):
        return math.nan
    k = max(int(np.searchsorted(est.t, t, side="right")) - 1, 0)
    h, rate, _ = height_rates(p.plant, math.radians(p.scenario.incline_deg), est.data[k])
    return float(h + rate * (t - est.t[k]) + p.gripper.capture_distance)


def estimated_peak_height(p: BplirParams, est: Log) -> float:
    """The highest the robot's estimate put the gripper (m, negative below
    the line) ahead of the holding gripper (nominal model; nan without an
    estimate there).  On a swing that timed out it tells the robot whether
    it believed the gripper had come within the capture band: the jaw
    would have sensed the line there, so the estimate ran above the truth."""
    if not len(est.t):
        return math.nan
    q1, q2 = est.data[:, 0], est.data[:, 1]
    a, pl = math.radians(p.scenario.incline_deg), p.plant
    s = q1 - a
    h = -pl.l1 * np.cos(s) - pl.l2 * np.cos(s + q2)
    ahead = pl.l1 * np.sin(s) + pl.l2 * np.sin(s + q2) > 0.0
    return float(h[ahead].max()) if ahead.any() else math.nan


def motor_summary(p: BplirParams, lg: dict[str, Log]) -> dict:
    """The motor's voltage and electrical energy over a swing (from its
    logs): the peak winding voltage, the driver's largest output, the time
    the current was held by the voltage envelope, the electrical energy
    drawn from the supply (net) and the energy regenerated into it."""
    m = p.motor
    if "voltage" not in lg:
        return {}
    v = lg["voltage"].data[:, 0]
    tv = lg["voltage"].t
    pe = lg["electrical_power"].data[:, 0]
    on = (np.abs(v) >= m.max_voltage * (1.0 - 1e-6)) if m.envelope else np.zeros(len(v), bool)
    dt = np.diff(tv)
    return {"supply_voltage_V": m.supply_voltage, "max_voltage_V": m.max_voltage,
            "peak_voltage_V": float(np.abs(v).max()) if len(v) else math.nan,
            "on_envelope_s": float(np.sum(dt * on[:-1])) if len(v) > 1 else 0.0,
            "electrical_energy_J": float(np.sum(0.5 * (pe[1:] + pe[:-1]) * dt)),
            "regenerated_J": float(np.sum(0.5 * dt * (np.maximum(-pe[1:], 0.0)
                                                       + np.maximum(-pe[:-1], 0.0))))}


def swing_summary(p: BplirParams, lg: dict[str, Log], status: dict, seed: int,
                  use_est: bool) -> dict:
    """The summary of a swing from its logs and the interlock's ``status``
    (success criteria, peaks, energy, estimation error, thresholds, seed)."""
    sc = p.scenario
    st = lg["state"]
    x, t = st.data, st.t
    q0, qT, _, _ = swing_geometry(p)
    tau = lg["torque"].data[:, 0]
    power = lg["power"].data[:, 0]
    energy_in = float(np.sum(0.5 * (power[1:] + power[:-1]) * np.diff(lg["power"].t)))
    est = lg["estimate"]
    n = min(len(est.t), np.searchsorted(est.t, t[-1], side="right"))
    truth = st.at(est.t[:n])
    est_err = float(np.abs(est.data[:n, :2] - truth[:, :2]).max()) if n else math.nan
    captured = status["outcome"] == "captured"
    x_end = x[-1]
    mirror_err = float(np.abs(x_end[:2] - qT).max())
    # the actuation delay the controller identified (nan: none identified)
    fit = lg["delay_fit"].data if "delay_fit" in lg else np.zeros((0, 2))
    fit = fit[fit[:, 1] > 0]
    delay_id = float(fit[-1, 0] * p.controller.period) if len(fit) else math.nan
    summary = {
        "success": captured,
        "outcome": status["outcome"],
        "swing_time_s": status["event_time_s"],
        "capture_distance_m": status["capture_distance_m"],
        "capture_speed_mps": status["capture_speed_mps"],
        "closest_distance_m": status["closest_distance_m"],
        "travel_m": status["travel_m"],
        # where the arrival is along the line relative to the planned grip
        # (the mirror point, 2 D from the start): negative = short of it
        "landing_error_m": (status["travel_m"] - 2.0 * sc.grip_spacing
                            if status["outcome"] in ("captured", "crash") else float("nan")),
        # what the gripper's jaw sensor tells the robot at the arrival: the
        # line is capture_distance from the gripper then, so the estimated
        # height's error is the estimate's distance less that (nominal model)
        "landing_height_error_m": arrival_height_error(p, est, status),
        "estimated_peak_height_m": estimated_peak_height(p, est),
        "fixed_gripper_open": status["fixed_gripper_open"],
        "peak_torque_Nm": float(np.abs(tau).max()),
        "peak_motor_power_W": float(np.abs(power).max()),
        "motor_power_rating_W": p.motor.power_rating,
        "within_power_rating": bool(np.abs(power).max() <= p.motor.power_rating),
        "energy_in_J": energy_in,
        **motor_summary(p, lg),
        "max_estimation_error_rad": est_err,
        "final_configuration_rad": x_end[:2].tolist(),
        "target_configuration_rad": qT.tolist(),
        "mirror_error_rad": mirror_err,
        "delay_identified_s": delay_id,
        "delay_fit_ratio": float(fit[-1, 1]) if len(fit) else math.nan,
        "estimator_in_loop": use_est,
        "controller": (plugin_name(p.controller.plugin) if p.controller.plugin
                       else p.controller.preset),
        "path_mode": p.path.mode,
        "incline_deg": sc.incline_deg,
        "grip_spacing_m": sc.grip_spacing,
        "seed": seed,
        "thresholds": {"capture_distance_m": p.gripper.capture_distance,
                       "capture_speed_mps": p.gripper.capture_speed,
                       "min_travel_fraction": sc.min_travel_fraction,
                       "max_time_s": sc.max_time,
                       "torque_limit_Nm": min(p.controller.torque_limit, p.motor.torque_limit)},
        "true_friction": dc.asdict(p.simulated_friction),
        "start_configuration_rad": list(map(float, q0)),
    }
    return summary


# ----------------------------------------------------------- exports


def summary_with_params(result: SwingResult) -> dict:
    """The swing's summary with the parameters it ran with."""
    return result.summary.to_dict() | {"parameters": to_dict(result.params)}


