"""The results table of a study directory: one CSV row per finished sample,
appended and flushed as samples finish, read back for resuming."""
from __future__ import annotations

import csv
import math
import os
from pathlib import Path

import numpy as np

from .study import Study, StudyError, StudyRow
from ...io import atomic_path

# ------------------------------------------------------------ result table

def columns(study: Study) -> list[str]:
    """The columns of a study's results CSV."""
    return ["index", "seed", *study.names, *study.result_fields, "error"]


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
    if col in ("outcome", "error", "fall_cause"):
        return text
    if col in ("success", "fixed_gripper_open", "fall", "interlock_fall"):
        return text == "true"
    return float(text) if text not in ("", "None") else math.nan


def check_header(path, header: list[str], cols: list[str]) -> None:
    """Refuse (``StudyError``) a results table whose header is not ``cols``:
    it is another study's."""
    if header != cols:
        raise StudyError(f"{path}: its columns do not match this study; use another output "
                         "directory (--out)")


def read_results(path, cols: list[str] | None = None) -> list[StudyRow]:
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
        if cols is not None:
            check_header(path, header, cols)
        for rec in reader:
            if len(rec) != len(header):
                continue  # a row cut short by an interruption
            try:
                rows.append(StudyRow({c: _parse(c, v) for c, v in zip(header, rec)}))
            except ValueError:
                continue
    return rows


class ResultWriter:
    """Appends one row per finished sample and flushes it to disk."""

    def __init__(self, path: Path, cols: list[str], existing: list[dict]):

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
        """Append one row and flush it to disk."""
        self._w.writerow([_fmt(row.get(c)) for c in self.cols])
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def close(self) -> None:
        """Close the file."""
        self._fh.close()


