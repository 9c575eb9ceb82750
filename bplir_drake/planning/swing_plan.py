"""What a swing plan is, independent of how it was made: the sampled plan
(:class:`SwingPlan`), the target it ends at and the limits it keeps (the
motor's envelope as the planner holds it, the torque it may use).  The
planner (:mod:`.plan`) and the plan libraries (:mod:`.plan_library`)
both build on it."""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..io import Result
from ..params import BplirParams
from ..params.follow import robot_scales
from ..systems.plant import initial_configuration, kinetic_energy, potential_energy
from .figure import plot_plan


#: smallest Coulomb smoothing velocity the planner uses (rad/s)
PLAN_FRICTION_SMOOTHING = 0.2


#: the planner's price of time in the robot's own units: its cost
#: ``int tau^2 dt + w T`` over ``Q0^2 T0`` (torque scale ``Q0 = m g L``, time
#: scale ``T0 = sqrt(L/g)``, reach ``L = l1 + l2``) is
#: ``int (tau/Q0)^2 d(t/T0) + PLAN_TIME_PRICE T/T0``, so robots alike in shape
#: get plans alike in shape (:func:`plan_time_weight`); its value is the
#: dissertation robot's price, w = 1 N^2 m^2 at m g L = 100.258 N m
PLAN_TIME_PRICE = 9.948646e-5


def plan_time_weight(plant) -> float:
    """The planner's weight ``w`` on a plan's duration for the robot
    ``plant`` (N^2 m^2 s / s): :data:`PLAN_TIME_PRICE` ``(m g L)^2``, to six
    significant digits (finer than the solver's tolerance tells)."""
    q0 = robot_scales(plant)[1]
    return float(f"{PLAN_TIME_PRICE * q0 * q0:.6g}")


#: how far beyond its torque limit a stored plan's torque may reach (relative:
#: the solver's constraint tolerance and the dense samples between knots)
PLAN_TORQUE_SLACK = 1e-3

#: how far beyond its power limit a stored plan's dense samples may reach
#: (relative): the limit holds at the knots, the cubic between them swings
#: past it (by up to 6 % in the shipped plans)
PLAN_POWER_SLACK = 0.25

#: the shortest time between two samples of a plan (s): finer than any
#: simulator step, and the least time Drake's trajectories can tell apart
#: by many orders of magnitude
MIN_PLAN_STEP = 1e-6

#: the plan's fields that are flags, words and numbers, in its stored meta
PLAN_FLAGS, PLAN_WORDS = ("solved", "feasible"), ("solver", "status")
PLAN_NUMBERS = ("incline_deg", "torque_limit", "power_limit", "tolerance", "voltage_limit",
                "voltage_share", "resistance", "emf_per_rate", "torque_per_amp")


