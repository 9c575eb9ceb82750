"""Nonlinear closed-loop studies of the controller on the Drake diagram:
elbow step responses and the anti-windup comparison."""
from __future__ import annotations

import dataclasses as dc
from dataclasses import dataclass

import numpy as np

from ...diagrams import build_control_loop
from ...params import BplirParams
from ...simulate import logs, make_simulator, run


@dataclass
class StepMetrics:
    """An elbow step of the closed loop: settling time (s), final error and overshoot (relative to
    the step), largest outer-loop signal v (rad/s^2) and torque (N m), and the response
    q2(t) (rad)."""
    settling_time: float      # into +/- band of the step, after the step
    final_error: float        # relative
    overshoot: float          # relative
    max_v: float
    max_torque: float
    t: np.ndarray
    q2: np.ndarray


def elbow_step(params: BplirParams, target: float, *, t_step: float = 0.1, duration: float = 1.5,
               band: float = 0.1, q0=(0.0, 0.0)) -> StepMetrics:
    """Step of the elbow reference from q0[1] to ``target`` on the nonlinear
    loop (discrete controller at Ts, true state)."""
    b = build_control_loop(params, reference=((0.0, t_step), (q0[1], target)))
    sim = make_simulator(b, q0)
    run(sim, duration)
    lg = logs(b, sim)
    t, x = lg["state"].t, lg["state"].data
    y, step = x[:, 1], target - q0[1]
    after = t >= t_step
    out = np.abs(y - target) > band * abs(step)
    k = np.nonzero(out & after)[0]
    settle = (t[k[-1] + 1] - t_step if k[-1] + 1 < len(t) else np.inf) if len(k) else 0.0
    return StepMetrics(float(settle), float(abs(y[-1] - target) / abs(step)),
                       float(max(0.0, np.max((y - target) * np.sign(step)) / abs(step))),
                       float(np.abs(lg["v"].data).max()), float(np.abs(lg["torque"].data).max()),
                       t, y)


def windup_release(params: BplirParams, *, torque_limit: float = 6.0, push: float = -9.0,
                   hold: float = 0.3, t_push=(1.0, 3.0), duration: float = 6.0,
                   aw_gain: float | None = None) -> dict:
    """Hold the elbow at ``hold`` rad, push it with an external elbow torque
    ``push`` during ``t_push`` so the controller sits at its (low) limit while
    the integrator winds up, then release.  Returns the overshoot after the
    release and the errors 1 s and 3 s after it."""
    ctrl = params.controller if aw_gain is None else dc.replace(params.controller, aw_gain=aw_gain)
    p = params.with_(controller=ctrl)
    b = build_control_loop(p, reference=hold, torque_limit=torque_limit,
                           input_disturbance=((0.0, t_push[0], t_push[1]), (0.0, push, 0.0)))
    sim = make_simulator(b, (0.0, hold))
    run(sim, duration)
    lg = logs(b, sim)
    t, y = lg["state"].t, lg["state"].data[:, 1]
    after = t >= t_push[1]

    def err_at(dt):
        return float(abs(y[np.argmin(np.abs(t - (t_push[1] + dt)))] - hold))

    during = (t > t_push[0]) & (t < t_push[1])
    sat = np.abs(lg["torque_unsaturated"].data[during, 0]) > torque_limit
    return {"overshoot_rad": float(np.max(y[after] - hold)), "error_1s_rad": err_at(1.0),
            "error_3s_rad": err_at(2.9), "saturated_fraction_during_push": float(np.mean(sat)),
            "aw_gain": ctrl.aw_gain, "torque_limit_Nm": torque_limit}
