"""The figure of a planned swing: angles, torque and power, and the robot on the line."""
from __future__ import annotations

import math
import numpy as np
from ..params import BplirParams
from ..systems.plant import elbow_position, gripper_position
from ..plotting import figure_axes, finish


def plot_plan(plan: SwingPlan, params: BplirParams, axes=None):
    """Figure of a plan: joint angles, torque and power with the limits, and
    the robot drawn at a few instants on the line (three axes)."""
    from matplotlib import colormaps


    fig, ax = figure_axes(axes, 1, 3, figsize=(15, 4.2))
    t, X = plan.times, plan.states
    ax[0].plot(t, X[:, 0], label="q1")
    ax[0].plot(t, X[:, 1], label="q2")
    ax[0].set(xlabel="t (s)", ylabel="angle (rad)", title="planned joint angles")
    ax[0].legend()
    ax[1].plot(t, plan.torque, label="torque (N m)")
    ax[1].plot(t, plan.power / 10.0, label="power / 10 (W)")
    limits = ((plan.torque_limit, "k--", "torque limit"),
              (plan.power_limit / 10.0, "r:", "power limit / 10"))
    for lim, style, name in limits:
        ax[1].axhline(lim, color=style[0], ls=style[1:], label=name)
        ax[1].axhline(-lim, color=style[0], ls=style[1:])
    top = max(lim for lim, _, _ in limits)
    ax[1].set_ylim(-1.15 * top, 1.6 * top)   # the legend above the limits, clear of them
    ax[1].set(xlabel="t (s)", title=f"peak {plan.peak_torque:.1f} N m, {plan.peak_power:.0f} W")
    ax[1].legend(loc="upper center", ncol=2, fontsize=8)
    alpha = math.radians(plan.incline_deg)
    D = params.scenario.grip_spacing
    ax[2].plot([-1.3 * D * math.cos(alpha), 1.3 * D * math.cos(alpha)],
               [-1.3 * D * math.sin(alpha), 1.3 * D * math.sin(alpha)], "k-", lw=2)
    p = params.plant
    for k, i in enumerate(np.linspace(0, len(t) - 1, 9).astype(int)):
        e = np.asarray(elbow_position(X[i, :2], p.l1))
        g = np.asarray(gripper_position(X[i, :2], p.l1, p.l2))
        c = colormaps["viridis"](k / 8)
        ax[2].plot([0, e[0], g[0]], [0, e[1], g[1]], "-o", color=c, ms=3)
    ax[2].set_aspect("equal")
    ax[2].set(title=f"{plan.incline_deg:g} deg line, {plan.duration:.2f} s, "
                    f"link 1 reverses {plan.link1_reversals}x")
    return finish(fig)
