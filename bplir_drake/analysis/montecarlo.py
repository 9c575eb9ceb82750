"""Monte Carlo robustness studies of the brachiation swing.

A *study* is a scenario (a base parameter set), distributions over uncertain
quantities of the simulated robot, its sensors and its environment, a number
of samples and a root seed.  Sample ``k`` is fully determined by
``(study, k)``: its parameter draws come from
``default_rng([root_seed, k, crc32(name)])`` (one stream per quantity, so
adding a quantity does not change the others) and its swing seed (sensor
noise, gusts) from ``SeedSequence([root_seed, k])``.  Results therefore do
not depend on the number of workers or the order samples finish in, and any
sample can be replayed exactly (:func:`sample_params`).

Controllers and estimators keep the nominal model: distributions may only
address the simulated robot (``true_plant``, ``true_friction``), the sensors
(``imu``), the motor hardware (``motor``) and the scenario (wind, gusts,
grip spacing, incline, ...).

Study file (TOML)::

    samples = 1000
    seed = 0
    [parameters]                  # a parameter set, as for --config
    preset = "dissertation"
    [parameters.scenario]
    incline_deg = 0.0
    [uncertain."true_friction.fv1"]
    dist = "uniform"              # uniform | normal | truncnormal
    rel = 0.2                     # half-width (uniform) or sigma, relative to the base value
    # abs = 0.03                  # ... or absolute; center = x overrides the base value
    # clip = 2.0                  # truncnormal: truncated at +/- clip sigma

Without ``[uncertain]`` the dissertation's study is used: the four friction
coefficients uniform within +/- 20 % of nominal (3.3).

Execution (:func:`run_study`): a local process pool (all cores by default)
or a Dask cluster; one CSV row is appended per finished sample, so an
interrupted study resumes without recomputing finished samples; a sample that
raises is recorded with its error and the study goes on.
"""
from __future__ import annotations

import csv
import dataclasses as dc
import math
import os
import time
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable

import numpy as np

from ..io import write_json_atomic, write_text_atomic
from ..params import BLOCKS, BplirParams, ParameterError, from_dict, read_toml, to_dict

DIST_KINDS = ("uniform", "normal", "truncnormal")
#: blocks a distribution may address (never the nominal model)
UNCERTAIN_BLOCKS = ("true_plant", "true_friction", "imu", "motor", "scenario")
#: swing summary fields kept per sample
RESULT_FIELDS = ("outcome", "success", "swing_time_s", "capture_distance_m", "capture_speed_mps",
                 "closest_distance_m", "travel_m", "fixed_gripper_open", "peak_torque_Nm",
                 "peak_motor_power_W", "energy_in_J", "max_estimation_error_rad",
                 "mirror_error_rad")
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
        return self.name.split(".")[0]

    @property
    def field(self) -> str:
        return self.name.split(".")[1]

    def draw(self, base_value: float, rng: np.random.Generator) -> float:
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
    params: BplirParams = field(default_factory=BplirParams)
    distributions: tuple[Distribution, ...] = field(default_factory=dissertation_distributions)
    samples: int = 100
    seed: int = 0

    def __post_init__(self):
        if isinstance(self.samples, bool) or not isinstance(self.samples, int) or self.samples < 1:
            raise StudyError(f"samples = {self.samples!r} must be a whole number >= 1")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise StudyError(f"seed = {self.seed!r} must be a whole number >= 0")
        names = [d.name for d in self.distributions]
        if len(set(names)) != len(names):
            raise StudyError("an uncertain parameter is listed twice")

    @property
    def names(self) -> list[str]:
        return [d.name for d in self.distributions]

    def with_(self, **kw) -> "Study":
        return dc.replace(self, **kw)

    def as_dict(self) -> dict:
        return {"samples": self.samples, "seed": self.seed,
                "parameters": to_dict(self.params),
                "uncertain": {d.name: d.as_dict() for d in self.distributions}}

    def identity(self) -> dict:
        """What fixes every sample's result (everything but the sample count)."""
        d = self.as_dict()
        d.pop("samples")
        return d


