"""What a calibrated model implies for control: the elbow's dead-band (4.6) and the CPFL plant family (4.7) identified from step responses."""
from __future__ import annotations

import math
from dataclasses import dataclass
import numpy as np
from ...params import BplirParams
from ...diagrams import build_cpfl_step, build_free_swing
from ...simulate import logs, make_simulator, run
from ..control.plants import Plant, PlantFamily
from ..swing.swing_runner import draw_true_friction


def identify_deadband(params: BplirParams, *, ramp_rate: float = 0.05, start: float = 0.3,
                      max_torque: float = 1.5, rate_threshold: float = 0.02) -> dict:
    """Ramp the torque command slowly (N m/s, from ``start``) through the motor
    model from the hanging rest state; the identified dead-band is the
    command at which |q2'| first exceeds ``rate_threshold``, forward and
    reverse."""

    out = {}
    T = (max_torque - start) / ramp_rate
    for name, sign in (("forward", 1.0), ("reverse", -1.0)):
        times = np.arange(0.0, T, 0.01)
        built = build_free_swing(params, (times, sign * (start + ramp_rate * times)), motor=True,
                                 log_period=0.005)
        sim = make_simulator(built, (0.0, 0.0), accuracy=1e-6)
        # in 0.5 s chunks, ending once the elbow moves (the rest of the
        # ramp would only swing it: about half the simulated time)
        while sim.get_context().get_time() < T - 1e-9:
            run(sim, min(0.5, T - sim.get_context().get_time()))
            q2d = sim.get_context().get_continuous_state_vector().CopyToVector()[3]
            if abs(q2d) > rate_threshold:
                break
        st = logs(built, sim)["state"]
        moving = np.nonzero(np.abs(st.data[:, 3]) > rate_threshold)[0]
        out[name] = float(start + ramp_rate * st.t[moving[0]]) if len(moving) else math.nan
    out["configured"] = params.motor.deadband
    out["ramp_rate_Nm_s"] = ramp_rate
    out["rate_threshold_rad_s"] = rate_threshold
    return out


def cpfl_step_response(params: BplirParams, v: float, q0=(0.0, 0.0), qd0=(0.0, 0.0),
                       duration: float = 0.6, t_step: float = 0.05):
    """q2 response of the CPFL loop (discrete at Ts, through the motor) to a
    step of the outer-loop signal ``v`` at ``t_step``; returns (t, q2 - q2(t_step))."""

    built = build_cpfl_step(params, ((0.0, t_step), (0.0, v)))
    sim = make_simulator(built, q0, qd0, accuracy=1e-6)
    run(sim, duration)
    st = logs(built, sim)["state"]
    k0 = int(np.argmin(np.abs(st.t - t_step)))
    t = st.t[k0:] - st.t[k0]
    return t, st.data[k0:, 1] - st.data[k0, 1]


def damped_integrator_response(t, v, g, c, Td):
    """Step response of ``g e^{-s Td}/(s (s + c))`` to a step ``v``:
    ``v g (c t - 1 + e^{-c t}) / c^2`` (-> ``v g t^2/2`` as c -> 0)."""
    tt = np.maximum(np.asarray(t, dtype=float) - Td, 0.0)
    ct = c * tt
    small = ct < 1e-4
    out = np.where(small, tt * tt / 2 * (1 - ct / 3),
                   (ct + np.expm1(-np.where(small, 1.0, ct))) / max(c, 1e-300) ** 2)
    return v * g * out


def fit_step(t, y, v) -> dict:
    """Least-squares fit of the damped integrator with delay (:func:`damped_integrator_response`)
    to a step response y(t) to v: gain, damping, delay and RMSE."""
    from scipy.optimize import least_squares

    def res(z):
        g, c, Td = z
        return damped_integrator_response(t, v, g, c, Td) - y

    g0 = max(2 * y[-1] / (v * t[-1] ** 2), 1e-6)
    r = least_squares(res, [g0, 0.5, 0.005], bounds=([1e-9, 0.0, 0.0], [1e4, 50.0, 0.5]),
                      x_scale=[g0, 1.0, 0.01])
    g, c, Td = r.x
    return {"g": float(g), "c": float(c), "Td": float(Td),
            "rmse": float(np.sqrt(np.mean(r.fun ** 2)))}


@dataclass
class PlantFamilyFit:
    """Step fits of the CPFL plant (4.7): one fit per step, the responses, and the parameter ranges
    the family spans."""
    fits: list
    responses: list   # (t, y, v)
    ranges: dict      # k, a, Td -> (min, max)

    def envelope(self, t, v, n: int = 5, margin: float | None = None):
        """Min/max over an n^3 grid of the ranges (plus the largest fit RMSE
        scaled to the step, unless ``margin`` is given)."""
        grid = [np.linspace(*self.ranges[k], n) for k in ("g", "c", "Td")]
        ys = np.array([damped_integrator_response(t, v, g, c, d)
                       for g in grid[0] for c in grid[1] for d in grid[2]])
        m = max(f["rmse"] / abs(r[2]) for f, r in zip(self.fits, self.responses)) * abs(v) \
            if margin is None else margin
        return ys.min(axis=0) - m, ys.max(axis=0) + m

    def qft_family(self):
        """The identified family as QFT plants ``g e^{-s Td}/(s (s + c))``
        on the corners of the ranges."""
        import control   # python-control only where a family is asked for

        plants = [Plant(control.tf([g], [1.0, c, 0.0]), d, f"g={g:.3g} c={c:.3g} Td={d:.3g}")
                  for g in self.ranges["g"] for c in self.ranges["c"] for d in self.ranges["Td"]]
        return PlantFamily(plants, "identified CPFL family (4.7)")


def identify_plant_family(params: BplirParams, steps=(10.0, 20.0, 40.0, -20.0), n_plants: int = 3,
                          seed: int = 0) -> PlantFamilyFit:
    """Step tests of the CPFL loop on ``n_plants`` robots with friction drawn
    within +/-20 % (the first one nominal), for each step size in ``steps``."""

    fits, responses = [], []
    for i in range(n_plants):
        p = params if i == 0 else draw_true_friction(params, seed + i)
        for v in steps:
            t, y = cpfl_step_response(p, v)
            fits.append(fit_step(t, y, v))
            responses.append((t, y, v))
    ranges = {k: (min(f[k] for f in fits), max(f[k] for f in fits)) for k in ("g", "c", "Td")}
    return PlantFamilyFit(fits, responses, ranges)
