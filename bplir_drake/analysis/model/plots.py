"""Plots of the model analyses."""
from __future__ import annotations

from ..plotting import figure_axes, finish


def plot_free_swing(result, axes=None):
    """Angles, rates and energy of a free swing (data from simulate_free_swing)."""
    fig, axes = figure_axes(axes, 3, 1, figsize=(8, 8), sharex=True)
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
    return finish(fig, "BPLIR free swing")


