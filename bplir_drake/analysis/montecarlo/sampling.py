"""The samples of a study: each sample's draws and seed from ``(study,
index)`` alone, its parameters, and running it into a result row."""
from __future__ import annotations

import dataclasses as dc
import math
import zlib
from typing import Any

import numpy as np

from ...io import raise_stop
from ...params import BplirParams
from .study import Study, StudyRow
from ..swing.swing_runner import SwingRunner
from ..traverse.line import line_from_dict
from ..traverse.traversal import run_traverse

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
_TRAVERSE_RUNNERS: dict = {}  # ... and the two of traversals (gripper 1 / gripper 2 holding)


def run_sample(study: Study, index: int) -> StudyRow:
    """One sample as a result row; never raises (errors are recorded)."""
    global _RUNNER

    if _RUNNER is None:
        _RUNNER = SwingRunner()
    row: dict[str, Any] = {"index": index, "seed": sample_seed(study.seed, index)}
    row.update(draw_values(study, index))
    try:
        p, seed, _ = sample_params(study, index)
        if study.line is not None:
            summary = run_traverse_sample(study, p, seed).sample_fields()
        else:
            summary = _RUNNER.run(p, seed=seed).summary
    except Exception as exc:  # impossible draw, unreachable line, integrator failure ...
        raise_stop()   # a signal's stop that a solver wrapped: the study ends, no error row
        return StudyRow(row | _error_fields(exc, study))
    row.update({k: summary[k] for k in study.result_fields})
    row["error"] = ""
    return StudyRow(row)


def run_traverse_sample(study: Study, params: BplirParams, seed: int, motion=False):
    """The traversal of a traversal study's sample (this process's runners;
    ``motion`` as :func:`~..traverse.run.run_traverse`: not kept in a study)."""

    if not _TRAVERSE_RUNNERS:
        _TRAVERSE_RUNNERS.update({1: SwingRunner(), 2: SwingRunner()})
    line = line_from_dict(study.line, "study line",
                          max_incline_deg=params.traverse.max_incline_deg)
    return run_traverse(line, params, seed=seed, runners=_TRAVERSE_RUNNERS, motion=motion,
                        knocks=study.knocking)


def error_text(exc: BaseException) -> str:
    """An exception as one line of at most 300 characters, for a result row."""
    return " ".join(f"{type(exc).__name__}: {exc}".split())[:300]


def _error_fields(exc: BaseException, study: Study) -> dict:
    return {k: math.nan for k in study.result_fields} | {
        "outcome": "error", "success": False, "fixed_gripper_open": False,
        "error": error_text(exc)}


