"""The rows of a study's ``results.csv`` read back for resuming, checked cell
by cell: each a whole row of the header's cells, its index and seed whole
numbers, its drawn quantities the values its sample draws, its flags true
or false, its outcome one a sample can have and agreeing with its
success, and its figures numbers in their ranges.  A row that fails is
damaged: it is dropped and its sample run again (:func:`read_checked`)."""
from __future__ import annotations

import csv
import math
from pathlib import Path

from ...systems.gripper import OUTCOMES as SWING_OUTCOMES
from ..traverse.traverse_result import OUTCOMES as TRAVERSE_OUTCOMES
from .sampling import draw_values, sample_seed
from .store import _parse, check_header
from .study import KNOCK_FIELDS, Study, StudyRow
from ..traverse.knocked import RECOVERY_ENDS

#: the outcomes a swing sample and a traversal sample can end with, and the
#: one each calls a success
SAMPLE_OUTCOMES = {False: (set(SWING_OUTCOMES) - {"swinging"} | {"error"}, "captured"),
                   True: (set(TRAVERSE_OUTCOMES), "passed")}

#: the ranges of a sample's figures by their unit (the column's suffix):
#: wide enough for any robot the parameters allow, narrow enough that a
#: hand-edited 1e300 is not summarised
FIGURE_RANGES = {"_mps": (0.0, 1e3), "_s": (0.0, 1e5), "_m": (-1e4, 1e4), "_Nm": (0.0, 1e5),
                 "_W": (-1e7, 1e7), "_J": (-1e9, 1e9), "_rad": (0.0, 1e3), "_V": (0.0, 1e4),
                 "_A2s": (0.0, 1e9), "_Ns": (0.0, 1e5), "_m_per_min": (-1e4, 1e4)}

#: whole-number figures of a traversal sample (nan where none)
COUNTS = ("obstacles_passed", "swings", "retries", "failed_swing") + tuple(
    f for f in KNOCK_FIELDS if f.startswith("knocks"))

FLAGS = ("success", "fixed_gripper_open", "fall", "interlock_fall")


def _figure_range(column: str) -> tuple[float, float]:
    """The range of a figure column (the longest unit suffix that matches)."""
    suffix = max((s for s in FIGURE_RANGES if column.endswith(s)), key=len, default=None)
    return FIGURE_RANGES[suffix] if suffix else (-1e6, 1e6)


def row_damage(study: Study, header: list[str], cells: list[str]) -> str | None:
    """What is wrong with one row of ``study``'s results (None: nothing)."""
    if len(cells) != len(header):
        return f"it has {len(cells)} cells, the header {len(header)}"
    row = dict(zip(header, cells))
    for name in ("index", "seed"):
        try:
            int(row[name])
        except ValueError:
            return f"its {name} {row[name][:40]!r} is not a whole number"
    for name in FLAGS:
        if name in row and row[name] not in ("true", "false"):
            return f"its {name} {row[name][:40]!r} is not true or false"
    traverse = study.line is not None
    allowed, good = SAMPLE_OUTCOMES[traverse]
    if row["outcome"] not in allowed:
        return f"its outcome {row['outcome'][:40]!r} is not one a sample can have"
    if (row["success"] == "true") != (row["outcome"] == good):
        return f"its success {row['success']} disagrees with its outcome {row['outcome']!r}"
    k = int(row["index"])
    if k < 0 or int(row["seed"]) != sample_seed(study.seed, k):
        return None   # not this study's row: the resume refuses the table (checked_rows)
    drawn = draw_values(study, k)
    for name in study.names:
        problem = _drawn(row[name], drawn.get(name))
        if problem:
            return f"its {name} {problem}"
    if "fall_cause" in row and row["fall_cause"] not in allowed | {""} | set(RECOVERY_ENDS):
        return f"its fall_cause {row['fall_cause'][:40]!r} is not an outcome a traversal has"
    for name in study.result_fields:
        if name in FLAGS or name in ("outcome", "fall_cause"):
            continue
        problem = _figure(name, row[name])
        if problem:
            return f"its {name} {problem}"
    return None


def _drawn(text: str, value) -> str | None:
    """What is wrong with a drawn quantity's cell (None: it is the draw)."""
    try:
        x = float(text)
    except ValueError:
        return f"{text[:40]!r} is not a number"
    if value is None or not math.isclose(x, value, rel_tol=1e-12, abs_tol=1e-15):
        return f"{x:g} is not the value its sample draws"
    return None


def _figure(name: str, text: str) -> str | None:
    """What is wrong with a figure's cell (None: empty, nan or in range)."""
    if text in ("", "None", "nan"):
        return None
    try:
        x = float(text)
    except ValueError:
        return f"{text[:40]!r} is not a number"
    if name in COUNTS:
        return None if x == int(x) and 0 <= x <= 1e6 else f"{x:g} is not a count"
    lo, hi = _figure_range(name)
    return None if lo <= x <= hi else f"{x:g} is outside [{lo:g}, {hi:g}]"


def read_checked(study: Study, path: Path, cols: list[str]) -> tuple[list[StudyRow], list[str]]:
    """(the whole rows of ``path``, parsed; a line for each damaged row:
    which line and why).  A header other than ``cols`` is refused
    (``StudyError``): the table is another study's."""
    if not path.exists():
        return [], []
    rows, damaged = [], []
    with path.open(newline="") as fh:
        reader = csv.reader(fh)
        header = next(reader, None)
        if header is None:
            return [], []
        check_header(path, header, cols)
        for line, cells in enumerate(reader, 2):
            why = row_damage(study, header, cells)
            if why is None:
                try:
                    rows.append(StudyRow({c: _parse(c, v) for c, v in zip(header, cells)}))
                    continue
                except ValueError as exc:
                    why = str(exc)[:80]
            damaged.append(f"line {line}: {why}")
    return rows, damaged
