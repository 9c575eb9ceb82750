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

import contextlib
import os
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

from ...io import DictResult, Result, write_json_atomic
from ...labelled import study_dataset
from .executors import map_jobs
from .sampling import run_sample, sample_params
from .statistics import summarize
from .store import ResultWriter, columns, read_results
from .row_check import read_checked
from .study import RESULTS_FILE, STUDY_FILE, SUMMARY_FILE, Study, StudyError, load_study, save_study
from ..swing.swing_runner import run_swing
from .study_plots import plot_success_vs_parameters, study_figures
from .sampling import run_traverse_sample

def check_out(study: Study, out) -> None:
    """Refuse (``StudyError``) a directory that holds a different study
    (other than its sample count): its results are never mixed with new
    ones.  Nothing is written; callers check before any work."""
    saved = Path(out) / STUDY_FILE
    if saved.exists() and load_study(saved).identity() != study.identity():
        raise StudyError(f"{out} holds results of a different study; use another output "
                         "directory (--out) or remove this one")


def prepare_out(study: Study, out: Path) -> list[dict]:
    """Create or reopen a study directory (:func:`check_out`); return the
    rows already done."""
    check_out(study, out)
    out.mkdir(parents=True, exist_ok=True)
    saved = out / STUDY_FILE
    save_study(study, saved)
    rows, damaged = read_checked(study, out / RESULTS_FILE, columns(study))
    if damaged:   # dropped here, so run again
        more = f" (and {len(damaged) - 3} more)" if len(damaged) > 3 else ""
        warnings.warn(f"{out / RESULTS_FILE}: {len(damaged)} damaged "
                      f"row{'s' if len(damaged) > 1 else ''} run again: "
                      + "; ".join(damaged[:3]) + more, stacklevel=2)
    return checked_rows(study, rows, out)


def checked_rows(study: Study, rows: list[dict], out: Path) -> list[dict]:
    """The finished rows of a resumed study: a row repeated word for word is
    kept once; two different rows of one sample, or a row whose seed is not
    its sample's (another study's), are refused naming the sample."""
    by_index: dict[int, dict] = {}
    for row in rows:
        k = row.index
        if k < 0:
            raise StudyError(f"{out / RESULTS_FILE} holds a row of sample {k}; sample indices "
                             "run from 0: remove it (or the file) and run again")
        if k in by_index:
            if by_index[k] != row:
                raise StudyError(f"{out / RESULTS_FILE} holds two different rows of sample "
                                 f"{k}; remove one (or the file) and run again")
            continue
        if 0 <= k < study.samples and row.seed != sample_params(study, k)[1]:
            raise StudyError(f"{out / RESULTS_FILE}: the row of sample {k} has seed "
                             f"{row['seed']}, not this study's; it belongs to another study")
        by_index[k] = row
    return list(by_index.values())