def study_from_dict(data: dict, source: str = "study") -> Study:
    if not isinstance(data, dict):
        raise StudyError(f"{source}: a study must be a table")
    allowed = {"samples", "seed", "parameters", "uncertain"}
    unknown = set(data) - allowed
    if unknown:
        raise StudyError(f"{source}: unknown key '{sorted(unknown)[0]}'; allowed: "
                         + ", ".join(sorted(allowed)))
    table = data.get("parameters", {})
    if not isinstance(table, dict):
        raise StudyError(f"{source}: [parameters] must be a table of parameter blocks")
    params = from_dict(table)
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
    return Study(params, dists, data.get("samples", 100), data.get("seed", 0))


def load_study(path) -> Study:
    path = Path(path)
    data = read_toml(path, "study file", StudyError)
    try:
        return study_from_dict(data, str(path))
    except StudyError:
        raise
    except ParameterError as exc:
        raise StudyError(f"{path}: {exc}") from None


def save_study(study: Study, path) -> None:
    import tomli_w

    write_text_atomic(path, tomli_w.dumps(study.as_dict()))


# ------------------------------------------------------------ one sample

def sample_seed(root: int, index: int) -> int:
    """The swing seed of sample ``index`` (sensor noise, gusts)."""
    return int(np.random.SeedSequence([root, index]).generate_state(1, dtype=np.uint32)[0])


def pinned(params: BplirParams) -> BplirParams:
    """``params`` with the simulated robot set explicitly (``true_plant`` and
    ``true_friction`` = their current values), so the swing runner draws no
    friction of its own."""
    return params.with_(true_plant=params.simulated_plant,
                        true_friction=params.simulated_friction)


def base_value(params: BplirParams, name: str) -> float:
    """The value of ``"block.field"`` in ``params``."""
    block, fld = name.split(".")
    return float(getattr(getattr(params, block), fld))


def apply_values(params: BplirParams, values: dict[str, float]) -> BplirParams:
    """``params`` with every ``"block.field"`` of ``values`` replaced
    (validated: an impossible value raises :class:`ParameterError`)."""
    blocks: dict[str, dict[str, float]] = {}
    for name, value in values.items():
        block, fld = name.split(".")
        blocks.setdefault(block, {})[fld] = value
    return params.with_(**{b: dc.replace(getattr(params, b), **kv) for b, kv in blocks.items()})


def draw_values(study: Study, index: int) -> dict[str, float]:
    """The drawn value of every uncertain quantity of sample ``index``."""
    p = pinned(study.params)
    drawn = {}
    for d in study.distributions:
        rng = np.random.default_rng([study.seed, index, zlib.crc32(d.name.encode())])
        drawn[d.name] = d.draw(base_value(p, d.name), rng)
    return drawn


def sample_params(study: Study, index: int) -> tuple[BplirParams, int, dict[str, float]]:
    """(parameters, swing seed, drawn values) of sample ``index``.

    The simulated robot starts from the nominal model (:func:`pinned`, so the
    swing runner draws nothing more) and the study's draws are applied on
    top.  An impossible draw (e.g. a negative mass) raises
    :class:`ParameterError`.
    """
    drawn = draw_values(study, index)
    return apply_values(pinned(study.params), drawn), sample_seed(study.seed, index), drawn


_RUNNER = None  # this process's SwingRunner: one diagram serves every sample of a structure


def run_sample(study: Study, index: int) -> dict:
    """One sample as a result row; never raises (errors are recorded)."""
    global _RUNNER
    from .swing import SwingRunner

    if _RUNNER is None:
        _RUNNER = SwingRunner()
    row: dict[str, Any] = {"index": index, "seed": sample_seed(study.seed, index)}
    row.update(draw_values(study, index))
    try:
        p, seed, _ = sample_params(study, index)
        summary = _RUNNER.run(p, seed=seed).summary
    except Exception as exc:  # impossible draw, unreachable line, integrator failure ...
        return row | _error_fields(exc)
    row.update({k: summary[k] for k in RESULT_FIELDS})
    row["error"] = ""
    return row


