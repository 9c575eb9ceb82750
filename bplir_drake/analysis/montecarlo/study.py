"""A Monte Carlo study: its schema (base parameters, distributions over the
simulated robot and its world, samples, root seed) and its TOML file."""
from __future__ import annotations

import dataclasses as dc
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...io import Record, write_text_atomic
from ...params import (BLOCKS, BplirParams, ParameterError, from_dict, read_toml,
                      relative_files, to_dict)
from ..traverse.line import line_from_dict
from ...params.knocks import Knocks


class StudyRow(Record):
    """One sample of a study: its index and seed, the quantities drawn (by
    their ``block.field`` names) and the result fields (``outcome``,
    ``success``, ``capture_speed_mps``, ...), with ``error`` for a sample
    that raised; read as attributes (``row.outcome``) or as the columns of
    ``results.csv`` (``row["true_plant.m2"]``)."""


def study_rows(rows) -> list[StudyRow]:
    """``rows`` (any mappings: a study's, or a user's dicts) as
    :class:`StudyRow`s."""
    return [r if isinstance(r, StudyRow) else StudyRow(r) for r in rows]

DIST_KINDS = ("uniform", "normal", "truncnormal")
#: blocks a distribution may address (never the nominal model)
UNCERTAIN_BLOCKS = ("true_plant", "true_friction", "imu", "line_sensor", "motor", "scenario")
#: swing summary fields kept per sample
RESULT_FIELDS = ("outcome", "success", "swing_time_s", "capture_distance_m", "capture_speed_mps",
                 "closest_distance_m", "travel_m", "landing_error_m",
                 "landing_height_error_m", "fixed_gripper_open",
                 "peak_torque_Nm", "peak_motor_power_W", "energy_in_J",
                 "max_estimation_error_rad", "mirror_error_rad", "delay_identified_s",
                 "peak_voltage_V", "on_envelope_s")
#: traversal summary fields kept per sample of a traversal study (the worst
#: swing's figures under the swing fields' names)
TRAVERSE_FIELDS = ("outcome", "success", "obstacles_passed", "swings", "retries", "failed_swing",
                   "time_s", "distance_m", "speed_m_per_min", "energy_J", "energy_per_m_J",
                   "rest_time_s", "capture_speed_mps", "peak_capture_impulse_Ns",
                   "swing_time_s", "peak_torque_Nm", "peak_motor_power_W", "energy_in_J",
                   "peak_voltage_V", "peak_i2t_A2s", "max_estimation_error_rad", "fixed_gripper_open")
#: the fields a knocked traversal study keeps per sample beside those
#: (:func:`~..traverse.knocked.knock_totals`)
KNOCK_FIELDS = ("knocks", "fall", "fall_cause", "interlock_fall", "uptime", "knocks_swing",
                "knocks_pump", "knocks_catch", "knocks_retry", "knocks_damp", "knocks_hanging")
#: what a traversal sets itself from the line (a study may not draw it)
TRAVERSE_FIXED = ("scenario.grip_spacing", "scenario.incline_deg")
STUDY_FILE, RESULTS_FILE, SUMMARY_FILE = "study.toml", "results.csv", "summary.json"


class StudyError(ParameterError):
    """A study file or study directory is invalid (one-line message)."""


# ------------------------------------------------------------ distributions

