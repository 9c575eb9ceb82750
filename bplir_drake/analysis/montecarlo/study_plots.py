"""Figures of a Monte Carlo study, drawn from its result rows.

* ``success_vs_parameters.png``: per uncertain quantity, every sample's
  capture speed against the drawn value (coloured by outcome) and the binned
  success rate;
* ``histograms.png``: capture speed, swing time, peak torque, peak power;
* ``influence.png``: the two most influential quantities against each other.
"""
from __future__ import annotations

import math

import numpy as np

from .statistics import MIN_INFLUENCE_SAMPLES, influence
from .study import Study, study_rows
from ...plotting import figure_axes, finish
from dataclasses import fields
from ...params import BLOCKS

OUTCOME_COLOURS = {"captured": "tab:green", "crash": "tab:red", "timeout": "tab:orange",
                   "fault": "tab:purple", "error": "black"}


def quantity_label(name: str) -> str:
    """An axis label for a study's quantity ``block.field``: its meaning and
    unit from the parameter metadata (the simulated robot's, for ``true_``
    blocks)."""


    block, _, field = name.partition(".")
    cls = BLOCKS.get(block)
    md = next((f.metadata for f in fields(cls) if f.name == field), {}) if cls else {}
    doc = md.get("doc", "").split(" (")[0].split(";")[0] or field
    owner = ("simulated robot: " if block.startswith("true_")
             else "line sensor: " if block == "line_sensor" else "")
    unit = md.get("unit", "")
    return f"{owner}{doc}" + (f" [{unit}]" if unit else "")


def _colour(rows):
    return [OUTCOME_COLOURS.get(r.outcome, "grey") for r in rows]


#: where each panel of :func:`plot_success_vs_parameters` draws the success
#: rate (0 and 1, as fractions of the axes' height): a band above the capture
#: speeds and the limit line, which keep below :data:`SPEED_TOP`
RATE_BAND, SPEED_TOP = (0.80, 0.95), 0.74


def _grid_columns(n: int) -> int:
    """Columns of a grid of ``n`` panels: the fewest empty panels, then the
    nearest to three columns."""
    if n <= 3:
        return n
    return min(range(2, 6), key=lambda c: (-n % c, abs(c - 3)))


def plot_success_vs_parameters(study: Study, rows: list[dict], axes=None):
    """Capture speed (m/s) against each uncertain quantity, coloured by
    outcome, with the success rate per sixth of its range in a band above
    (one axis per quantity); returns the figure."""
    from matplotlib.ticker import MaxNLocator

    rows = study_rows(rows)
    names, shown = _panel_quantities(study, rows)
    ncol = _grid_columns(len(names))
    nrow = math.ceil(len(names) / ncol)
    fig, axes = figure_axes(axes, nrow, ncol, figsize=(4.6 * ncol, 3.4 * nrow), squeeze=False)
    speed = np.array([r.capture_speed_mps for r in rows], dtype=float)
    succ = np.array([bool(r.success) for r in rows])
    limit = study.params.gripper.capture_speed
    top = max(limit, np.nanmax(speed, initial=limit)) / SPEED_TOP
    for ax, name in zip(axes.flat, names):
        x = np.array([r[name] for r in rows], dtype=float)
        ax.scatter(x, np.nan_to_num(speed, nan=0.0), s=8, c=_colour(rows), alpha=0.7)
        ax.axhline(limit, color="k", lw=0.8, ls="--")
        ax.annotate("capture speed limit", (0.01, limit), xycoords=("axes fraction", "data"),
                    xytext=(0, -2), textcoords="offset points", fontsize=7, va="top")
        ax.set_ylim(0.0, top)
        ax.set_xlabel(quantity_label(name), fontsize=8)
        ax.set_ylabel("capture speed [m/s]")
        ax.xaxis.set_major_locator(MaxNLocator(5))
        ax.ticklabel_format(axis="x", style="sci", scilimits=(-3, 4), useOffset=False)
        _success_band(ax, x, succ)
    for ax in list(axes.flat)[len(names):]:
        ax.remove()
    return finish(fig, "Capture speed and success rate against each drawn quantity",
                  f"{len(rows)} samples, root seed {study.seed}; {shown}; dots: green captured, "
                  "red crash, orange timeout, purple fault, black error; blue: success rate per sixth of the "
                  "range")


#: the most panels :func:`plot_success_vs_parameters` draws (a grid of 3 x 3
#: stays legible at a page's width)
MAX_PANELS = 9


def _panel_quantities(study: Study, rows) -> tuple[list[str], str]:
    """(the quantities to draw, what the caption says of the choice): all of
    them up to :data:`MAX_PANELS`, else the most influential ones (or, with
    too few samples to rank them, the first)."""
    names = study.names or ["index"]
    if len(names) <= MAX_PANELS:
        return names, "every drawn quantity"
    inf = influence(study, rows)
    if inf:
        top = sorted(inf, key=inf.get, reverse=True)[:MAX_PANELS]
        return [n for n in names if n in top], (f"the {len(top)} of {len(names)} drawn "
                                                "quantities most correlated with the result")
    return names[:MAX_PANELS], (f"the first {MAX_PANELS} of {len(names)} drawn quantities "
                                f"(fewer than {MIN_INFLUENCE_SAMPLES} samples rank none)")


