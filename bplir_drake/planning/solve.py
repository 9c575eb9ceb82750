"""Open-loop swing planning by trajectory optimisation (Drake
``DirectCollocation``): the full-state trajectory from the start pose at
rest to the mirror target at rest (7.1) on the nominal model *with* joint
friction (Coulomb smoothing widened to at least 0.2 rad/s), with ``|tau| <=
torque_limit``, ``|tau q2'| <= power_limit`` and the winding voltage ``R
tau/kt + Km N q2'`` within ``plan.voltage_share`` of the driver's largest
output at every knot (``motor.envelope``), minimising ``int tau^2 dt +
time_weight * T``.  A plan is feasible when its constraints hold within the
tolerance at the knots and the voltage within the driver's largest output
between them too.  An uphill swing reverses link 1 at least once (a
back-swing): not a single path ``q2 = phi(q1)``, which is why the path
generator cannot climb; a pumping manoeuvre (``scenario.manoeuvre``)
reverses it as often as its plan needs.  :func:`tracking_plan` plans to rest
``plan.end_depth`` below the line with Drake's finite-horizon LQR gains for
:class:`bplir_drake.systems.plan_tracker.PlanTracker`.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import replace

import numpy as np

from ..params import BplirParams, ParameterError, around
from .swing_plan import (
    HANGING_GUESSES, HANGING_KNOTS, HANGING_MINOR_ITERATIONS, PLAN_FRICTION_SMOOTHING, PUMP_KNOTS, UNBALANCED_SHARE, SwingPlan, energy_balance, planned_for, plan_envelope, plan_friction, plan_time_weight, plan_torque_limit, planned_target, pump_guesses, shifted_angles)
from ..params.derive import planned_from_hanging
from .library import library_plan
from .file import read_plan_file
from ..systems.symbolic_plant import symbolic_plant
from ..systems.plant import start_configuration
from .cache import cached
from ..systems.friction import friction_torques_along
from ..systems.motor import i2t_trace, interlock_budget
from ..progress import ambient, progress_bar
from ..systems.plan_tracker import RICCATI_ACCURACY, TrackerWeights, plan_gains
from .status import (
    SOLVER_STATUS, no_plan_message)


def plan_model(params: BplirParams):
    """(model, friction): the nominal plant with its friction (Coulomb
    smoothing widened to ``PLAN_FRICTION_SMOOTHING``), elbow torque in and
    state out, in closed form
    (:func:`~bplir_drake.systems.symbolic_plant.symbolic_plant`)."""

    friction = plan_friction(params.friction)
    return symbolic_plant(params.plant, friction), friction


def plan_swing(params: BplirParams, *, power_limit: float | None = None, knots: int = 41,
               time_weight: float | None = None, max_duration: float | None = None,
               guess_duration: float = 1.5, tolerance: float = 1e-4,
               iterations: int = 1500, end_depth: float = 0.0,
               initial: SwingPlan | None = None, minor_iterations: int | None = None,
               rate_limit: float = 0.0, cache: bool = True,
               progress: bool = False) -> SwingPlan:
    """Plan the scenario's swing on the nominal model, from the nominal start
    pose (what the controller knows; the simulated robot never enters).
    ``power_limit`` defaults to the motor's rating, the torque limit to the
    controller's; the duration is free within ``max_duration`` (default: the
    scenario's timeout).  ``end_depth``: the plan comes to rest with the free
    gripper this far below the line (m, inside the capture band), so that
    the band is entered just before the end, slowly, instead of during the
    final braking.  ``initial``: start the solver from this plan (its
    states shifted linearly in time onto this start and target, its
    torque as is) instead of the straight line from start to target over
    ``guess_duration`` (:func:`warm_guess`).  With ``cache`` the plan is
    read from, or written to, the disk cache (:func:`plan_cache_path`:
    keyed by every input the planner reads; a solve takes about a
    minute).  ``progress``: count SNOPT's evaluations on standard error
    while it solves.  ``minor_iterations``: SNOPT's limit on all its
    (minor) iterations (default SNOPT's own, which a swing from hanging
    exceeds).  ``rate_limit``: the largest elbow rate (rad/s) at the knots
    (0: none but the voltage envelope's).  ``time_weight``: the price of the
    plan's duration (default: the robot's, :func:`plan_time_weight`)."""

    if not 5 <= knots <= 400:
        raise ParameterError(f"knots = {knots} is out of range; allowed [5, 400]")
    power = params.motor.power_rating if power_limit is None else float(power_limit)
    if time_weight is None:
        time_weight = plan_time_weight(params.plant)
    if not (power > 0 and math.isfinite(power)):
        raise ParameterError(f"power limit = {power:g} W is not allowed; allowed (0, inf) W")
    tmax = params.scenario.max_time if max_duration is None else float(max_duration)
    if not 0.0 <= end_depth < params.gripper.capture_distance:
        raise ParameterError(f"end depth = {end_depth:g} m is out of range; allowed "
                             f"[0, {params.gripper.capture_distance:g}) m (the capture band)")
    if params.scenario.start == "plan":
        raise ParameterError("scenario.start = 'plan' tracks plan.file; the planner plans from "
                             "line or hanging")
    q0 = start_configuration(params.scenario.start, params.scenario.grip_spacing, params.plant,
                             math.radians(params.scenario.incline_deg))
    qT = planned_target(params, end_depth)
    tau_max = plan_torque_limit(params)
    inputs = dict(plant=params.plant.key_dict(), friction=params.friction.as_dict(),
                  envelope=plan_envelope(params),
                  q0=q0.tolist(), qT=qT.tolist(), tau_max=tau_max, power=power, tmax=tmax,
                  knots=knots, time_weight=time_weight, guess_duration=guess_duration,
                  tolerance=tolerance, iterations=iterations,
                  incline_deg=params.scenario.incline_deg)
    if minor_iterations is not None:
        inputs["minor_iterations"] = int(minor_iterations)
    if rate_limit > 0:
        inputs["rate_limit"] = float(rate_limit)
    guess = None
    if initial is not None:
        guess = warm_guess(initial, q0, qT)
        inputs["initial"] = hashlib.sha256(b"".join(
            np.ascontiguousarray(a, dtype=float).tobytes() for a in guess)).hexdigest()

    def solve():   # in a log, a long solve says it runs (a terminal's bar is progress's)
        with progress_bar(False if progress else ambient(), unit="plans", total=1,
                          desc=f"solving a plan for this robot ({knots} knots)") as said:
            plan = _solve_plan(params, q0, qT, tau_max, power, tmax, knots, time_weight,
                               guess_duration, tolerance, iterations, progress, guess,
                               minor_iterations, rate_limit)
            said.update()
            return plan

    if not cache:
        return solve()

    return cached(inputs, solve, make=SwingPlan, fits=lambda plan: planned_for(plan, inputs))


def warm_guess(plan: SwingPlan, q0, qT) -> tuple:
    """(times, states, torque) of ``plan`` as an initial guess from ``q0`` to
    ``qT``: its angles shifted by ``(1 - s) (q0 - its start) + s (qT - its
    end)`` at the fraction ``s`` of its duration, its rates and torque as
    they are (a plan for a nearby grip spacing)."""
    s = (plan.times - plan.times[0]) / (plan.times[-1] - plan.times[0])
    states = shifted_angles(s, plan.states, q0, qT)
    return np.asarray(plan.times, dtype=float), states, np.asarray(plan.torque, dtype=float)


#: re-solves with a tighter voltage bound at the knots when the voltage
#: between them exceeds the driver's output
PLAN_VOLTAGE_REFINEMENTS = 4


def _peak_voltage(dircol, result, env, knots) -> float:
    """The largest |winding voltage| along the reconstructed trajectory."""
    if env is None:
        return 0.0
    xs = dircol.ReconstructStateTrajectory(result)
    us = dircol.ReconstructInputTrajectory(result)
    t = np.linspace(xs.start_time(), xs.end_time(), 20 * knots)
    rate = xs.vector_values(t)[3]
    tau = us.vector_values(t)[0]
    return float(np.max(np.abs(env["resistance"] / env["torque_per_amp"] * tau
                               + env["emf_per_rate"] * rate)))


def _solve_plan(params, q0, qT, tau_max, power, tmax, knots, time_weight, guess_duration,
                tolerance, iterations, progress=False, guess=None,
                minor_iterations=None, rate_limit=0.0) -> SwingPlan:
    """The DirectCollocation solve of :func:`plan_swing`."""
    from pydrake.all import (DirectCollocation, PiecewisePolynomial, SnoptSolver, Solve,
                             SolverOptions)


    system, friction = plan_model(params)
    dircol = DirectCollocation(system, system.CreateDefaultContext(), num_time_samples=knots,
                               minimum_time_step=0.2 / (knots - 1),
                               maximum_time_step=tmax / (knots - 1))
    prog = dircol.prog()
    x0, xT = np.r_[q0, 0.0, 0.0], np.r_[qT, 0.0, 0.0]
    prog.AddBoundingBoxConstraint(x0, x0, dircol.initial_state())
    prog.AddBoundingBoxConstraint(xT, xT, dircol.final_state())
    u, x = dircol.input(), dircol.state()
    dircol.AddConstraintToAllKnotPoints(u[0] <= tau_max)
    dircol.AddConstraintToAllKnotPoints(u[0] >= -tau_max)
    dircol.AddConstraintToAllKnotPoints(u[0] * x[3] <= power)
    dircol.AddConstraintToAllKnotPoints(u[0] * x[3] >= -power)
    if rate_limit > 0:
        dircol.AddConstraintToAllKnotPoints(x[3] <= rate_limit)
        dircol.AddConstraintToAllKnotPoints(x[3] >= -rate_limit)
    env = plan_envelope(params)
    volts = []
    if env is not None:   # the winding voltage, linear in the torque and the elbow rate
        volt = env["resistance"] / env["torque_per_amp"] * u[0] + env["emf_per_rate"] * x[3]
        volts = dircol.AddConstraintToAllKnotPoints(volt <= env["share"] * env["voltage"]) + \
            dircol.AddConstraintToAllKnotPoints(volt >= -env["share"] * env["voltage"])
    dircol.AddRunningCost(u[0] ** 2)
    if time_weight > 0:
        dircol.AddFinalCost(dircol.time()[0] * float(time_weight))
    if guess is None:
        dircol.SetInitialTrajectory(PiecewisePolynomial(), PiecewisePolynomial.FirstOrderHold(
            [0.0, min(guess_duration, tmax)], np.c_[x0, xT]))
    else:
        times, states, torque = guess
        dircol.SetInitialTrajectory(PiecewisePolynomial.FirstOrderHold(times, torque[None, :]),
                                    PiecewisePolynomial.FirstOrderHold(times, states.T))
    options = SolverOptions()
    snopt = SnoptSolver().solver_id()
    options.SetOption(snopt, "Major iterations limit", int(iterations))
    if minor_iterations is not None:
        options.SetOption(snopt, "Iterations limit", int(minor_iterations))

    with progress_bar(progress, desc="plan (SNOPT)", unit="evaluations") as bar:
        # at every evaluation: the count, and a moment a signal or wall limit can stop it
        prog.AddVisualizationCallback(lambda z: bar.update(), prog.decision_variables())
        result = Solve(prog, None, options)
        share = None if env is None else env["share"]
        for _ in range(PLAN_VOLTAGE_REFINEMENTS):   # the voltage between the knots
            peak = _peak_voltage(dircol, result, env, knots)
            if env is None or peak <= env["voltage"]:
                break
            share *= 0.98 * env["voltage"] / peak
            for b in volts:
                c = b.evaluator()
                c.UpdateLowerBound(np.maximum(c.lower_bound(), -share * env["voltage"]))
                c.UpdateUpperBound(np.minimum(c.upper_bound(), share * env["voltage"]))
            result = Solve(prog, result.GetSolution(), options)
    feasible = not result.GetInfeasibleConstraintNames(prog, tolerance)
    xs = dircol.ReconstructStateTrajectory(result)
    us = dircol.ReconstructInputTrajectory(result)
    times = np.linspace(xs.start_time(), xs.end_time(), 20 * knots)
    states = np.array([xs.value(t).ravel() for t in times])
    torque = np.array([us.value(t).ravel()[0] for t in times])
    fr = friction_torques_along(states, friction)
    electric = {} if env is None else dict(
        voltage_limit=env["voltage"], voltage_share=share,
        resistance=env["resistance"], emf_per_rate=env["emf_per_rate"],
        torque_per_amp=env["torque_per_amp"])
    plan = SwingPlan(times, states, torque, fr, bool(result.is_success()), feasible,
                     result.get_solver_id().name(), params.scenario.incline_deg, tau_max,
                     power, tolerance, **electric,
                     status=SOLVER_STATUS.get(result.get_solution_result().name, "failed"))
    if env is not None and plan.peak_voltage > env["voltage"]:   # between the knots
        plan = replace(plan, feasible=False)
    return plan


#: initial-guess durations (s) :func:`tracking_plan` tries in turn until a plan
#: is feasible (on a -8 deg line 1.5 s ends 1e-4 outside the tolerance, 1.0 s not);
#: from hanging at rest (``scenario.start``) :data:`HANGING_GUESSES`
PLAN_GUESSES = (1.5, 1.0, 2.0)


def tracking_plan(params: BplirParams):
    """(plan, tracking gains) for the scenario of ``params``: the plan of
    :func:`scenario_plan`, the gains from Drake's finite-horizon LQR on the
    nominal model (:func:`tracking_gains`: disk cache too); from the
    shipped library when it covers the scenario (:mod:`.plan_library`)."""
    found = None if params.plan.file else library_plan(params)
    if found is not None:
        return found
    plan = scenario_plan(params)
    return plan, tracking_gains(params.plant, params.friction, plan,
                                weights=TrackerWeights.of(params.plan))


def _on_grid(spacing: float, step: float) -> float:
    """``spacing`` rounded to the plans' grid of ``step`` (m)."""
    return round(round(spacing / step) * step, 9)