@dataclass(frozen=True)
class Distribution:
    """One uncertain quantity ``name`` = ``"block.field"``."""

    name: str
    dist: str = "uniform"
    rel: float | None = None
    abs: float | None = None
    center: float | None = None
    clip: float = 2.0

    def __post_init__(self):
        where = f"uncertain.\"{self.name}\""
        if self.dist not in DIST_KINDS:
            raise StudyError(f"{where}: dist = '{self.dist}' is unknown; allowed: "
                             + ", ".join(DIST_KINDS))
        if (self.rel is None) == (self.abs is None):
            raise StudyError(f"{where}: give exactly one of rel (relative spread) or abs "
                             "(absolute spread)")
        spread = self.rel if self.rel is not None else self.abs
        if not _is_number(spread) or not math.isfinite(spread) or spread < 0:
            raise StudyError(f"{where}: spread = {spread!r} must be a finite number >= 0")
        if self.center is not None and (not _is_number(self.center)
                                        or not math.isfinite(self.center)):
            raise StudyError(f"{where}: center = {self.center!r} must be a finite number")
        if not _is_number(self.clip) or not (0 < self.clip <= 10):
            raise StudyError(f"{where}: clip = {self.clip!r} must lie in (0, 10] sigmas")
        _check_name(self.name)

    @property
    def block(self) -> str:
        """The parameter block the quantity lives in."""
        return self.name.split(".")[0]

    @property
    def field(self) -> str:
        """The field of the quantity in its block."""
        return self.name.split(".")[1]

    def draw(self, base_value: float, rng: np.random.Generator) -> float:
        """One draw around ``base_value`` (or ``center``) from ``rng``."""
        center = base_value if self.center is None else self.center
        scale = self.abs if self.abs is not None else self.rel * abs(center)
        if self.dist == "uniform":
            u = rng.uniform(-1.0, 1.0)
        elif self.dist == "normal":
            u = rng.standard_normal()
        else:  # truncated normal by rejection (clip >= a fraction of sigma)
            while True:
                u = rng.standard_normal()
                if abs(u) <= self.clip:
                    break
        return float(center + scale * u)

    def as_dict(self) -> dict:
        """The distribution as its TOML table."""
        d = {"dist": self.dist}
        for key in ("rel", "abs", "center"):
            if getattr(self, key) is not None:
                d[key] = getattr(self, key)
        if self.dist == "truncnormal":
            d["clip"] = self.clip
        return d


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _check_name(name: str) -> None:
    parts = name.split(".") if isinstance(name, str) else []
    if len(parts) != 2 or parts[0] not in UNCERTAIN_BLOCKS:
        hint = ""
        if len(parts) == 2 and parts[0] in ("plant", "friction"):
            hint = f" (the nominal model is what the controller uses; perturb true_{name})"
        raise StudyError(f"unknown uncertain parameter '{name}'{hint}; allowed: "
                         + ", ".join(f"{b}.<field>" for b in UNCERTAIN_BLOCKS))
    cls = BLOCKS[parts[0]]
    numeric = {f.name for f in dc.fields(cls) if "lo" in f.metadata}
    if parts[1] not in numeric:
        raise StudyError(f"unknown uncertain parameter '{name}'; numeric fields of "
                         f"[{parts[0]}]: " + ", ".join(sorted(numeric)))


def dissertation_distributions() -> tuple[Distribution, ...]:
    """Friction of both joints uniform within +/- 20 % of nominal (3.3)."""
    return tuple(Distribution(f"true_friction.{k}", "uniform", rel=0.2)
                 for k in ("fv1", "fv2", "fc1", "fc2"))


# ------------------------------------------------------------ study

