"""Results as labelled arrays (xarray, the ``xarray`` extra): a result's
time series as a ``Dataset`` over ``time``, its rows as one over ``row``
-- or, for a study, over ``sample`` with the quantities each sample drew
(and its seed) as coordinates, so ``ds.where(ds["true_plant.m2"] > 1.6)``
selects by what was drawn."""
from __future__ import annotations

import numpy as np

#: the names a time column goes by in the package's tables
TIME_COLUMNS = ("t", "t_s", "time_s")


def _xarray():
    try:
        import xarray
    except ImportError:
        raise ImportError("to_xarray() needs xarray: pip install 'bplir-drake[xarray]'") \
            from None
    return xarray


def _column(values) -> np.ndarray:
    """A column as an array: numbers as floats, flags as booleans, words as objects."""
    arr = np.asarray(values)
    return arr if arr.dtype.kind in "fiub" else np.asarray(values, dtype=object)


def table_dataset(table, attrs: dict | None = None):
    """A result's :meth:`~bplir_drake.io.Result.table` as an
    ``xarray.Dataset``: a dict of columns over ``time`` (its time column
    the coordinate), a list of rows over ``row``."""
    xr = _xarray()
    if isinstance(table, dict):
        time = next((c for c in TIME_COLUMNS if c in table), None)
        n = len(next(iter(table.values()))) if table else 0
        coords = {"time": np.asarray(table[time], dtype=float)} if time else {"time": np.arange(n)}
        data = {k: ("time", _column(v)) for k, v in table.items() if k != time}
        return xr.Dataset(data, coords=coords, attrs=attrs or {})
    rows = [dict(r) for r in table]
    names = list(dict.fromkeys(k for r in rows for k in r))
    data = {k: ("row", _column([r.get(k) for r in rows])) for k in names}
    return xr.Dataset(data, coords={"row": np.arange(len(rows))}, attrs=attrs or {})


def study_dataset(rows, drawn: list[str], attrs: dict | None = None):
    """A study's rows as an ``xarray.Dataset`` over ``sample`` (the sample
    index): its result fields the data, the ``drawn`` quantities and the
    seed coordinates along ``sample``."""
    xr = _xarray()
    rows = [dict(r) for r in rows]
    names = list(dict.fromkeys(k for r in rows for k in r))
    index = np.asarray([r["index"] for r in rows], dtype=int)
    coords = {"sample": index}
    coords |= {k: ("sample", _column([r.get(k) for r in rows])) for k in ["seed", *drawn]}
    data = {k: ("sample", _column([r.get(k) for r in rows])) for k in names
            if k not in coords and k != "index"}
    return xr.Dataset(data, coords=coords, attrs=attrs or {})