@dataclass
class SwingPlan(Result):
    """A planned swing, sampled densely from the collocation solution."""

    times: np.ndarray          # (n,)
    states: np.ndarray         # (n, 4): q1, q2, q1d, q2d
    torque: np.ndarray         # (n,)
    friction: np.ndarray       # (n, 2): friction torques f1, f2 of the planning model
    solved: bool               # the solver reported optimality
    feasible: bool             # every constraint holds within ``tolerance``
    solver: str
    incline_deg: float
    torque_limit: float
    power_limit: float
    tolerance: float
    voltage_limit: float = math.inf   # the driver's largest output voltage (V)
    voltage_share: float = 1.0        # the share of it the knots may use
    resistance: float = 0.0           # winding resistance (ohm)
    emf_per_rate: float = 0.0         # back-EMF per elbow rate, Km N (V s/rad)
    torque_per_amp: float = 1.0       # kt (N m/A)
    #: how the solver ended (:data:`SOLVER_STATUS`): "solved", "infeasible"
    #: (it proved the constraints cannot hold), "iteration limit", ...
    status: str = ""

    def table(self) -> dict:
        """The plan as time series: ``t_s``, the state, the elbow torque,
        the planning model's friction, the power and the winding voltage,
        a column each."""
        return {"t_s": self.times, "q1_rad": self.states[:, 0], "q2_rad": self.states[:, 1],
                "q1d_radps": self.states[:, 2], "q2d_radps": self.states[:, 3],
                "tau_Nm": self.torque, "friction1_Nm": self.friction[:, 0],
                "friction2_Nm": self.friction[:, 1], "power_W": self.power,
                "voltage_V": self.voltage}

    @property
    def duration(self) -> float:
        """Duration of the plan (s)."""
        return float(self.times[-1])

    @property
    def power(self) -> np.ndarray:
        """Mechanical elbow power along the plan (W)."""
        return self.torque * self.states[:, 3]

    @property
    def voltage(self) -> np.ndarray:
        """Winding voltage along the plan (V): ``R tau/kt + Km N q2'``."""
        return (self.resistance * self.torque / self.torque_per_amp
                + self.emf_per_rate * self.states[:, 3])

    @property
    def peak_voltage(self) -> float:
        """Largest absolute winding voltage of the plan (V)."""
        return float(np.max(np.abs(self.voltage)))

    @property
    def peak_torque(self) -> float:
        """Largest absolute torque of the plan (N m)."""
        return float(np.max(np.abs(self.torque)))

    @property
    def peak_power(self) -> float:
        """Largest absolute power of the plan (W)."""
        return float(np.max(np.abs(self.power)))

    @property
    def energy_in(self) -> float:
        """Work of the elbow motor, int tau q2' dt."""
        return float(np.trapezoid(self.power, self.times))

    @property
    def dissipated(self) -> float:
        """Work of friction, int (f1 q1' + f2 q2') dt."""
        f, v = self.friction, self.states[:, 2:4]
        return float(np.trapezoid(f[:, 0] * v[:, 0] + f[:, 1] * v[:, 1], self.times))

    @property
    def link1_reversals(self) -> int:
        """How often link 1 changes direction (0 for a single forward swing)."""
        w = self.states[:, 2]
        moving = w[np.abs(w) > 0.05]
        return int(np.count_nonzero(np.diff(np.sign(moving)) != 0))

    def check(self) -> None:
        """Raise ``ValueError`` saying what is wrong when this cannot be a
        swing's plan: finite times, increasing; states (n, 4), torque (n,)
        and friction (n, 2) at those times, finite; a feasible plan's
        torque within its torque limit."""
        t = np.asarray(self.times)
        if t.ndim != 1 or len(t) < 2:
            raise ValueError(f"its times have shape {t.shape}; a plan has at least 2")
        n = len(t)
        for name, shape in (("states", (n, 4)), ("torque", (n,)), ("friction", (n, 2))):
            got = np.shape(getattr(self, name))
            if got != shape:
                raise ValueError(f"its {name} have shape {got}; its {n} times need {shape}")
        for name in ("times", "states", "torque", "friction"):
            if not np.all(np.isfinite(getattr(self, name))):
                raise ValueError(f"its {name} have a missing or non-finite value")
        if np.any(np.diff(t) <= 0):
            raise ValueError(f"its times do not increase at sample {int(np.argmax(np.diff(t) <= 0)) + 2}")
        if t[0] != 0.0:
            raise ValueError(f"it starts at {t[0]:g} s; a plan starts at 0")
        if np.diff(t).min() < MIN_PLAN_STEP:
            raise ValueError(f"two of its samples are {np.diff(t).min():.3g} s apart; allowed "
                             f"at least {MIN_PLAN_STEP:g} s")
        self._check_meta()
        if self.feasible:
            self._check_limits()

    def _check_meta(self) -> None:
        """Raise ``ValueError`` unless the flags are booleans, the words
        strings and the numbers real numbers in their ranges."""
        for name in PLAN_FLAGS:
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise ValueError(f"its {name} is {getattr(self, name)!r}, not true or false")
        for name in PLAN_WORDS:
            if not isinstance(getattr(self, name), str):
                raise ValueError(f"its {name} is {getattr(self, name)!r}, not a word")
        for name in PLAN_NUMBERS:
            v = getattr(self, name)
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.floating)):
                raise ValueError(f"its {name} is {v!r}, not a number")
        ranges = {"incline_deg": (-90.0, 90.0), "voltage_share": (1e-9, 1.0)}
        for name, (lo, hi) in ranges.items():
            if not lo <= getattr(self, name) <= hi:
                raise ValueError(f"its {name} is {getattr(self, name)!r}; allowed [{lo:g}, {hi:g}]")
        for name in ("torque_limit", "power_limit", "voltage_limit", "torque_per_amp"):
            if not getattr(self, name) > 0:   # NaN fails too; inf is "no limit"
                raise ValueError(f"its {name} is {getattr(self, name)!r}; allowed (0, inf]")
        for name in ("resistance", "emf_per_rate"):
            if not 0 <= getattr(self, name) < math.inf:
                raise ValueError(f"its {name} is {getattr(self, name)!r}; allowed [0, inf)")
        if not (self.tolerance > 0 or (math.isnan(self.tolerance) and self.status == "external")):
            raise ValueError(f"its tolerance is {self.tolerance!r}; allowed (0, inf)")

    def _check_limits(self) -> None:
        """Raise ``ValueError`` when a feasible plan breaks its own torque,
        power or voltage limit."""
        if self.peak_torque > self.torque_limit * (1 + PLAN_TORQUE_SLACK):
            raise ValueError(f"its torque reaches {self.peak_torque:g} N m, beyond its limit "
                             f"{self.torque_limit:g} N m")
        if self.peak_power > self.power_limit * (1 + PLAN_POWER_SLACK):
            raise ValueError(f"its power reaches {self.peak_power:g} W, beyond its limit "
                             f"{self.power_limit:g} W")
        if self.peak_voltage > self.voltage_limit * (1 + PLAN_TORQUE_SLACK):
            raise ValueError(f"its winding voltage reaches {self.peak_voltage:g} V, beyond "
                             f"the driver's {self.voltage_limit:g} V")

    def objective(self, time_weight: float = 1.0) -> float:
        """The planner's cost ``int tau^2 dt + time_weight T`` on the dense
        samples (the collocation's own value up to the quadrature)."""
        return float(np.trapezoid(self.torque ** 2, self.times)) + time_weight * self.duration

    def torque_on_ticks(self, period: float) -> tuple[np.ndarray, np.ndarray]:
        """(times s, planned torque N m) every ``period`` from the start, as
        a driver of that period sees the plan."""
        t = np.arange(int(self.duration / period) + 1) * period
        return t, np.interp(t, self.times, self.torque)

    def plot(self, axes=None, *, params: BplirParams):
        """Angles, torque and power, and the robot on the line drawn with the
        nominal links and grip spacing of ``params`` (three axes)."""
        return plot_plan(self, params, axes)

    def summary(self) -> dict:
        """Feasibility, duration, peaks and limits as JSON-ready data."""
        return {"incline_deg": self.incline_deg, "solved": self.solved,
                "feasible": self.feasible, "solver": self.solver,
                "duration_s": self.duration, "peak_torque_Nm": self.peak_torque,
                "peak_motor_power_W": self.peak_power, "energy_in_J": self.energy_in,
                "friction_loss_J": self.dissipated, "link1_reversals": self.link1_reversals,
                "torque_limit_Nm": self.torque_limit, "power_limit_W": self.power_limit,
                "peak_voltage_V": self.peak_voltage if self.emf_per_rate else None,
                "voltage_limit_V": (self.voltage_limit if math.isfinite(self.voltage_limit)
                                    else None),
                "peak_elbow_rate_rad_s": float(np.max(np.abs(self.states[:, 3]))),
                "constraint_tolerance": self.tolerance, "solver_status": self.status}


