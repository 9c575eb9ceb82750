"""Knockdown curves: a robot's uptime and falls against how hard it is
knocked, from knocked traversal studies (``bplir montecarlo --traverse LINE
--knocks RATE:SEVERITY``, one study per severity), and their figure."""
from __future__ import annotations

import numpy as np

from ...plotting import figure_axes, finish


def knockdown_curve(summaries) -> list[dict]:
    """One point per knocked study summary (its ``knockdown`` block), by
    severity: ``severity``, ``rate`` (a minute), ``runs``, ``mean_uptime``,
    ``no_fall``, ``no_fall_rate`` and its 95 % Wilson ``no_fall_ci95``,
    ``falls_by_cause``, ``interlock_falls``, ``seed``.  A summary without
    knocks raises ``ValueError``."""
    points = []
    for s in summaries:
        kd = s.get("knockdown")
        if kd is None:
            raise ValueError(f"the study of root seed {s.get('seed')} was not knocked")
        points.append({"severity": float(kd["knocks"]["severity"]),
                       "rate": float(kd["knocks"]["rate"]), "runs": kd["runs"],
                       "mean_uptime": kd["mean_uptime"], "no_fall": kd["no_fall"],
                       "no_fall_rate": kd["no_fall_rate"], "no_fall_ci95": kd["no_fall_ci95"],
                       "falls_by_cause": kd["falls_by_cause"],
                       "interlock_falls": kd["interlock_falls"], "seed": s.get("seed")})
    return sorted(points, key=lambda p: p["severity"])

def plot_knockdown(curves: dict, axes=None, standard: float | None = None):
    """Mean uptime and the share of runs without a fall (with its 95 %
    Wilson interval) against the knocks' severity, one line per robot
    (``curves``: label -> :func:`knockdown_curve`); ``standard``: the
    severity marked as the standard one.  Two axes; returns the figure."""
    fig, (ax_up, ax_fall) = figure_axes(axes, 1, 2, figsize=(10, 4.2))
    for label, points in curves.items():
        sev = np.array([p["severity"] for p in points])
        up = np.array([p["mean_uptime"] for p in points])
        rate = np.array([p["no_fall_rate"] for p in points])
        lo = np.array([p["no_fall_ci95"][0] for p in points])
        hi = np.array([p["no_fall_ci95"][1] for p in points])
        line, = ax_up.plot(sev, up, "o-", label=label)
        ax_fall.errorbar(sev, rate, yerr=[rate - lo, hi - rate], fmt="o-", capsize=3,
                         color=line.get_color(), label=label)
    for ax, what in ((ax_up, "mean uptime"), (ax_fall, "runs without a fall")):
        ax.set_xlabel("knock severity (1: alone, it swings the free link 30 deg from rest)")
        ax.set_ylabel(what)
        ax.set_ylim(0.0, 1.02)
        ax.grid(True, alpha=0.3)
        if standard is not None:
            ax.axvline(standard, color="0.5", lw=0.8, ls="--", label="the standard severity")
    ax_fall.legend(loc="lower left", fontsize=8)
    rates = sorted({p["rate"] for pts in curves.values() for p in pts})
    runs = sorted({p["runs"] for pts in curves.values() for p in pts})
    seeds = sorted({p["seed"] for pts in curves.values() for p in pts if p["seed"] is not None})
    return finish(fig, "Knocked traversals: uptime and falls against severity",
                  f"{', '.join(f'{r:g}' for r in rates)} knocks a minute; "
                  f"{'/'.join(str(n) for n in runs)} runs a point; root seed"
                  f"{'s' if len(seeds) > 1 else ''} {', '.join(str(s) for s in seeds)}; "
                  "bars: 95 % Wilson intervals")

__all__ = ["knockdown_curve", "plot_knockdown"]
