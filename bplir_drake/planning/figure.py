"""The figure of a planned swing: angles, torque and power, and the robot on the line."""
from __future__ import annotations

import math
import numpy as np
from ..params import BplirParams
from ..systems.plant import elbow_position, gripper_position
from ..plotting import figure_axes, finish


def plot_plan(plan: SwingPlan, params: BplirParams, axes=None):
    """Figure of a plan (four axes): joint angles; elbow torque and motor
    power, each against its limit; and the robot drawn at nine instants on
    its inclined line, coloured by time."""
    fig, ax = figure_axes(axes, 2, 2, figsize=(11, 7.5))
    t, X = plan.times, plan.states
    a = ax[0, 0]
    a.plot(t, X[:, 0], label="q1")
    a.plot(t, X[:, 1], label="q2")
    a.set(xlabel="time [s]", ylabel="joint angle [rad]", title="planned joint angles")
    a.legend(loc="best", fontsize=8)
    for a, y, lim, label, name in ((ax[0, 1], plan.torque, plan.torque_limit,
                                    "elbow torque [N m]", "torque limit"),
                                   (ax[1, 0], plan.power, plan.power_limit,
                                    "motor power [W]", "power rating")):
        a.plot(t, y, color="C0")
        for sign in (1, -1):
            a.axhline(sign * lim, color="k", ls="--", lw=0.8)
        a.text(t[-1], 0.97 * lim, name, ha="right", va="top", fontsize=8, color="0.3")
        a.set_ylim(-1.1 * lim, 1.1 * lim)
        a.set(xlabel="time [s]", ylabel=label)
    ax[0, 1].set_title(f"peak {plan.peak_torque:.1f} N m")
    ax[1, 0].set_title(f"peak {plan.peak_power:.0f} W")
    _draw_poses(ax[1, 1], plan, params)
    for a in ax.flat:
        a.grid(True, alpha=0.3)
    return finish(fig)


def _draw_poses(ax, plan, params) -> None:
    """The robot at nine instants of ``plan`` on its line (nominal links),
    coloured by time with a colour bar."""
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    t, X = plan.times, plan.states
    alpha = math.radians(plan.incline_deg)
    D = params.scenario.grip_spacing
    ax.plot([-1.3 * D * math.cos(alpha), 1.3 * D * math.cos(alpha)],
            [-1.3 * D * math.sin(alpha), 1.3 * D * math.sin(alpha)], "k-", lw=2, label="line")
    p, cmap = params.plant, colormaps["viridis"]
    norm = Normalize(0.0, float(t[-1]))
    for i in np.linspace(0, len(t) - 1, 9).astype(int):
        e = np.asarray(elbow_position(X[i, :2], p.l1))
        g = np.asarray(gripper_position(X[i, :2], p.l1, p.l2))
        ax.plot([0, e[0], g[0]], [0, e[1], g[1]], "-o", color=cmap(norm(t[i])), ms=3)
    ax.set_aspect("equal")
    ax.set(xlabel="horizontal [m]", ylabel="vertical [m]",
           title=f"{plan.incline_deg:g} deg line, {plan.duration:.2f} s, "
                 f"link 1 reverses {plan.link1_reversals}x")
    ax.figure.colorbar(ScalarMappable(norm, cmap), ax=ax, label="time [s]", shrink=0.8)