@dataclass(frozen=True)
class Study:
    """A Monte Carlo study: base parameters, distributions, number of samples, root seed."""
    params: BplirParams = field(default_factory=BplirParams)
    distributions: tuple[Distribution, ...] = field(default_factory=dissertation_distributions)
    samples: int = 100
    seed: int = 0
    line: dict | None = None   # a traversal study: the line file's tables (``bplir traverse``)
    knocks: dict | None = None  # a knocked traversal study: its [knocks] table (params.knocks)

    def __post_init__(self):
        if isinstance(self.samples, bool) or not isinstance(self.samples, int) or self.samples < 1:
            raise StudyError(f"samples = {self.samples!r} must be a whole number >= 1")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise StudyError(f"seed = {self.seed!r} must be a whole number >= 0")
        names = [d.name for d in self.distributions]
        if len(set(names)) != len(names):
            raise StudyError("an uncertain parameter is listed twice")
        if self.knocks is not None:
            if self.line is None:
                raise StudyError("[knocks] knock traversals; a study with them needs a [line]")
            try:
                Knocks.from_dict(self.knocks)
            except ParameterError as exc:
                raise StudyError(f"[knocks]: {exc}") from None
        if self.line is not None:
            fixed = [n for n in names if n in TRAVERSE_FIXED]
            if fixed:
                raise StudyError(
                    f"uncertain '{fixed[0]}' cannot be drawn in a traversal study: the traversal "
                    "sets every swing's grip spacing and incline from the line and its plan; "
                    "allowed: any other uncertain parameter")

    @property
    def result_fields(self) -> tuple[str, ...]:
        """The summary fields each sample's row keeps."""
        if self.line is None:
            return RESULT_FIELDS
        return TRAVERSE_FIELDS + (KNOCK_FIELDS if self.knocks is not None else ())

    @property
    def knocking(self) -> Knocks | None:
        """The study's knocks (None: not knocked)."""
        return None if self.knocks is None else Knocks.from_dict(self.knocks)
    @property
    def names(self) -> list[str]:
        """The uncertain quantities' names, in order."""
        return [d.name for d in self.distributions]

    def with_(self, **kw) -> "Study":
        """A copy with fields replaced."""
        return dc.replace(self, **kw)

    def as_dict(self) -> dict:
        """The study as its TOML document."""
        d = {"samples": self.samples, "seed": self.seed,
             "parameters": to_dict(self.params),
             "uncertain": {d.name: d.as_dict() for d in self.distributions}}
        if self.line is not None:
            d["line"] = self.line
        if self.knocks is not None:
            d["knocks"] = self.knocks
        return d

    def identity(self) -> dict:
        """What fixes every sample's result (everything but the sample count)."""
        d = self.as_dict()
        d.pop("samples")
        return d


def study_from_dict(data: dict, source: str = "study", base_dir=None) -> Study:
    """A :class:`Study` from a parsed study document; errors name ``source``;
    its parameters' relative files are read from ``base_dir``."""
    if not isinstance(data, dict):
        raise StudyError(f"{source}: a study must be a table")
    allowed = {"samples", "seed", "parameters", "uncertain", "line", "knocks"}
    unknown = set(data) - allowed
    if unknown:
        raise StudyError(f"{source}: unknown key '{sorted(unknown)[0]}'; allowed: "
                         + ", ".join(sorted(allowed)))
    table = data.get("parameters", {})
    if not isinstance(table, dict):
        raise StudyError(f"{source}: [parameters] must be a table of parameter blocks")
    params = from_dict(table, base_dir=base_dir)
    unc = data.get("uncertain")
    if unc is None:
        dists = dissertation_distributions()
    else:
        if not isinstance(unc, dict):
            raise StudyError(f"{source}: [uncertain] must be a table of distributions")
        dists = []
        for name, spec in unc.items():
            if not isinstance(spec, dict):
                raise StudyError(f"{source}: uncertain.\"{name}\" must be a table "
                                 "(dist, rel|abs, center, clip)")
            extra = set(spec) - {"dist", "rel", "abs", "center", "clip"}
            if extra:
                raise StudyError(f"{source}: uncertain.\"{name}\": unknown key "
                                 f"'{sorted(extra)[0]}'; allowed: dist, rel, abs, center, clip")
            dists.append(Distribution(name, **spec))
        dists = tuple(dists)
    line = data.get("line")
    if line is not None:

        line_from_dict(line, f"{source} [line]",
                       max_incline_deg=params.traverse.max_incline_deg)  # validates
    knocks = data.get("knocks")
    if knocks is not None and not isinstance(knocks, dict):
        raise StudyError(f"{source}: [knocks] must be a table (rate, severity, joints)")
    return Study(params, dists, data.get("samples", 100), data.get("seed", 0), line, knocks)


def load_study(path) -> Study:
    """Read a study TOML file; errors are :class:`StudyError` naming the file."""
    path = Path(path)
    data = read_toml(path, "study file", StudyError)
    try:
        return study_from_dict(data, str(path), base_dir=path.parent)
    except StudyError:
        raise
    except ParameterError as exc:
        raise StudyError(f"{path}: {exc}") from None


def save_study(study: Study, path) -> None:
    """Write ``study`` as TOML at ``path`` (atomic), its parameters' files
    relative to its directory."""
    import tomli_w

    data = study.as_dict()
    data["parameters"] = relative_files(data["parameters"], Path(path).parent)
    write_text_atomic(path, tomli_w.dumps(data))


