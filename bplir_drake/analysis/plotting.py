"""Plots: each function takes computed data and writes a figure file.

Matplotlib is imported lazily with the Agg backend, so plotting works on
headless machines and in tests.
"""
from __future__ import annotations

from pathlib import Path

from ..io import atomic_path


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path, title=None) -> Path:
    import matplotlib.pyplot as plt

    if title:
        fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    with atomic_path(path) as tmp:  # never a half-written figure
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    return path


def plot_free_swing(result, path) -> Path:
    """Angles, rates and energy of a free swing (data from simulate_free_swing)."""
    plt = _plt()
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    t, x = result.t, result.x
    axes[0].plot(t, x[:, 0], label="q1 (gripper joint)")
    axes[0].plot(t, x[:, 1], label="q2 (elbow, relative)")
    axes[0].set_ylabel("angle [rad]")
    axes[0].legend(loc="upper right")
    axes[1].plot(t, x[:, 2], label="q1'")
    axes[1].plot(t, x[:, 3], label="q2'")
    axes[1].set_ylabel("rate [rad/s]")
    axes[1].legend(loc="upper right")
    axes[2].plot(t, result.total, "k", label="total")
    axes[2].plot(t, result.kinetic, label="kinetic")
    axes[2].plot(t, result.potential, label="potential")
    axes[2].set_ylabel("energy [J]")
    axes[2].set_xlabel("time [s]")
    axes[2].legend(loc="upper right")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    return _save(fig, path, "BPLIR free swing")


def plot_estimate(t, estimate, gyro_integral, path, *, truth=None, title="Kinematic EKF") -> Path:
    """Figs 5.4-5.7 style: angles (EKF, gyro integral, truth if known) and,
    with a truth, the angle errors of both."""
    import numpy as np

    plt = _plt()
    rows = 3 if truth is not None else 2
    fig, axes = plt.subplots(rows, 1, figsize=(9, 2.8 * rows), sharex=True)
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
    return _save(fig, path, title)


def plot_observability(result, path) -> Path:
    """Relative smallest singular value of O (gyro-only and full) against time,
    with the (5.17) points marked, and the entries a31, a42."""
    plt = _plt()
    fig, axes = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
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
    return _save(fig, path, "Observability along the swing (red: gyro-only rank loss, (5.17))")