def error_text(exc: BaseException) -> str:
    """An exception as one line of at most 300 characters, for a result row."""
    return " ".join(f"{type(exc).__name__}: {exc}".split())[:300]


def _error_fields(exc: BaseException) -> dict:
    return {k: math.nan for k in RESULT_FIELDS} | {
        "outcome": "error", "success": False, "fixed_gripper_open": False,
        "error": error_text(exc)}


# ------------------------------------------------------------ result table

def columns(study: Study) -> list[str]:
    return ["index", "seed", *study.names, *RESULT_FIELDS, "error"]


def _fmt(v) -> str:
    if v is None:
        return ""
    if isinstance(v, bool) or isinstance(v, np.bool_):
        return "true" if v else "false"
    if isinstance(v, (float, np.floating)):
        return repr(float(v))
    return str(v)


def _parse(col: str, text: str):
    if col in ("index", "seed"):
        return int(text)
    if col in ("outcome", "error"):
        return text
    if col in ("success", "fixed_gripper_open"):
        return text == "true"
    return float(text) if text not in ("", "None") else math.nan


def read_results(path, cols: list[str] | None = None) -> list[dict]:
    """Rows of a results CSV (complete rows only), parsed."""
    path = Path(path)
    if not path.exists():
        return []
    rows = []
    with path.open(newline="") as fh:
        reader = csv.reader(fh)
        header = next(reader, None)
        if header is None:
            return []
        if cols is not None and header != cols:
            raise StudyError(f"{path}: its columns do not match this study; use another --out")
        for rec in reader:
            if len(rec) != len(header):
                continue  # a row cut short by an interruption
            try:
                rows.append({c: _parse(c, v) for c, v in zip(header, rec)})
            except ValueError:
                continue
    return rows


class ResultWriter:
    """Appends one row per finished sample and flushes it to disk."""

    def __init__(self, path: Path, cols: list[str], existing: list[dict]):
        from ..io import atomic_path

        self.path, self.cols = path, cols
        # rewrite the valid rows (drops a line cut short by an interruption)
        # through a temporary file and a rename: the table is never half-written
        with atomic_path(path) as tmp:
            with tmp.open("w", newline="") as fh:
                w = csv.writer(fh)
                w.writerow(cols)
                for r in existing:
                    w.writerow([_fmt(r.get(c)) for c in cols])
        self._fh = path.open("a", newline="")
        self._w = csv.writer(self._fh)

    def write(self, row: dict) -> None:
        self._w.writerow([_fmt(row.get(c)) for c in self.cols])
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def close(self) -> None:
        self._fh.close()


# ------------------------------------------------------------ execution

def _pool_map(fn: Callable, args: list[tuple], workers: int) -> Iterable:
    """Yield fn(*a) as they finish, in a process pool (or inline).

    Workers are forked where the platform allows it (no re-import of the
    caller's script, no pydrake start-up per worker); each sample builds its
    own diagram, so no Drake object crosses a process boundary."""
    if workers <= 1:
        for a in args:
            yield fn(*a)
        return
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor, as_completed

    method = "fork" if "fork" in mp.get_all_start_methods() else "spawn"
    ex = ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context(method))
    futures = [ex.submit(fn, *a) for a in args]
    finished = False
    try:
        for fut in as_completed(futures):
            yield fut.result()
        finished = True
    finally:
        if finished:
            ex.shutdown(wait=True)
        else:  # interrupted: do not wait for the samples still running
            procs = list(getattr(ex, "_processes", {}).values())
            ex.shutdown(wait=False, cancel_futures=True)
            for proc in procs:
                proc.terminate()