@contextlib.contextmanager
def study_lock(out: Path):
    """Hold the study directory ``out`` exclusively (its ``.lock``, opened
    without following a link, records the holder's PID): a second run into
    the same directory is refused with the holder's PID while the first
    runs; the lock goes with the process, however it ends.  The file stays
    (removing it would let two runs lock two files), emptied of the PID
    when the run ends."""
    import fcntl

    out.mkdir(parents=True, exist_ok=True)
    fd = os.open(out / ".lock", os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.read(fd, 32).decode(errors="replace").strip() or "another process"
            raise StudyError(f"study directory {out} is in use by process {holder}; wait for "
                             "it to finish or choose another output directory (--out)") from None
        os.ftruncate(fd, 0)
        os.write(fd, str(os.getpid()).encode())
        try:
            yield
        finally:
            os.ftruncate(fd, 0)   # no PID of a process long gone in a finished study
    finally:
        os.close(fd)


def run_study(study: Study, out, *, workers: int = 0, dask: bool = False,
              scheduler: str | None = None, progress: bool = False) -> "StudySummary":
    """Run (or resume) ``study`` into directory ``out``; returns the summary
    (also written to ``summary.json``: a dict, and a result with ``plot()``
    and ``to_pandas()``, :class:`StudySummary`).  Results: ``results.csv``.  The
    directory is held exclusively while the study runs (:func:`study_lock`)."""
    out = Path(out)
    with study_lock(out):
        return _run_study(study, out, workers, dask, scheduler, progress)


def _run_study(study: Study, out: Path, workers: int, dask: bool, scheduler,
               progress) -> "StudySummary":
    """The body of :func:`run_study`, the directory held."""
    existing = prepare_out(study, out)  # finished rows are never deleted
    have = {r.index for r in existing}
    done = [r for r in existing if r.index < study.samples]
    todo = [(study, k) for k in range(study.samples) if k not in have]
    writer = ResultWriter(out / RESULTS_FILE, columns(study), existing)
    t0 = time.perf_counter()
    try:
        for row in map_jobs(run_sample, todo, workers=workers, dask=dask, scheduler=scheduler,
                            progress=progress,
                            unit="swings" if study.line is None else "traversals"):
            writer.write(row)
    finally:
        writer.close()
    rows = sorted(read_results(out / RESULTS_FILE), key=lambda r: r.index)
    # the finished table in sample order: identical whatever the workers did
    ResultWriter(out / RESULTS_FILE, columns(study), rows).close()
    # a smaller -n than a previous run reports its first samples
    kept = [r for r in rows if r.index < study.samples]   # no negative index: refused above
    summary = summarize(study, kept)
    summary["run"] = {"computed_now": len(todo), "resumed_from": len(done),
                      "wall_time_s": time.perf_counter() - t0,
                      "workers": workers or os.cpu_count(),
                      "executor": "dask" if (dask or scheduler) else "process pool"}
    write_json_atomic(out / SUMMARY_FILE, summary)
    return StudySummary(summary, StudyResult(study, kept))


def replay(study_dir, index: int):
    """Re-run sample ``index`` of a study directory: (SwingResult, or
    TraverseResult for a traversal study; recorded row or None)."""

    study_dir = Path(study_dir)
    if not (study_dir / STUDY_FILE).exists():
        raise StudyError(f"{study_dir} is not a study directory (no {STUDY_FILE})")
    study = load_study(study_dir / STUDY_FILE)
    rows = read_results(study_dir / RESULTS_FILE) if (study_dir / RESULTS_FILE).exists() else []
    kept = {r.index for r in rows}
    if isinstance(index, bool) or not isinstance(index, int) or not (
            0 <= index < study.samples or index in kept):
        extra = f" or a kept row ({max(kept)} is the last)" if kept and max(kept) >= study.samples \
            else ""
        raise StudyError(f"--sample {index} is out of range; allowed 0..{study.samples - 1}"
                         + extra)
    p, seed, _ = sample_params(study, index)
    recorded = next((r for r in rows if r.index == index), None)
    if study.line is not None:

        return run_traverse_sample(study, p, seed, motion=None), recorded
    return run_swing(p, seed=seed), recorded


@dataclass
class StudyResult(Result):
    """A study and its result rows (one dict per sample, sample order)."""

    study: Study
    rows: list

    @classmethod
    def load(cls, study_dir) -> "StudyResult":
        """The study and finished rows of a study directory."""
        study_dir = Path(study_dir)
        if not (study_dir / STUDY_FILE).exists():
            raise StudyError(f"{study_dir} is not a study directory (no {STUDY_FILE})")
        study = load_study(study_dir / STUDY_FILE)
        rows = sorted((r for r in read_results(study_dir / RESULTS_FILE, columns(study))
                       if r.index < study.samples), key=lambda r: r.index)
        return cls(study, rows)

    def summary(self) -> dict:
        """Success rate with its Wilson interval, outcomes, percentiles
        (:func:`~.statistics.summarize`)."""
        return summarize(self.study, self.rows)

    def plot(self, axes=None):
        """Success against each uncertain quantity (one axis per quantity)."""

        return plot_success_vs_parameters(self.study, self.rows, axes)

    def figures(self) -> dict:
        """Every figure of the study by file name (:func:`~.plots.study_figures`)."""

        return study_figures(self.study, self.rows)

    def table(self) -> list:
        """The result rows, one per sample."""
        return self.rows

    def to_xarray(self):
        """The rows as an ``xarray.Dataset`` over ``sample``, the drawn
        quantities and the seeds its coordinates (the ``xarray`` extra)."""
        return study_dataset(self.rows, self.study.names,
                             attrs={"root_seed": self.study.seed, "samples": self.study.samples})


class StudySummary(DictResult):
    """What :func:`run_study` returns: the dict ``summary.json`` holds and a
    result (``plot()``, ``to_pandas()`` of its rows) through the
    :class:`StudyResult` it summarises (``.result``)."""

    def __init__(self, summary: dict, result: StudyResult):
        super().__init__(summary)
        self.result = result

    def __reduce__(self):   # pickled as what it is, its result with it
        return (StudySummary, (dict(self), self.result))

    def plot(self, axes=None):
        """Success against each uncertain quantity (:meth:`StudyResult.plot`)."""
        return self.result.plot(axes)

    def table(self) -> list:
        """The study's rows, one per sample."""
        return self.result.rows

    def to_xarray(self):
        """The study's rows over ``sample`` (:meth:`StudyResult.to_xarray`)."""
        return self.result.to_xarray()
