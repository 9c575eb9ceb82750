"""A Gymnasium environment of one swing: the package's swing diagram with
the elbow command as the action.

Each episode is one swing of a robot drawn at ``reset(seed=...)`` from a
study's uncertainty (default: the robot's verification study,
:func:`~bplir_drake.analysis.commission.verdict.verification_study`, the
realistic study in the robot's own units: masses, friction, IMU errors,
actuation delay, wind and gusts, the grip spacing when a grid is given).
The simulated robot is that draw; what the policy sees is the robot's
computer's: the EKF's estimate (``observation = "estimate"``: q1, q2, q1',
q2') or the IMU sample (``"imu"``: gyro1, gyro2, acc1_x, acc1_y, acc2_x,
acc2_y).

**Timing.**  A step is one controller tick ``T``.  The environment stops
half the compute latency after each tick ``t_k``, so the observation is
the tick's (IMU sample ``k`` and the estimate from it) and the action is
the command the zero-order hold takes ``compute_latency`` after ``t_k``:
what a controller plug-in reads and gives (:func:`as_controller` runs a
policy there, and the two give the same swing).

**Action**: the elbow command as a share of the torque limit, in [-1, 1]
(the driver then applies its own limits: the voltage envelope, the peak
current, the dead-band, the i^2 t interlock).

**Reward**: each step ``-(d / L) (T / max_time)``, ``d`` the free
gripper's distance to the grip it must take (the mirror point on the line,
one grip spacing past the holding gripper) and ``L`` the reach ``l1 + l2``
(so a whole timed-out episode far from the grip sums to about ``-d/L``);
on the last step ``+1`` for a capture, ``-1`` for a crash (arriving faster
than the gripper's capture speed) or a fault (the driver's interlock).
**Termination**: capture, crash or fault end the episode (``terminated``);
the scenario's ``max_time`` truncates it (``truncated``, outcome
"timeout").  ``info``: ``outcome``, ``time_s``, ``sample_seed``,
``swing_seed`` and the drawn values (on reset).

Why not Drake's ``DrakeGymEnv``: its ``reset`` returns the context to its
defaults after ``Simulator.Initialize``, undoing the initialization events
the IMU sampler and the gripper interlock run at ``t = 0``; its
``info_handler`` is never called (``if info_handler is
callable(info_handler)``, Drake 1.51); and it reports a timeout as a
termination.  This class uses Drake's ``Simulator`` directly.
"""
from __future__ import annotations

import math

import gymnasium as gym
import numpy as np

from ..analysis.commission.verdict import verification_study
from ..analysis.montecarlo.sampling import sample_params
from ..analysis.swing.swing_runner import SWING_ACCURACY, SWING_INTEGRATOR
from ..diagrams import build_swing
from ..params import BplirParams, preset
from ..simulate import SimulationError, make_simulator, run
from ..systems.gripper import line_metrics
from .render import LineRenderer, MeshcatRenderer

#: the observations by name, and their signals
OBSERVATIONS = {"estimate": ("q1", "q2", "q1d", "q2d"),
                "imu": ("gyro1", "gyro2", "acc1_x", "acc1_y", "acc2_x", "acc2_y")}
#: the observation's bounds: angles within this many turns, rates within
#: this many times the robot's fastest (the elbow's no-load rate, or the
#: pendulum rate sqrt(g / L) where larger), accelerations within this many g
TURNS, RATE_FACTOR, G_FACTOR = 2.0, 10.0, 10.0
#: the terminal rewards by outcome
TERMINAL_REWARD = {"captured": 1.0, "crash": -1.0, "fault": -1.0, "timeout": 0.0}