def _dask_map(fn: Callable, args: list[tuple], scheduler: str | None, workers: int) -> Iterable:
    """Yield fn(*a) as they finish on a Dask cluster: an existing one at
    ``scheduler`` or a LocalCluster of ``workers`` single-threaded processes."""
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise StudyError("Dask is not installed; install the extra: pip install "
                         "'bplir-drake[dask]'") from None
    cluster = None
    try:
        if scheduler:
            try:
                client = Client(scheduler, timeout="10s")
            except Exception as exc:  # noqa: BLE001 - Dask raises many kinds here
                msg = " ".join(str(exc).split())[:200]
                raise StudyError(f"cannot reach the Dask scheduler at {scheduler}: {msg}; "
                                 "expected an address like tcp://HOST:8786") from None
        else:
            cluster = LocalCluster(n_workers=max(1, workers), threads_per_worker=1,
                                   processes=True, dashboard_address=None)
            client = Client(cluster)
        with client:
            futures = [client.submit(fn, *a, pure=False) for a in args]
            for fut in as_completed(futures):
                yield fut.result()
    finally:
        if cluster is not None:
            cluster.close()


def map_jobs(fn: Callable, args: list[tuple], *, workers: int = 0, dask: bool = False,
             scheduler: str | None = None, progress: bool = False,
             desc: str = "samples") -> Iterable:
    """Run ``fn(*a)`` for every ``a``; yields results as they finish."""
    workers = workers or os.cpu_count() or 1
    if dask or scheduler:
        it = _dask_map(fn, args, scheduler, workers)
    else:
        it = _pool_map(fn, args, min(workers, max(1, len(args))))
    if progress:
        from tqdm import tqdm

        it = tqdm(it, total=len(args), desc=desc, unit="swing", leave=False)
    yield from it


def prepare_out(study: Study, out: Path) -> list[dict]:
    """Create or reopen a study directory; return the rows already done.

    A directory holding a different study (other than its sample count) is
    refused rather than mixed with new results.
    """
    out.mkdir(parents=True, exist_ok=True)
    saved = out / STUDY_FILE
    if saved.exists():
        old = load_study(saved)
        if old.identity() != study.identity():
            raise StudyError(f"{out} holds results of a different study; use another --out "
                             "or remove the directory")
    save_study(study, saved)
    return read_results(out / RESULTS_FILE, columns(study))


def run_study(study: Study, out, *, workers: int = 0, dask: bool = False,
              scheduler: str | None = None, progress: bool = False) -> dict:
    """Run (or resume) ``study`` into directory ``out``; returns the summary
    (also written to ``summary.json``).  Results: ``results.csv``."""
    out = Path(out)
    existing = prepare_out(study, out)  # finished rows are never deleted
    have = {r["index"] for r in existing}
    done = [r for r in existing if r["index"] < study.samples]
    todo = [(study, k) for k in range(study.samples) if k not in have]
    writer = ResultWriter(out / RESULTS_FILE, columns(study), existing)
    t0 = time.perf_counter()
    try:
        for row in map_jobs(run_sample, todo, workers=workers, dask=dask, scheduler=scheduler,
                            progress=progress):
            writer.write(row)
    finally:
        writer.close()
    rows = sorted(read_results(out / RESULTS_FILE), key=lambda r: r["index"])
    # the finished table in sample order: identical whatever the workers did
    ResultWriter(out / RESULTS_FILE, columns(study), rows).close()
    # a smaller -n than a previous run reports its first samples
    summary = summarize(study, [r for r in rows if r["index"] < study.samples])
    summary["run"] = {"computed_now": len(todo), "resumed_from": len(done),
                      "wall_time_s": time.perf_counter() - t0,
                      "workers": workers or os.cpu_count(),
                      "executor": "dask" if (dask or scheduler) else "process pool"}
    write_json_atomic(out / SUMMARY_FILE, summary)
    return summary


