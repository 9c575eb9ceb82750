"""After a swing that did not catch (a timeout, a crash, a driver trip): the robot hangs from its
holding gripper, drains the swing with the elbow until it hangs at rest,
and swings again from there.

:func:`damp` simulates the hanging robot (the true plant and friction)
under the elbow's damping law of :func:`~bplir_drake.diagrams.open_loop.
build_damping` (``traverse.recover_kp``, ``recover_kd``, ``recover_lean``)
from the state the swing ended in, in steps of a second, until
the energy above hanging at rest falls below ``traverse.recover_energy``
(damped) or ``traverse.recover_limit`` has passed, or the energy grows
beyond where it began (the law pumping instead of draining: given up).
:func:`~bplir_drake.planning.retry.retry` is the swing tried again
from hanging (``scenario.start``; its numbers, ``params.derive``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...params import BplirParams, ParameterError
from ...planning.solve import scenario_plan
from ...simulate import make_simulator, run
from ...systems.plant import kinetic_energy, potential_energy
from ...diagrams.open_loop import build_damping


@dataclass
class Damping:
    """The damping after a timeout or a driver trip: ``damped`` (came to rest within the
    limit), its duration (s), the energy above hanging at rest at its start
    and end (J), the state it ended in (its angles wrapped to [-pi, pi): the
    same pose, as the IMUs read it) and its logs (times, states, torque)."""

    damped: bool
    duration: float
    energy_start: float
    energy_end: float
    state: np.ndarray
    t: np.ndarray
    states: np.ndarray
    torque: np.ndarray


def swing_energy(x, p) -> float:
    """Energy (J) of the state ``x`` above hanging at rest, robot ``p``."""
    q, v = np.asarray(x[:2], float), np.asarray(x[2:4], float)
    return float(kinetic_energy(q, v, p) + potential_energy(q, p)
                 - potential_energy(np.zeros(2), p))


def damp(params: BplirParams, x0, pulses=()) -> Damping:
    """Drain the swing of the robot of ``params`` (its simulated plant),
    hanging from the holding gripper in state ``x0``, with the elbow's
    damping law (:mod:`module docs <.recovery>`); ``pulses``: knocks while
    it damps (``[(start s, (tau1, tau2) N m, duration s)]``; the energy
    they bring is drained too: the law gives up only on growth after them)."""
    tp = params.traverse
    built = build_damping(params, tp.recover_kp, tp.recover_kd, tp.recover_lean,
                          pulses=pulses)
    x0 = np.asarray(x0, dtype=float)
    sim = make_simulator(built, x0[:2], x0[2:], accuracy=1e-6)
    plant = built.plant
    pctx = plant.GetMyContextFromRoot(sim.get_context())
    true_p = params.simulated_plant
    e0 = energy = swing_energy(x0, true_p)
    grown = e0   # what the law must not grow beyond: the start's, or a knock's
    t = 0.0
    while ((energy > tp.recover_energy or t < _knocked_until(pulses, t))
           and t < tp.recover_limit and energy <= 1.1 * grown + 0.1):
        t_prev = t
        run(sim, min(1.0, tp.recover_limit - t))
        t = sim.get_context().get_time()
        energy = swing_energy(plant.GetPositionsAndVelocities(pctx), true_p)
        if any(t_prev - 1.0 <= s < t for s, _, _ in pulses):   # a knock's energy, to drain
            grown = max(grown, energy)
    ctx = sim.get_context()
    st = built.loggers["state"].FindLog(ctx)
    tq = built.loggers["torque"].FindLog(ctx)
    end = plant.GetPositionsAndVelocities(pctx).copy()
    end[:2] = (end[:2] + np.pi) % (2.0 * np.pi) - np.pi
    return Damping(energy <= tp.recover_energy, t, e0, energy, end,
                   st.sample_times(), st.data().T, tq.data()[0])


def _knocked_until(pulses, t: float) -> float:
    """The end of the last pulse that has begun by ``t`` (0: none)."""
    return max((s + d for s, _, d in pulses if s <= t + 1e-12), default=0.0)


def damping_drive(d: Damping, motor):
    """(current A, electrical energy J) along the damping ``d``: the
    current of the torque and the positive mechanical work through the
    gear's and the motor's efficiencies."""
    work = float(np.trapezoid(np.maximum(d.torque * d.states[:, 3], 0.0), d.t))
    return d.torque / motor.torque_per_amp, work / (motor.eta_g * motor.eta_m)


def can_retry(p: BplirParams) -> bool:
    """Whether the planner finds a swing from hanging for ``p`` (a try
    again, :func:`~bplir_drake.planning.retry.retry`) on the nominal model."""
    try:
        scenario_plan(p.resolved())
    except ParameterError:
        return False
    return True
