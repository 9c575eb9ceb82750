"""CSV files read as a stream: one line in memory at a time.

A log of millions of rows costs what its numbers cost (8 bytes each), not
what its text and Python's lists of strings cost.  The checks are those of
:func:`bplir_drake.io.read_text` (UTF-8, a byte-order mark accepted, no
binary or UTF-16 file) and of a well-formed table (a header, no repeated
name, every row as wide as the header); each problem raises the caller's
exception class with one line naming the file.
"""
from __future__ import annotations

import csv
import math
from array import array
from pathlib import Path
from typing import Iterator

from .io import text_lines


class LogError(ValueError):
    """A malformed or unusable log file (one-line message)."""


def csv_stream(path, what: str, error) -> tuple[list[str], Iterator[tuple[int, list[str]]]]:
    """(header, rows) of a CSV file: ``rows`` yields (line number, cells)
    lazily, blank lines skipped, each row checked to be as wide as the
    header."""
    path = Path(path)
    reader = csv.reader(text_lines(path, what, error))

    def advance():
        try:
            return next(reader)
        except csv.Error as exc:
            raise error(f"{what} {path} is not valid CSV: {exc}") from None

    try:
        first = advance()
    except StopIteration:
        raise error(f"{what} {path} is empty") from None
    header = [h.strip() for h in first]
    seen = set()
    for h in header:
        if h in seen:
            raise error(f"{what} {path}: column '{h}' appears twice in the header")
        seen.add(h)

    def body():
        while True:
            try:
                row = advance()
            except StopIteration:
                return
            if not row or all(not c.strip() for c in row):
                continue
            if len(row) != len(header):
                raise error(f"{what} {path} line {reader.line_num} has {len(row)} cells, the "
                            f"header has {len(header)}")
            yield reader.line_num, row

    return header, body()


def csv_rows(path, what: str, error) -> tuple[list[str], list[tuple[int, list[str]]]]:
    """(header, [(line number, cells)]) of a whole CSV file (small files:
    the rows are kept as text)."""
    header, rows = csv_stream(path, what, error)
    return header, list(rows)


def numeric_columns(path, what: str, required, error) -> tuple[dict, dict]:
    """Read a CSV file's numbers column by column, streaming.

    Returns (``required`` columns, further columns), each a dict of name to
    ``array('d')``.  Empty cells are NaN; a non-numeric cell in a required
    column raises ``error`` naming the line, in a further column it drops
    that column (a text column is ignored)."""
    path = Path(path)
    header, rows = csv_stream(path, what, error)
    missing = [c for c in required if c not in header]
    if missing:
        raise error(f"{what} {path} lacks column(s) {', '.join(missing)}; required: "
                    + ",".join(required))
    want = [(name, header.index(name)) for name in required]
    others = {h: i for i, h in enumerate(header) if h not in required}
    cols = {name: array("d") for name in required}
    extra = {h: array("d") for h in others}
    for lineno, row in rows:
        for name, i in want:
            cell = row[i].strip()
            try:
                cols[name].append(float(cell) if cell else math.nan)
            except ValueError:
                raise error(f"{what} {path} line {lineno} column {name}: '{cell[:40]}' is not "
                            "a number") from None
        for h in [h for h in extra]:
            cell = row[others[h]].strip()
            try:
                extra[h].append(float(cell) if cell else math.nan)
            except ValueError:
                del extra[h]   # a text column: ignored
    return cols, extra
