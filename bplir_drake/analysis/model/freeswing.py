"""Free swing: simulate plant + friction and compute the energy balance."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...diagrams import build_free_swing
from ...params import BplirParams
from ...simulate import logs, make_simulator, run
from .energy import energy, energy_rate_from_forces
from ...io import Result
from .model_plots import plot_free_swing


@dataclass
class FreeSwingResult(Result):
    """A free swing: times (s), state (N, 4), applied elbow torque (N m), generalized friction
    force, kinetic, potential and total energy (J) and its rate (W)."""
    t: np.ndarray            # (N,)
    x: np.ndarray            # (N, 4) q1, q2, q1d, q2d
    tau: np.ndarray          # (N,) elbow torque applied
    friction_force: np.ndarray  # (N, 2) generalized friction force (-f)
    kinetic: np.ndarray
    potential: np.ndarray
    total: np.ndarray
    energy_rate: np.ndarray  # (7.13) along the run

    @property
    def energy_start(self) -> float:
        """Total energy at the start (J)."""
        return float(self.total[0])

    @property
    def energy_end(self) -> float:
        """Total energy at the end (J)."""
        return float(self.total[-1])

    def table(self) -> dict:
        """The swing as time series: ``t_s``, the state, the elbow torque,
        the friction and the energies, a column each."""
        return {"t_s": self.t, "q1_rad": self.x[:, 0], "q2_rad": self.x[:, 1],
                "q1d_radps": self.x[:, 2], "q2d_radps": self.x[:, 3], "tau_Nm": self.tau,
                "friction1_Nm": self.friction_force[:, 0],
                "friction2_Nm": self.friction_force[:, 1], "kinetic_J": self.kinetic,
                "potential_J": self.potential, "total_J": self.total,
                "energy_rate_W": self.energy_rate}

    def plot(self, axes=None):
        """Angles, rates and energies against time (three axes)."""

        return plot_free_swing(self, axes)

    def summary(self) -> dict:
        """Duration, energies and start/end angles as JSON-ready data."""
        return {"duration_s": float(self.t[-1] - self.t[0]),
                "energy_start_J": self.energy_start, "energy_end_J": self.energy_end,
                "energy_change_J": self.energy_end - self.energy_start,
                "q_start": self.x[0, :2].tolist(), "q_end": self.x[-1, :2].tolist()}


def simulate_free_swing(params: BplirParams, q0, duration: float, *, v0=(0.0, 0.0),
                        elbow_torque=0.0, friction: bool = True, motor: bool = False,
                        accuracy: float = 1e-6, log_period: float = 0.001) -> FreeSwingResult:
    """Simulate the plant (with friction unless ``friction=False``, through the motor with
    ``motor=True``) from ``q0``, ``v0`` for ``duration`` s under a constant or scheduled
    ``elbow_torque``."""
    built = build_free_swing(params, elbow_torque, friction=friction, motor=motor,
                             log_period=log_period)
    sim = make_simulator(built, q0, v0, accuracy=accuracy)
    run(sim, duration, params.scenario.wall_limit, "the free swing")
    lg = logs(built, sim)
    x = lg["state"].data
    tau = lg["torque"].data[:, 0]
    gf = lg["friction"].data
    ke, pe, tot = energy(x, params.simulated_plant)
    return FreeSwingResult(lg["state"].t, x, tau, gf, ke, pe, tot,
                           energy_rate_from_forces(x, tau, gf))