def scenario_plan(params: BplirParams) -> SwingPlan:
    """The plan for the scenario of ``params`` with ``plan.end_depth``:
    interpolated from the shipped library when it covers the scenario
    (:mod:`.plan_library`), else for the grip spacing rounded to
    ``plan.spacing_step`` the first feasible :func:`plan_swing` (disk
    cache) of the guesses :data:`PLAN_GUESSES` and, for a spacing other
    than ``plan.warm_spacing``, the plan started from that spacing's plan
    (:func:`warm_guess`) if its :meth:`SwingPlan.objective` is lower (the
    straight-line guesses alone end in other local optima at 1.27 m, 0 deg
    and 1.1 m, -20 deg).  From hanging (``scenario.start``): the guesses
    :func:`hanging_plan`."""
    if params.plan.file:   # a plan made elsewhere
        return read_plan_file(params)
    found = library_plan(params)
    if found is not None:
        return found[0]
    sc, depth, step = params.scenario, params.plan.end_depth, params.plan.spacing_step
    if step > 0:   # the measured spacing on the plans' grid
        spacing = _on_grid(sc.grip_spacing, step)
        params = params.with_(scenario=replace(sc, grip_spacing=spacing))
    hanging = params.scenario.start == "hanging"
    if hanging:
        return hanging_plan(params)
    if params.scenario.manoeuvre_of() == "pump":
        return pump_plan(params)
    for guess in PLAN_GUESSES:   # SNOPT sometimes stops just outside the tolerance
        plan = plan_swing(params, end_depth=depth, guess_duration=guess)
        if plan.feasible:
            break
    warm = params.plan.warm_spacing
    if step > 0 and warm != "none":   # on the same grid (else the warm plan's own warm
        warm = _on_grid(warm, step)   # start recurses)
    if warm != "none" and not hanging and abs(params.scenario.grip_spacing - warm) > 1e-9:
        ref = scenario_plan(params.with_(scenario=replace(params.scenario, grip_spacing=warm)))
        started = plan_swing(params, end_depth=depth, initial=ref)
        w = plan_time_weight(params.plant)
        if started.feasible and (not plan.feasible or started.objective(w) < plan.objective(w)):
            plan = started
    if not plan.feasible:
        raise ParameterError(no_plan_message(plan))
    return plan