class BrachiationEnv(gym.Env):
    """One swing of ``params`` (default: the dissertation's robot) with its
    uncertainty drawn from ``study`` (a
    :class:`~bplir_drake.analysis.montecarlo.Study`; default the robot's
    verification study on its own line); ``observation`` "estimate" or
    "imu"; ``render_mode`` "rgb_array" (a picture of the robot on the line)
    or "human" (Meshcat).  See the module docstring."""

    #: a frame per step of the default 10 ms tick plays at real time
    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 100}

    def __init__(self, params: BplirParams | None = None, *, observation: str = "estimate",
                 study=None, render_mode: str | None = None):
        if observation not in OBSERVATIONS:
            raise ValueError(f"observation = {observation!r}; allowed: "
                             + ", ".join(OBSERVATIONS))
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode = {render_mode!r}; allowed: rgb_array, human")
        params = preset() if params is None else params
        self.study = study if study is not None else verification_study(
            params, params.scenario.incline_deg, 1, 0)
        self.observation, self.render_mode = observation, render_mode
        high = observation_bounds(params, observation)
        self.observation_space = gym.spaces.Box(-high, high, dtype=np.float64)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
        self.params = None       # the episode's drawn robot
        self._built = self._sim = self._renderer = None

    # ------------------------------------------------------------------ episodes

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """A new swing: a robot drawn from the study with a root seed taken
        from the environment's generator (seeded by ``seed``)."""
        super().reset(seed=seed)
        root = int(self.np_random.integers(2 ** 32))
        p, swing_seed, drawn = sample_params(self.study.with_(seed=root, samples=1), 0)
        self._start(p, swing_seed)
        return self._observe(), {"outcome": "swinging", "time_s": 0.0, "sample_seed": root,
                                 "swing_seed": swing_seed, "drawn": drawn}

    def _start(self, p: BplirParams, swing_seed: int) -> None:
        self.close_episode()
        p = p.resolved()
        self.params = p
        self._built = build_swing(p, seed=swing_seed, action_input=True)
        b = self._built
        self._action = b.diagram.GetInputPort("action")
        self._obs_port = b.diagram.GetOutputPort(self.observation)
        self._lock = b.systems["interlock"]
        geo = self._lock.geometry
        self._target, self._reach = geo.grip_spacing, geo.l1 + geo.l2
        self._state_port = b.diagram.GetOutputPort("true_state")
        self._period = p.controller.period
        self._max_time = p.scenario.max_time
        # the step's stop within the tick: after the sample, before the hold
        latency = p.controller.compute_latency
        self._offset = 0.5 * latency if latency > 0 else 1e-6 * self._period

        def zero_action(c):
            self._action.FixValue(c, np.zeros(1))

        self._sim = make_simulator(b, b.q0, accuracy=SWING_ACCURACY,
                                   integrator=SWING_INTEGRATOR, set_context=zero_action)
        self._ctx = self._sim.get_mutable_context()
        self._k = 0
        run(self._sim, self._offset, what="the episode's first tick")

    def step(self, action):
        """One controller tick with the elbow command ``action`` (a share
        of the torque limit)."""
        if self._sim is None:
            raise RuntimeError("call reset() before step()")
        self._action.FixValue(self._ctx, np.asarray(action, dtype=np.float64).reshape(1))
        self._k += 1
        try:
            self._sim.AdvanceTo(self._k * self._period + self._offset)
            outcome = self._lock.outcome(self._ctx)
        except (RuntimeError, SimulationError):   # the integrator gave up: a fault
            outcome = "fault"
        normal, along, _, _ = line_metrics(self.true_state(), self._lock.geometry)
        d = math.hypot(normal, along - self._target)
        reward = -(d / self._reach) * (self._period / self._max_time)
        reward += TERMINAL_REWARD.get(outcome, 0.0)
        terminated = outcome in ("captured", "crash", "fault")
        truncated = outcome == "timeout"
        info = {"outcome": outcome, "time_s": float(self._ctx.get_time()),
                "distance_m": float(d)}
        return self._observe(), float(reward), terminated, truncated, info

    def _observe(self) -> np.ndarray:
        space = self.observation_space
        return np.clip(np.array(self._obs_port.Eval(self._ctx), dtype=np.float64),
                       space.low, space.high)

    def true_state(self) -> np.ndarray:
        """The simulated robot's state (q1, q2, q1', q2') now."""
        return np.array(self._state_port.Eval(self._ctx), dtype=np.float64)

    # ------------------------------------------------------------------ rendering

    def render(self):
        """``"rgb_array"``: the robot on the line now, an (H, W, 3) uint8
        array; ``"human"``: the robot drawn in Meshcat (its address on
        ``self.meshcat``)."""
        if self.render_mode is None or self._sim is None:
            return None
        if self._renderer is None:
            self._renderer = (LineRenderer if self.render_mode == "rgb_array"
                              else MeshcatRenderer)()
        return self._renderer.draw(self.params, self.true_state(), self._ctx.get_time())

    @property
    def meshcat(self):
        """The Meshcat server of ``render_mode = "human"`` (None before the
        first render)."""
        return getattr(self._renderer, "meshcat", None)

    def close_episode(self) -> None:
        """Let the episode's diagram go (pydrake keeps a diagram of Python
        systems alive until it is released)."""
        if self._built is not None:
            self._sim = None
            self._built.release()
            self._built = None

    def close(self):
        """End the episode and close the renderer."""
        self.close_episode()
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def observation_bounds(params: BplirParams, observation: str) -> np.ndarray:
    """The largest magnitude of each observed signal (:data:`TURNS`,
    :data:`RATE_FACTOR`, :data:`G_FACTOR`); the observation is clipped to
    them."""
    p, m = params.plant, params.motor
    rate = math.sqrt(p.g / (p.l1 + p.l2))
    if m.envelope:
        rate = max(rate, m.max_voltage / (m.back_emf_constant * m.gear_ratio))
    rate *= RATE_FACTOR
    if observation == "estimate":
        return np.array([2 * math.pi * TURNS] * 2 + [rate] * 2)
    return np.array([rate] * 2 + [G_FACTOR * p.g] * 4)
