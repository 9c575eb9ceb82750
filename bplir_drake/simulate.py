"""Running built diagrams: simulator set-up, initial state, log extraction."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.analysis import ResetIntegratorFromFlags

from .io import HUNG_PLUGIN, WallClockLimit, wall_clock_limit


class SimulationError(RuntimeError):
    """The integrator failed (step size underflow, NaN state ...)."""


#: the names of the signals in the logs of the package's diagrams (a log
#: not named here calls its columns ``x[i]``)
SIGNAL_NAMES = {
    "state": ("q1", "q2", "q1d", "q2d"), "estimate": ("q1", "q2", "q1d", "q2d"),
    "torque": ("torque",), "power": ("power",), "current": ("current",),
    "voltage": ("voltage",), "electrical_power": ("electrical_power",),
    "tripped": ("tripped",), "friction": ("f1", "f2"), "command": ("torque_command",),
    "imu": ("gyro1", "gyro2", "acc1_x", "acc1_y", "acc2_x", "acc2_y"),
    "reference": ("q2_ref",), "delay_fit": ("delay_steps", "fit_ratio"), "v": ("v",),
    "blend_end": ("blend_end", "blend_floor")}


@dataclass
class Log:
    """A logged signal: times ``t`` (N,) and ``data`` (N, n) -- one row per
    sample, the transpose of Drake's ``VectorLog.data()`` -- with its
    columns' ``names``."""

    t: np.ndarray
    data: np.ndarray
    names: tuple[str, ...] = ()

    def __post_init__(self):
        if not self.names:
            n = self.data.shape[1] if self.data.ndim == 2 else 1
            self.names = tuple(f"x[{i}]" for i in range(n))

    def __getitem__(self, name: str) -> np.ndarray:
        """One named signal, (N,)."""
        if name not in self.names:
            raise KeyError(f"no signal '{name}' in this log; it has {', '.join(self.names)}")
        return self.data[:, self.names.index(name)]

    def to_columns(self) -> dict[str, np.ndarray]:
        """``{"t": ..., name: ...}``: a table's columns, e.g. for
        ``pandas.DataFrame(log.to_columns())``."""
        return {"t": self.t} | {n: self.data[:, i] for i, n in enumerate(self.names)}

    def at(self, t) -> np.ndarray:
        """The signal linearly interpolated at times ``t``: (len(t), n)."""
        return np.column_stack([np.interp(t, self.t, self.data[:, i])
                                for i in range(self.data.shape[1])])

    @classmethod
    def from_logger(cls, logger, context, names=()) -> "Log":
        """The log of a Drake logger (or TickLogger) in ``context``."""
        if hasattr(logger, "arrays"):  # TickLogger
            return cls(*logger.arrays(context), names=tuple(names))
        log = logger.FindLog(context)
        return cls(np.array(log.sample_times()), np.array(log.data()).T, tuple(names))


def make_simulator(built, q0, v0=(0.0, 0.0), *, accuracy: float = 1e-6,
                   integrator: str = "runge_kutta3", max_step: float = 0.01, set_context=None):
    """A simulator of ``built`` on a fresh context, with the plant at
    (q0, v0) (rad, rad/s; ``q0 = None``: ``set_context`` sets the state).

    ``set_context(context)``, when given, writes anything else into the
    fresh context (e.g. a Monte Carlo sample) before the simulator is
    initialised.  Error-controlled RK3 at accuracy 1e-6 handles the smoothed
    Coulomb friction (b = 0.01) well; ``max_step`` (s)
    bounds the step.
    """
    sim = Simulator(built.diagram)
    ctx = sim.get_mutable_context()
    if set_context is not None:
        set_context(ctx)
    if q0 is not None:   # else set_context wrote the state (a plant other than a MultibodyPlant)
        pctx = built.plant.GetMyMutableContextFromRoot(ctx)
        built.plant.SetPositions(pctx, np.asarray(q0, dtype=float))
        built.plant.SetVelocities(pctx, np.asarray(v0, dtype=float))
    ResetIntegratorFromFlags(sim, integrator, max_step)
    integ = sim.get_mutable_integrator()
    integ.set_target_accuracy(accuracy)
    sim.Initialize()
    return sim


def run(sim, duration: float, wall_limit: float | None = None,
        what: str = "the simulation", hint: str = "a stiff robot or a hung plug-in?") -> None:
    """Advance ``sim`` by ``duration``; integrator failures (and a callback's
    ``sys.exit``) become :class:`SimulationError`, and past ``wall_limit``
    seconds of wall-clock time :class:`WallClockLimit` is raised."""
    _advance(sim, sim.get_context().get_time() + duration, wall_limit, what, hint)


def _advance(sim, end: float, wall_limit, what: str, hint: str) -> None:
    """``sim.AdvanceTo(end)`` within ``wall_limit``; a failure inside is
    :class:`SimulationError` naming ``what`` and the time (a
    :class:`WallClockLimit` a C++ callback wrapped is raised as itself)."""
    try:
        with wall_clock_limit(wall_limit, what, hint):
            sim.AdvanceTo(end)
    except WallClockLimit:
        raise
    except (RuntimeError, SystemExit) as exc:
        _failed(sim, exc, what)


def _failed(sim, exc: BaseException, what: str):
    """Raise the :class:`SimulationError` (or the :class:`WallClockLimit` a C++
    callback wrapped) of a simulation that ``exc`` ended."""
    if isinstance(exc.__context__, WallClockLimit):   # raised inside a C++ callback
        raise exc.__context__ from None
    t = sim.get_context().get_time()
    if isinstance(exc, SystemExit):   # a plug-in's sys.exit() inside a Drake callback
        raise SimulationError(f"{what} failed at t = {t:.4f} s: a plug-in or callback called "
                              f"sys.exit({exc.code!r})") from None
    raise SimulationError(f"{what} failed at t = {t:.4f} s: {exc}") from None


def logs(built, sim) -> dict[str, Log]:
    """Every logger of ``built`` in the simulator's context, by name."""
    ctx = sim.get_context()
    return {name: Log.from_logger(lg, ctx, SIGNAL_NAMES.get(name, ()))
            for name, lg in built.loggers.items()}


def run_until_outcome(sim, built, max_time: float, wall_limit: float | None = None,
                      what: str = "the swing") -> str:
    """Advance until the gripper interlock reports an outcome (its update
    ends the simulation) or ``max_time`` (plus two interlock periods);
    past ``wall_limit`` seconds of wall-clock time :class:`WallClockLimit`
    is raised (naming ``what``)."""
    lock = built.systems["interlock"]
    _advance(sim, max_time + 2 * lock.period, wall_limit, what, HUNG_PLUGIN)
    return lock.outcome(sim.get_context())