def hanging_plan(params: BplirParams, *, power_limit: float | None = None,
                 knots: int = HANGING_KNOTS, progress: bool = False,
                 strict: bool = True) -> SwingPlan:
    """The plan from hanging at rest (``scenario.start = "hanging"``): the
    first feasible of the guesses :data:`HANGING_GUESSES` on ``knots``
    (:data:`HANGING_KNOTS`) with up to :data:`HANGING_MINOR_ITERATIONS`
    minor iterations, the torque within ``hanging.torque_share`` of its limit
    and the voltage within the envelope of ``hanging.supply_voltage``
    (:func:`planned_from_hanging`: a pump of several swings the tracker can
    follow with headroom), no warm start.  With ``hanging.i2t_share``
    a feasible plan that by itself uses more of the driver's i^2 t budget
    (:func:`planned_i2t`) gives way to the next guess, and the least
    heating feasible plan is kept if none keeps to it.  Where no guess is
    feasible on an inclined line, the solver starts from the level line's
    plan from hanging instead (SNOPT's straight-line guesses stop at its
    iteration limit there; at 48 V on a +13 deg chord it found one in
    about 90 s).  When none is feasible: ``ParameterError`` naming why, or
    with ``strict=False`` the last guess's plan (``bplir plan`` reports
    it)."""
    params = planned_from_hanging(params)
    allowance = i2t_allowance(params)
    kept = None   # (i^2 t, plan) of the least heating feasible plan
    for guess in HANGING_GUESSES:
        plan = hanging_solve(params, power_limit=power_limit, knots=knots, progress=progress,
                             guess_duration=guess)
        if not plan.feasible:
            continue
        heat = planned_i2t(plan, params.motor)
        if heat <= allowance:
            return plan
        if kept is None or heat < kept[0]:
            kept = (heat, plan)
    if kept is not None:
        return kept[1]
    warm = _warm_from_level(params, power_limit, knots, progress)
    if warm is not None:
        return warm
    if strict:
        raise ParameterError(no_plan_message(plan))
    return plan


