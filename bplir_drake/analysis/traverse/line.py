"""A stretch of line: its shape (incline along it) and its obstacles, read
from TOML.

Positions ``s`` are arc lengths along the conductor from the stretch's start
(m).  The incline ``alpha(s)`` (positive: rising in the direction of travel)
is given either as points ``[[s, deg], ...]`` joined linearly or as a
catenary (span, sag and where the stretch lies in the span); the line's
points ``(x, y)`` follow by integrating ``(cos alpha, sin alpha)``.  A
swing sees the line as straight between its two grips: the chord's length
and incline (:meth:`Line.chord`).

Line file::

    length = 8.0                  # m
    start = 1.5                   # front gripper at the start (m); the rear one a grip spacing behind
    incline = [[0.0, 0.0], [8.0, 0.0]]   # (s m, incline deg) points ...
    # [catenary]                  # ... or a catenary
    # span = 40.0                 # tower to tower (m, towers at equal height)
    # sag = 1.2                   # at mid-span (m)
    # offset = 1.0                # the stretch starts this far from the left tower (m)
    [[obstacles]]
    position = 2.5                # where the obstacle starts (m)
    width = 0.3                   # along the line (m)
    name = "spacer damper"        # optional
"""
from __future__ import annotations

import bisect
import functools
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...params import ParameterError, read_toml


class LineError(ParameterError):
    """A line file or a line is invalid or impossible (one-line message)."""


@dataclass(frozen=True)
class Obstacle:
    """An interval ``[start, start + width]`` of the line no gripper may clasp."""

    start: float
    width: float
    name: str = "obstacle"

    @property
    def end(self) -> float:
        """Where the obstacle ends (m)."""
        return self.start + self.width


@dataclass(frozen=True)
class Line:
    """A stretch of line: length (m), the incline table ``(s, alpha)`` (m,
    rad), obstacles sorted along it, the front gripper's start position (m)
    and the file's data (for the record)."""

    length: float
    s_table: np.ndarray
    incline_table: np.ndarray
    obstacles: tuple
    start: float
    data: dict = field(default_factory=dict)

    def incline_at(self, s) -> np.ndarray | float:
        """The line's incline (rad) at ``s``."""
        return np.interp(s, self.s_table, self.incline_table)

    def _grid(self):
        s = np.linspace(min(0.0, float(self.s_table[0])), max(self.length, float(self.s_table[-1])),
                        4001)
        a = self.incline_at(s)
        ds = np.diff(s)
        x = np.concatenate([[0.0], np.cumsum(ds * 0.5 * (np.cos(a[1:]) + np.cos(a[:-1])))])
        y = np.concatenate([[0.0], np.cumsum(ds * 0.5 * (np.sin(a[1:]) + np.sin(a[:-1])))])
        i0 = np.searchsorted(s, 0.0)
        return s, x - x[i0], y - y[i0]

    def point(self, s) -> np.ndarray:
        """The line's point(s) ``(x, y)`` at arc length ``s`` (x horizontal, y up,
        the stretch's start at the origin)."""
        g, x, y = self._grid()
        return np.stack([np.interp(s, g, x), np.interp(s, g, y)], axis=-1)

    def chord(self, s1: float, s2: float) -> tuple[float, float]:
        """(length m, incline rad) of the straight line from ``s1`` to ``s2``
        (``s2 > s1``): what a swing between grips there sees."""
        (x1, y1), (x2, y2) = self.point([s1, s2])
        return float(math.hypot(x2 - x1, y2 - y1)), float(math.atan2(y2 - y1, x2 - x1))

    def obstacle_at(self, s: float, half_width: float = 0.0) -> Obstacle | None:
        """The obstacle a clasp of half-width ``half_width`` centred at ``s``
        touches, or ``None`` (obstacles are sorted and do not overlap: a
        bisection, so long lines stay cheap)."""
        return self.obstacle_in(s, s, half_width)

    def obstacle_in(self, a: float, b: float, margin: float = 0.0) -> Obstacle | None:
        """The first obstacle touching ``[a - margin, b + margin]``, or ``None``."""
        i = bisect.bisect_right(self._ends, a - margin)   # the first ending past a - margin
        if i < len(self.obstacles) and self.obstacles[i].start < b + margin:
            return self.obstacles[i]
        return None

    @functools.cached_property
    def _ends(self) -> list:
        return [ob.end for ob in self.obstacles]

    def polyline(self, n: int = 200) -> np.ndarray:
        """``(n, 2)`` points of the stretch, for drawing."""
        return self.point(np.linspace(0.0, self.length, n))


# ------------------------------------------------------------------ reading

def _number(data: dict, key: str, where: str, lo: float, hi: float, default=None,
            lo_open: bool = True) -> float:
    v = data.get(key, default)
    if v is None:
        raise LineError(f"{where}: '{key}' is missing; allowed {'(' if lo_open else '['}"
                        f"{lo:g}, {hi:g}] m")
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise LineError(f"{where}: {key} = {v!r} is not a finite number")
    if (v <= lo if lo_open else v < lo) or v > hi:
        raise LineError(f"{where}: {key} = {v:g} is out of range; allowed "
                        f"{'(' if lo_open else '['}{lo:g}, {hi:g}]")
    return float(v)


def _table(data, where: str, keys: tuple[str, ...]) -> dict:
    """``data`` as a table of only ``keys`` (else a one-line LineError)."""
    if not isinstance(data, dict):
        raise LineError(f"{where} must be a table with " + ", ".join(keys))
    unknown = set(data) - set(keys)
    if unknown:
        raise LineError(f"{where}: unknown key '{sorted(unknown)[0]}'; allowed: "
                        + ", ".join(sorted(keys)))
    return data


