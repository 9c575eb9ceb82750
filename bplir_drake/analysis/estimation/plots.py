"""Plots of the estimation studies."""
from __future__ import annotations

import numpy as np

from ..plotting import figure_axes, finish


def plot_estimate(t, estimate, gyro_integral, axes=None, *, truth=None, title="Kinematic EKF"):
    """Figs 5.4-5.7 style: angles (EKF, gyro integral, truth if known) and,
    with a truth, the angle errors of both."""
    rows = 3 if truth is not None else 2
    fig, axes = figure_axes(axes, rows, 1, figsize=(9, 2.8 * rows), sharex=True)
    for i, ax in enumerate(axes[:2]):
        if truth is not None:
            ax.plot(t, truth[:, i], "k", lw=2.2, alpha=0.35, label="truth")
        ax.plot(t, estimate[:, i], "C0", label="K-EKF")
        ax.plot(t, gyro_integral[:, i], "C3--", lw=1, label="gyro integral (5.41)")
        ax.set_ylabel(f"theta{i + 1} [rad]")
        ax.legend(loc="upper right", fontsize=8)
        ax.grid(True, alpha=0.3)
    if truth is not None:
        ax = axes[2]
        for i in range(2):
            ax.plot(t, estimate[:, i] - truth[:, i], f"C{i}", label=f"EKF error theta{i + 1}")
            ax.plot(t, gyro_integral[:, i] - truth[:, i], f"C{i}:",
                    label=f"GYR error theta{i + 1}")
        ax.axhline(0.05, color="grey", lw=0.8)
        ax.axhline(-0.05, color="grey", lw=0.8)
        lim = max(0.1, 1.2 * float(np.percentile(np.abs(estimate[:, :2] - truth[:, :2]), 99)))
        ax.set_ylim(-lim, lim)
        ax.set_ylabel("error [rad]")
        ax.legend(loc="upper right", fontsize=8, ncol=2)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    return finish(fig, title)


def plot_observability(result, axes=None):
    """Relative smallest singular value of O (gyro-only and full) against time,
    with the (5.17) points marked, and the entries a31, a42."""
    fig, axes = figure_axes(axes, 2, 1, figsize=(9, 6), sharex=True)
    ax = axes[0]
    ax.semilogy(result.t, result.smin_gyro, label="gyro only (5.16)")
    ax.semilogy(result.t, result.smin_full, label="gyro + accelerometer (5.18)")
    ax.axhline(result.threshold, color="grey", ls="--", lw=0.8, label="rank threshold")
    for e in result.events:
        ax.axvline(e["t"], color="C3", lw=0.6, alpha=0.6)
    ax.set_ylabel("sigma_min / sigma_max")
    ax.legend(loc="lower right", fontsize=8)
    ax.grid(True, alpha=0.3)
    ax = axes[1]
    ax.plot(result.t, result.a31, label="a31 = -g c1/r1")
    ax.plot(result.t, result.a42, label="a42 = d(omega2')/d(theta2)")
    ax.axhline(0, color="k", lw=0.6)
    ax.set_ylabel("A entries [1/s^2]")
    ax.set_xlabel("time [s]")
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(True, alpha=0.3)
    return finish(fig, "Observability along the swing (red: gyro-only rank loss, (5.17))")
