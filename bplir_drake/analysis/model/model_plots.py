"""Plots of the model analyses."""
from __future__ import annotations

from ...plotting import figure_axes, finish
import numpy as np


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
    return finish(fig, "Free swing")




def _voltage_lines(ax, result, w, top) -> None:
    """The envelope at the other voltage, the power rating and the no-load rate."""
    ax.plot(w, result.other_torque[:, 1], "--", color="tab:gray",
            label=f"envelope at {result.other_voltage:g} V")
    ax.plot(w, result.other_torque[:, 0], "--", color="tab:gray")
    fast = np.abs(w) > 1e-6
    rating = np.where(fast, result.power_rating / np.where(fast, np.abs(w), 1.0), np.nan)
    rating[rating > top] = np.nan
    ax.plot(w, np.sign(w) * rating, ":", color="tab:red",
            label=f"{result.power_rating:g} W rating")
    ax.axvline(result.no_load_speed, color="tab:blue", lw=0.8, alpha=0.6)
    ax.annotate(f"no-load {result.no_load_speed:.1f} rad/s", (result.no_load_speed, 0.0),
                xytext=(4, 6), textcoords="offset points", fontsize=8, color="tab:blue")


def plot_envelope(result, axes=None):
    """The elbow's torque-speed envelope (data from ``torque_envelope``):
    the deliverable torque at the supply voltage (shaded), at the other
    voltage (dashed), the motor's power rating (dotted) and a swing's
    operating points (dots)."""

    fig, ax = figure_axes(axes, 1, 1, figsize=(7.5, 5.5))
    w, lo, hi = result.speeds, result.torque[:, 0], result.torque[:, 1]
    top = 1.15 * result.current_torque
    ax.fill_between(w, lo, hi, color="tab:blue", alpha=0.12, lw=0)
    ax.plot(w, hi, color="tab:blue", lw=2,
            label=(f"envelope at {result.supply_voltage:g} V supply" if result.voltage_limited
                   else "torque limit (no voltage envelope modelled)"))
    ax.plot(w, lo, color="tab:blue", lw=2)
    if result.voltage_limited:
        _voltage_lines(ax, result, w, top)
    if len(result.swing_rate):
        ax.plot(result.swing_rate, result.swing_torque, ".", ms=3, color="tab:orange",
                label=result.swing_label or "swing")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.axvline(0.0, color="k", lw=0.5)
    ax.set_ylim(-top, top)
    ax.set_xlim(w[0], w[-1])
    ax.set_xlabel("elbow rate q2' [rad/s]")
    ax.set_ylabel("elbow torque [N m]")
    for x, y, text in ((0.98, 0.98, "motoring"), (0.02, 0.98, "braking"),
                       (0.98, 0.02, "braking"), (0.02, 0.02, "motoring")):
        ax.text(x, y, text, transform=ax.transAxes, ha="right" if x > 0.5 else "left",
                va="top" if y > 0.5 else "bottom", fontsize=8, color="0.3")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(0.0, 0.93), fontsize=8, framealpha=0.9)
    return finish(fig)


def plot_closed_loop_poles(result, axes=None):
    """The frozen-time poles of the tracker's loop along its plan: their
    real parts (1/s; symmetric log scale, the fast pole and the slow ones
    on one axis) and their frequencies (rad/s), against the plan's time."""
    fig, axes = figure_axes(axes, 2, 1, figsize=(8, 6), sharex=True)
    t, lam = result.times, result.poles   # each time's poles from the fastest to the slowest
    names = ["fastest", "second", "third", "slowest"]
    for i in range(lam.shape[1]):
        name = names[i] if lam.shape[1] == 4 else f"pole {i + 1}"
        axes[0].plot(t, lam[:, i].real, ".-", ms=3, label=name)
        axes[1].plot(t, np.abs(lam[:, i].imag), ".-", ms=3, label=name)
    axes[0].set_yscale("symlog", linthresh=1.0)
    axes[0].axhline(0.0, color="k", lw=0.8)
    axes[0].set_ylabel("real part [1/s]")
    axes[0].legend(loc="lower right", fontsize="small", ncol=2)
    axes[1].set_ylabel("frequency |imag| [rad/s]")
    axes[1].set_xlabel("time along the plan [s]")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    return finish(fig, "The tracker's loop: frozen-time poles along the plan",
                  caption=f"plan of {result.duration:.2f} s; A - B K(t) of the nominal plant "
                          "with friction, the LQR's model")