def _warm_from_level(params: BplirParams, power_limit, knots: int, progress: bool):
    """The plan from hanging on an inclined line started from the level
    line's (:func:`warm_guess`), when the straight-line guesses found none;
    None where that fails too, or the line is level."""
    sc = params.scenario
    if sc.incline_deg == 0.0:
        return None
    level = hanging_plan(params.with_(scenario=replace(sc, incline_deg=0.0)), knots=knots,
                         power_limit=power_limit, strict=False)
    if not level.feasible:
        return None
    plan = hanging_solve(params, power_limit=power_limit, knots=knots, progress=progress,
                         initial=level)
    return plan if plan.feasible else None


def hanging_solve(made: BplirParams, *, power_limit: float | None = None,
                  knots: int = HANGING_KNOTS, progress: bool = False, **start) -> SwingPlan:
    """One solve of the plan from hanging of ``made`` (as
    :func:`planned_from_hanging` makes it): ``plan.end_depth``, its own iteration
    limit, started from ``start`` (``guess_duration``
    or ``initial``, as :func:`plan_swing` takes them)."""
    return plan_swing(made, power_limit=power_limit, end_depth=made.plan.end_depth, knots=knots,
                      minor_iterations=HANGING_MINOR_ITERATIONS, progress=progress, **start)


