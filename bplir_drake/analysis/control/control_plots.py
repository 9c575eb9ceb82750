"""Plots of QFT data: Nichols chart with templates and bounds, tracking
envelope, family step and disturbance responses, zero-dynamics portraits."""
from __future__ import annotations

import numpy as np

from ...plotting import figure_axes, finish


def _nichols_xy(values):
    ph = np.degrees(np.unwrap(np.angle(values)))
    ph = np.where(ph > 0, ph - 360, ph)
    return ph, 20 * np.log10(np.abs(values))


def plot_nichols(bounds, templates_at_w, L0_dense, w_dense, axes=None, title="QFT Nichols chart"):
    """Bounds (contours of the allowed region per design frequency), the
    templates shifted to the nominal loop, and the nominal loop L0."""
    fig, ax = figure_axes(axes, figsize=(9, 7))
    from matplotlib import colormaps

    colors = colormaps["viridis"](np.linspace(0, 1, len(bounds.omegas)))
    comb = bounds.combined
    for k, (w, c) in enumerate(zip(bounds.omegas, colors)):
        ax.contour(bounds.phases_deg, bounds.mags_db, comb[k].T.astype(float), levels=[0.5],
                   colors=[c], linewidths=1.2)
        ax.plot([], [], color=c, label=f"bound {w:g} rad/s")
    for k, (w, c) in enumerate(zip(bounds.omegas, colors)):
        tmpl = templates_at_w[k] / templates_at_w[k][0] * np.interp(w, w_dense, np.abs(L0_dense)) \
            * np.exp(1j * np.interp(w, w_dense, np.unwrap(np.angle(L0_dense))))
        ph, mg = _nichols_xy(tmpl)
        ax.plot(ph, mg, ".", color=c, ms=3)
    ph, mg = _nichols_xy(L0_dense)
    ax.plot(ph, mg, "k", lw=1.8, label="nominal L0")
    ax.set_xlim(-360, 0)
    ax.set_ylim(bounds.mags_db[0], bounds.mags_db[-1])
    ax.set_xlabel("open-loop phase [deg]")
    ax.set_ylabel("open-loop gain [dB]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="lower left", ncol=2)
    return finish(fig, title)


def plot_tracking(verification, axes=None, title="Tracking |F L/(1+L)| of the family vs (6.17)"):
    """Closed-loop tracking magnitudes of the family against the bounds (6.17) on one axis; returns
    the figure."""
    r = verification.responses
    w = r["w"]
    lo, up = r["bounds"]
    fig, ax = figure_axes(axes, figsize=(8, 5))
    for m in r["TF_mag"]:
        ax.semilogx(w, 20 * np.log10(m), color="C0", lw=0.6, alpha=0.5)
    ax.semilogx(w, 20 * np.log10(lo), "k--", lw=1.5, label="(6.17) lower")
    ax.semilogx(w, 20 * np.log10(up), "k", lw=1.5, label="(6.17) upper")
    ax.set_ylim(-60, 10)
    ax.set_xlabel("frequency [rad/s]")
    ax.set_ylabel("magnitude [dB]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    return finish(fig, title)


def plot_family_responses(verification, axes=None, title="Family responses (Figs 6.10-6.12)"):
    """Step and disturbance responses of every plant of the family (2 x 2 axes); returns the
    figure."""
    r = verification.responses
    t = r["t"]
    fig, axes = figure_axes(axes, 2, 2, figsize=(11, 7))
    for key, ax, lab in (("step", axes[0, 0], "unit step tracking"),
                         ("u", axes[0, 1], "control v for a unit step"),
                         ("out_dist", axes[1, 0], "unit output disturbance"),
                         ("in_dist", axes[1, 1], "unit input disturbance")):
        for y in r[key]:
            ax.plot(t, y, color="C0", lw=0.6, alpha=0.6)
        ax.set_title(lab, fontsize=10)
        ax.grid(True, alpha=0.3)
        ax.set_xlabel("time [s]")
    axes[0, 0].axhline(1.1, color="k", ls="--", lw=0.8)
    axes[0, 0].axhline(0.9, color="k", ls="--", lw=0.8)
    return finish(fig, title)


def plot_zero_dynamics(portraits, axes=None, title="Zero dynamics (Figs 6.2-6.3)"):
    """Phase portraits (q1, q1' in rad, rad/s) of the zero dynamics, one axis per portrait; returns
    the figure."""
    fig, axes = figure_axes(axes, 1, len(portraits), figsize=(6 * len(portraits), 5))
    axes = np.atleast_1d(axes)
    for ax, pp in zip(axes, portraits):
        for _, q1, qd in pp.trajectories:
            ax.plot(q1, qd, lw=0.9)
            ax.plot(q1[0], qd[0], "k.", ms=5)
        ax.set_title("with friction (4.11)" if pp.friction else "without friction")
        ax.set_xlabel("q1 [rad]")
        ax.set_ylabel("q1' [rad/s]")
        ax.grid(True, alpha=0.3)
    return finish(fig, title)