#: a plan whose energy balance leaves more than this share of the energy it
#: exchanges unaccounted does not obey the robot's dynamics between its
#: knots (:func:`energy_balance`)
UNBALANCED_SHARE = 0.1


def energy_balance(plan: SwingPlan, plant) -> dict:
    """How well ``plan`` keeps the nominal robot ``plant``'s energy: the
    elbow's work ``int tau q2' dt`` (J), the friction's (J), the change of
    the robot's energy from start to end (J) and ``residual_share``, what
    the first less the second leaves unaccounted in the third as a share of
    the energy exchanged (the work's size plus the friction's).  A plan
    whose dynamics hold between its knots keeps it to the quadrature's
    error; one that gains energy the collocation's coarse steps lend it
    (a plan that pumps with too few knots) does not."""
    x = np.asarray(plan.states)
    energy = [kinetic_energy(s[:2], s[2:], plant) + potential_energy(s[:2], plant)
              for s in (x[0], x[-1])]
    work, loss = plan.energy_in, plan.dissipated
    residual = (energy[1] - energy[0]) - (work - loss)
    exchanged = abs(work) + abs(loss)
    return dict(work_J=work, friction_J=loss, change_J=energy[1] - energy[0],
                residual_J=residual, residual_share=abs(residual) / exchanged if exchanged
                else 0.0)


def plan_envelope(params: BplirParams) -> dict | None:
    """The motor's voltage envelope as the planner holds it (``None``
    without it): the driver's largest voltage, the share of it the knots
    may use, the winding resistance, the back-EMF per elbow rate and the
    torque per ampere (nominal motor)."""
    m = params.motor
    if not m.envelope:
        return None
    return dict(voltage=m.max_voltage, share=params.plan.voltage_share,
                resistance=m.resistance, emf_per_rate=m.back_emf_constant * m.gear_ratio,
                torque_per_amp=m.torque_per_amp)