def pump_plan(params: BplirParams, *, progress: bool = False, strict: bool = True) -> SwingPlan:
    """The plan of a pumping manoeuvre from the line: the first feasible
    :func:`pump_solve` of the guesses :func:`pump_guesses`; else
    ``ParameterError`` naming why (``strict=False``: the last guess's plan)."""
    for guess in pump_guesses(params.plant):
        plan = pump_solve(params, progress=progress, guess_duration=guess)
        if plan.feasible:
            return plan
    if strict:
        raise ParameterError(no_plan_message(plan))
    return plan


def pump_solve(params: BplirParams, *, progress: bool = False, **start) -> SwingPlan:
    """One solve of a pump's plan from ``start`` (``guess_duration`` or
    ``initial``) on :data:`PUMP_KNOTS` with the hanging plans' iteration
    limit; not feasible where it does not keep the robot's energy
    (:func:`energy_balance` over :data:`UNBALANCED_SHARE`)."""
    plan = plan_swing(params, end_depth=params.plan.end_depth, knots=PUMP_KNOTS,
                      minor_iterations=HANGING_MINOR_ITERATIONS, progress=progress, **start)
    if plan.feasible and energy_balance(plan, params.plant)["residual_share"] > UNBALANCED_SHARE:
        return replace(plan, feasible=False, status="energy not kept")
    return plan