# ------------------------------------------------------------ statistics

def wilson_interval(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (scipy)."""
    if n == 0:
        return (math.nan, math.nan)
    from scipy.stats import binomtest

    ci = binomtest(successes, n).proportion_ci(confidence, method="wilson")
    return (float(ci.low), float(ci.high))


PERCENTILE_FIELDS = ("capture_speed_mps", "swing_time_s", "peak_torque_Nm", "peak_motor_power_W",
                     "energy_in_J", "max_estimation_error_rad")


def summarize(study: Study, rows: list[dict]) -> dict:
    ran = [r for r in rows if r["outcome"] != "error"]
    errors = [r for r in rows if r["outcome"] == "error"]
    k = sum(bool(r["success"]) for r in ran)
    n = len(ran)
    lo, hi = wilson_interval(k, n)
    outcomes: dict[str, int] = {}
    for r in rows:
        outcomes[r["outcome"]] = outcomes.get(r["outcome"], 0) + 1
    pct = {}
    for f in PERCENTILE_FIELDS:
        v = np.array([r[f] for r in ran if r[f] is not None and np.isfinite(r[f])], dtype=float)
        pct[f] = ({q: float(np.percentile(v, int(q[1:]))) for q in ("p5", "p50", "p95")}
                  | {"max": float(v.max())}) if v.size else {}
    return {
        "samples": len(rows),
        "samples_requested": study.samples,
        "seed": study.seed,
        "successes": k,
        "success_rate": k / n if n else math.nan,
        "success_rate_ci95": [lo, hi],
        "ci_method": "Wilson score, 95 %, over samples that ran (errors excluded)",
        "outcomes": outcomes,
        "failed_samples": [{"index": r["index"], "seed": r["seed"], "error": r["error"]}
                           for r in errors],
        "unsuccessful_samples": [{"index": r["index"], "outcome": r["outcome"],
                                  "capture_speed_mps": r["capture_speed_mps"]}
                                 for r in ran if not r["success"]],
        "fixed_gripper_opened_early": sum(bool(r["fixed_gripper_open"]) and not r["success"]
                                          for r in rows),
        "percentiles": pct,
        "uncertain": {d.name: d.as_dict() for d in study.distributions},
        "incline_deg": study.params.scenario.incline_deg,
        "controller": study.params.controller.preset,
    }


def influence(study: Study, rows: list[dict]) -> dict[str, float]:
    """How strongly each uncertain quantity drives the result: |correlation|
    with success when both outcomes occur, else with the capture speed."""
    ran = [r for r in rows if r["outcome"] != "error"]
    succ = np.array([float(r["success"]) for r in ran])
    if 0 < succ.sum() < len(succ):
        target = succ
    else:
        target = np.array([r["capture_speed_mps"] for r in ran], dtype=float)
    out = {}
    for name in study.names:
        x = np.array([r[name] for r in ran], dtype=float)
        ok = np.isfinite(x) & np.isfinite(target)
        if ok.sum() > 2 and np.std(x[ok]) > 0 and np.std(target[ok]) > 0:
            out[name] = float(abs(np.corrcoef(x[ok], target[ok])[0, 1]))
        else:
            out[name] = 0.0
    return out


def replay(study_dir, index: int):
    """Re-run sample ``index`` of a study directory: (SwingResult, recorded row or None)."""
    from .swing import run_swing

    study_dir = Path(study_dir)
    if not (study_dir / STUDY_FILE).exists():
        raise StudyError(f"{study_dir} is not a study directory (no {STUDY_FILE})")
    study = load_study(study_dir / STUDY_FILE)
    if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < study.samples:
        raise StudyError(f"--sample {index} is out of range; allowed 0..{study.samples - 1}")
    p, seed, _ = sample_params(study, index)
    recorded = next((r for r in read_results(study_dir / RESULTS_FILE) if r["index"] == index),
                    None)
    return run_swing(p, seed=seed), recorded