def plan_friction(friction):
    """The friction the planner models: ``friction`` with its Coulomb
    smoothing widened to at least :data:`PLAN_FRICTION_SMOOTHING`."""
    return replace(friction, b=max(friction.b, PLAN_FRICTION_SMOOTHING))


def shifted_angles(fractions, states, q0, qT) -> np.ndarray:
    """``states`` with their angles shifted by ``(1 - s) (q0 - first) +
    s (qT - last)`` at the fraction ``s`` of the plan's duration
    (``fractions``, 0 to 1), so they start at ``q0`` and end at ``qT``;
    rates as they are."""
    s = np.asarray(fractions, dtype=float)
    states = np.array(states, dtype=float)
    states[:, :2] += (np.outer(1.0 - s, np.asarray(q0) - states[0, :2])
                      + np.outer(s, np.asarray(qT) - states[-1, :2]))
    return states


def plan_torque_limit(params: BplirParams) -> float:
    """The torque a plan may use (N m): ``plan.torque_share`` of the
    smallest of the controller's limit, the motor's and its peak current's."""
    m = params.motor
    return params.plan.torque_share * min(params.controller.torque_limit, m.torque_limit,
                                          m.torque_per_amp * m.i_peak)


def planned_target(params: BplirParams, end_depth: float = 0.0) -> np.ndarray:
    """The mirror target (7.1) of the nominal robot, turned about the pivot
    so that the free gripper rests ``end_depth`` below the line at the same
    distance along it."""

    sc = params.scenario
    D = sc.grip_spacing
    q = initial_configuration(math.hypot(D, end_depth), params.plant, 0.0)
    return np.array([-q[0] + math.radians(sc.incline_deg) - math.atan2(end_depth, D), -q[1]])


#: a plan from hanging at rest (``scenario.start``): the initial-guess
#: durations tried in turn (it pumps before it reaches, 3-6 s), its
#: collocation knots and SNOPT's limit on its minor iterations
HANGING_GUESSES = (3.0, 4.0, 5.0, 6.0)
HANGING_KNOTS = 61
HANGING_MINOR_ITERATIONS = 150_000


#: a pumping manoeuvre from the line (``scenario.manoeuvre = "pump"``): its
#: collocation knots (dense enough that a pump of several swings keeps the
#: robot's energy between them, :data:`UNBALANCED_SHARE`), and its
#: initial-guess durations in the robot's time unit sqrt(L/g), tried in turn
PUMP_KNOTS = 151
PUMP_GUESSES = (8.5, 10.5, 12.5)


def pump_guesses(plant) -> tuple[float, ...]:
    """:data:`PUMP_GUESSES` in seconds for the robot ``plant``."""
    t0 = robot_scales(plant)[0]
    return tuple(round(k * t0, 2) for k in PUMP_GUESSES)


def planned_for(plan: SwingPlan, inputs: dict) -> None:
    """Raise ``ValueError`` saying what differs when the stored ``plan``
    is not a plan of the planner's ``inputs`` (the key it is filed under):
    its incline, limits and tolerance, its duration within the longest
    allowed, its start at the start pose at rest within ten times the
    solver's tolerance, and the motor's envelope (its voltage share at
    most the one asked for)."""
    said = {"incline_deg": inputs["incline_deg"], "torque_limit": inputs["tau_max"],
            "power_limit": inputs["power"], "tolerance": inputs["tolerance"]}
    env = inputs.get("envelope")
    if env is not None:   # the share may be tighter: the planner tightens it where the
        if plan.voltage_share > env["share"] * (1 + 1e-12):   # voltage between knots is high
            raise ValueError(f"its voltage_share is {plan.voltage_share!r}, above the "
                             f"{env['share']!r} it is filed under")
        said |= {"voltage_limit": env["voltage"], "resistance": env["resistance"],
                 "emf_per_rate": env["emf_per_rate"], "torque_per_amp": env["torque_per_amp"]}
    for name, want in said.items():
        got = getattr(plan, name)
        if not math.isclose(got, want, rel_tol=1e-12, abs_tol=1e-12):
            raise ValueError(f"its {name} is {got!r}, but it is filed under {want!r}")
    if plan.duration > inputs["tmax"] * (1 + 1e-9):
        raise ValueError(f"it lasts {plan.duration:g} s; it was planned within "
                         f"{inputs['tmax']:g} s")
    start = np.r_[np.asarray(inputs["q0"], dtype=float), 0.0, 0.0]   # at rest
    off = float(np.max(np.abs(plan.states[0] - start)))
    if off > 10 * inputs["tolerance"]:
        raise ValueError(f"it starts {off:.3g} away from the start it is filed under")