def _success_band(ax, x, succ) -> None:
    """The success rate per sixth of ``x``'s range, on a right axis whose 0
    and 1 lie in :data:`RATE_BAND` of the axes' height."""
    ok = np.isfinite(x)
    if ok.sum() < 4 or np.ptp(x[ok]) <= 0:
        return
    edges = np.linspace(x[ok].min(), x[ok].max(), 7)
    idx = np.clip(np.digitize(x[ok], edges) - 1, 0, 5)
    rate = [succ[ok][idx == i].mean() if np.any(idx == i) else np.nan for i in range(6)]
    ax2 = ax.twinx()
    ax2.step(edges, rate + rate[-1:], where="post", color="tab:blue")
    lo, hi = RATE_BAND
    span = 1.0 / (hi - lo)
    ax2.set_ylim(-lo * span, (1.0 - lo) * span)
    ax2.set_yticks([0.0, 1.0])
    ax2.set_ylabel("success", color="tab:blue", fontsize=7)   # short: inside the band
    ax2.yaxis.set_label_coords(1.07, (lo + hi) / 2)


def _hist_range(v: np.ndarray) -> tuple[float, float]:
    """The histogram's range: the data's, widened around a value that (nearly)
    every sample shares (a traversal's swing count, a time at its limit), so
    its bins are never narrower than floating point can tell apart."""
    lo, hi = float(v.min()), float(v.max())
    least = 1e-6 * max(1.0, abs(lo), abs(hi))
    if hi - lo >= least:
        return lo, hi
    mid = 0.5 * (lo + hi)
    return mid - least * 500, mid + least * 500


def plot_histograms(study: Study, rows: list[dict], axes=None):
    """Histograms of capture speed, swing time, peak torque and peak power (2 x 2 axes); returns
    the figure."""
    from matplotlib.ticker import MaxNLocator

    rows = study_rows(rows)
    every = study.line is not None   # a traversal's figures: its worst swing, its swings' sum
    fields = [("capture_speed_mps", "capture speed [m/s]", study.params.gripper.capture_speed,
               "limit"),
              ("swing_time_s", "time swinging, all swings [s]" if every else "swing time [s]",
               None, ""),
              ("peak_torque_Nm", "peak torque [N m]", None, ""),
              ("peak_motor_power_W", "peak motor power [W]", study.params.motor.power_rating,
               "rating")]
    fig, axes = figure_axes(axes, 2, 2, figsize=(10, 7))
    for ax, (f, label, limit, name) in zip(axes.flat, fields):
        v = np.array([r[f] for r in rows if r.outcome != "error"], dtype=float)
        v = v[np.isfinite(v)]
        if v.size:
            ax.hist(v, bins=min(40, max(5, v.size // 5)), range=_hist_range(v),
                    color="tab:blue", alpha=0.8)
        if limit is not None:
            ax.axvline(limit, color="tab:red", ls="--", label=name)
            ax.legend(loc="upper right", fontsize=8)
        ax.ticklabel_format(axis="x", useOffset=False)   # values at a limit: no "+1.989e1"
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))   # counts are whole
        ax.set_xlabel(label)
        ax.set_ylabel("samples")
    return finish(fig, "Monte Carlo distributions")


def plot_influence(study: Study, rows: list[dict], axes=None):
    """The samples over the two most influential quantities, coloured by outcome (one axis);
    returns the figure."""
    rows = study_rows(rows)
    inf = influence(study, rows)
    ranked = sorted(inf, key=inf.get, reverse=True)
    fig, ax = figure_axes(axes, figsize=(6.5, 5))
    if len(ranked) >= 2:
        a, b = ranked[:2]
        ax.scatter([r[a] for r in rows], [r[b] for r in rows], c=_colour(rows), s=12)
        ax.set_xlabel(f"{quantity_label(a)} (|r| = {inf[a]:.2f})")
        ax.set_ylabel(f"{quantity_label(b)} (|r| = {inf[b]:.2f})")
    elif ranked:
        a = ranked[0]
        ax.scatter([r[a] for r in rows], [r.capture_speed_mps for r in rows],
                   c=_colour(rows), s=12)
        ax.set_xlabel(quantity_label(a))
        ax.set_ylabel("capture speed [m/s]")
    else:   # too few samples to rank: say so rather than rank noise
        ax.text(0.5, 0.5, f"{len(rows)} samples: too few to rank the drawn quantities\n"
                f"(at least {MIN_INFLUENCE_SAMPLES})", ha="center", va="center",
                transform=ax.transAxes)
        ax.set_axis_off()
    return finish(fig, "The two most influential quantities",
                  "green captured, red crash, orange timeout, purple fault, black error")


def study_figures(study: Study, rows: list[dict]) -> dict:
    """The figures of a study's rows by file name: success against each
    uncertain quantity, histograms of the results, the two most influential
    quantities."""
    return {"success_vs_parameters.png": plot_success_vs_parameters(study, rows),
            "histograms.png": plot_histograms(study, rows),
            "influence.png": plot_influence(study, rows)}