def _catenary(cat, where: str, length: float):
    _table(cat, f"{where}: [catenary]", ("span", "sag", "offset"))
    span = _number(cat, "span", f"{where} [catenary]", 0.0, 2000.0)
    # a physical conductor sags: at least 1e-4 of its span (flatter is a
    # straight line, given by incline points), at most a quarter of it
    sag = _number(cat, "sag", f"{where} [catenary]", span * 1e-4, span / 4, lo_open=False)
    offset = _number(cat, "offset", f"{where} [catenary]", 0.0, span, default=0.0, lo_open=False)
    # sag = a (cosh(span / 2a) - 1): solve for the catenary parameter a
    from scipy.optimize import brentq

    a = brentq(lambda a: a * (math.cosh(span / (2 * a)) - 1.0) - sag, span / 1000.0, 1e7 * span)
    c = span / 2
    # arc length from x0 to x1 is a (sinh((x1 - c)/a) - sinh((x0 - c)/a))
    u0 = math.sinh((offset - c) / a)
    x_end = c + a * math.asinh(length / a + u0)
    if x_end > span:
        raise LineError(f"{where}: the stretch ({length:g} m of line from {offset:g} m) runs "
                        f"past the far tower at {span:g} m; allowed a shorter length or offset")
    s = np.linspace(0.0, length, 801)
    slope = s / a + u0  # the slope sinh((x(s) - c) / a) grows linearly in arc length
    return s, np.arctan(slope)


def line_from_dict(data: dict, where: str = "line", *, max_incline_deg: float = 25.0) -> Line:
    """A :class:`Line` from the tables of a line file; every problem raises
    :class:`LineError` naming the key and the allowed range."""
    if not isinstance(data, dict):
        raise LineError(f"{where}: a line file is a TOML table")
    allowed = {"length", "start", "incline", "catenary", "obstacles", "name"}
    for key in data:
        if key not in allowed:
            raise LineError(f"{where}: unknown key '{key}'; allowed: " + ", ".join(sorted(allowed)))
    length = _number(data, "length", where, 0.0, 10000.0)
    if "incline" in data and "catenary" in data:
        raise LineError(f"{where}: give either incline points or [catenary], not both")
    if "catenary" in data:
        s_tab, a_tab = _catenary(data["catenary"], where, length)
    else:
        pts = data.get("incline", [[0.0, 0.0], [length, 0.0]])
        if (not isinstance(pts, list) or not pts or not all(
                isinstance(p, list) and len(p) == 2 and all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                    for v in p) for p in pts)):
            raise LineError(f"{where}: incline = {pts!r} must be a list of [position m, incline "
                            "deg] pairs of finite numbers")
        s_tab = np.array([float(p[0]) for p in pts])
        if np.any(np.diff(s_tab) <= 0):
            raise LineError(f"{where}: incline positions {s_tab.tolist()} must increase")
        a_tab = np.radians([float(p[1]) for p in pts])
        if len(s_tab) == 1:
            s_tab, a_tab = np.array([0.0, length]), np.repeat(a_tab, 2)
    worst = float(np.degrees(np.max(np.abs(a_tab))))
    if worst > max_incline_deg:
        raise LineError(f"{where}: the line's incline reaches {worst:.1f} deg; allowed "
                        f"[-{max_incline_deg:g}, {max_incline_deg:g}] deg (traverse.max_incline_deg)")
    obs_data = data.get("obstacles", [])
    if not isinstance(obs_data, list):
        raise LineError(f"{where}: obstacles must be an array of tables ([[obstacles]])")
    obstacles = []
    for i, ob in enumerate(obs_data):
        w = f"{where}: obstacle {i + 1}"
        _table(ob, w, ("position", "width", "name"))
        pos = _number(ob, "position", w, 0.0, length)
        width = _number(ob, "width", w, 0.0, length)
        name = ob.get("name", f"obstacle {i + 1}")
        if not isinstance(name, str):
            raise LineError(f"{w}: name = {name!r} must be a string")
        if pos + width > length:
            raise LineError(f"{w} ({pos:g}-{pos + width:g} m) runs past the stretch's end; "
                            f"allowed position + width <= length = {length:g} m")
        obstacles.append(Obstacle(pos, width, name))
    obstacles.sort(key=lambda o: o.start)
    for a, b in zip(obstacles[:-1], obstacles[1:]):
        if b.start < a.end:
            raise LineError(f"{where}: obstacles '{a.name}' ({a.start:g}-{a.end:g} m) and "
                            f"'{b.name}' ({b.start:g}-{b.end:g} m) overlap")
    start = _number(data, "start", where, 0.0, length)
    line = Line(length, s_tab, a_tab, tuple(obstacles), start, dict(data))
    hit = line.obstacle_at(start)
    if hit is not None:
        raise LineError(f"{where}: the start {start:g} m lies on '{hit.name}' "
                        f"({hit.start:g}-{hit.end:g} m); a gripper cannot clasp an obstacle")
    return line


def load_line(path, *, max_incline_deg: float = 25.0) -> Line:
    """Read a line file (errors name the file and the problem)."""
    path = Path(path)
    return line_from_dict(read_toml(path, "line file", LineError), str(path),
                          max_incline_deg=max_incline_deg)


__all__ = ["Line", "LineError", "Obstacle", "line_from_dict", "load_line"]