def planned_i2t(plan: SwingPlan, motor) -> float:
    """The most of the driver's i^2 t (A^2 s) the planned torque alone uses,
    from a reset driver (:func:`~bplir_drake.systems.motor.i2t_trace` of the
    plan's current on the driver's ticks, :meth:`SwingPlan.torque_on_ticks`)."""
    current = np.abs(plan.torque_on_ticks(motor.driver_period)[1]) / motor.torque_per_amp
    return float(np.max(i2t_trace(0.0, current, motor)[0], initial=0.0))


def i2t_allowance(params: BplirParams) -> float:
    """The driver's i^2 t (A^2 s) a plan from hanging of ``params`` (as
    :func:`planned_from_hanging` makes it) may use by itself:
    ``hanging.i2t_share`` of the budget (infinite with the share "none")."""
    share = params.hanging.i2t_share
    return math.inf if share == "none" else share * interlock_budget(params.motor)


_GAINS: dict = {}


def gains_inputs(plant, friction, plan: SwingPlan,
                 weights: TrackerWeights = TrackerWeights()) -> dict:
    """Every input of the tracking gains of ``plan``: the nominal model
    (plant, friction), the LQR weights (:class:`TrackerWeights`, as
    :func:`plan_gains` uses them) and the plan's samples (by digest)."""

    digest = hashlib.sha256(b"".join(np.ascontiguousarray(a, dtype=float).tobytes()
                                     for a in (plan.times, plan.states, plan.torque)))
    return dict(plant=plant.key_dict(), friction=friction.as_dict(),
                smoothing=PLAN_FRICTION_SMOOTHING,
                weights=dataclasses.asdict(weights), riccati=RICCATI_ACCURACY,
                plan=digest.hexdigest())


def tracking_gains(plant, friction, plan: SwingPlan, cache: bool = True,
                   weights: TrackerWeights = TrackerWeights()):
    """Finite-horizon LQR gains along ``plan`` on the nominal model (plant,
    friction) with the LQR ``weights``: kept in this process per input, and
    with ``cache`` on disk (:mod:`.plan_cache`, keyed by :func:`gains_inputs`)."""

    inputs = gains_inputs(plant, friction, plan, weights)

    def solve():
        model, _ = plan_model(around(plant, friction))   # any link lengths
        return plan_gains(model, plan.times, plan.states, plan.torque, weights)

    if not cache:
        return solve()
    key = json.dumps(inputs, sort_keys=True)
    if key not in _GAINS:

        _GAINS[key] = cached(inputs, solve, kind="gains")
    return _GAINS[key]
