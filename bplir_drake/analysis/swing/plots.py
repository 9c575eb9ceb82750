"""Figures and animation of a swing (data from :func:`analysis.swing.run_swing`)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ...io import atomic_path
from ..plotting import figure_axes, finish
from .run import log_table


def plot_swing(result, axes=None, title=None):
    """Six panels in the style of Fig. 7.6: angles, rates, applied torque,
    friction torques, end-effector x/y, energy split."""
    cols, d = log_table(result)
    c = {k: d[:, i] for i, k in enumerate(cols)}
    s = result.summary
    fig, ax = figure_axes(axes, 3, 2, figsize=(12, 9), sharex=True)
    a = ax[0, 0]
    a.plot(c["t"], c["q1"], "C0", label="q1")
    a.plot(c["t"], c["q2"], "C1", label="q2")
    a.plot(c["t"], c["q1_est"], "C0:", label="q1 estimate")
    a.plot(c["t"], c["q2_est"], "C1:", label="q2 estimate")
    a.plot(c["t"], c["q2_ref"], "k--", lw=0.8, label="q2 reference")
    a.set_ylabel("angle [rad]")
    a.legend(fontsize=7, ncol=2)
    a = ax[0, 1]
    a.plot(c["t"], c["q1d"], "C0", label="q1'")
    a.plot(c["t"], c["q2d"], "C1", label="q2'")
    a.set_ylabel("rate [rad/s]")
    a.legend(fontsize=7)
    a = ax[1, 0]
    a.plot(c["t"], c["torque"], "C3", label="applied (motor)")
    a.plot(c["t"], c["torque_cmd"], "k:", lw=0.8, label="commanded")
    lim = s["thresholds"]["torque_limit_Nm"]
    a.axhline(lim, color="grey", lw=0.6)
    a.axhline(-lim, color="grey", lw=0.6)
    a.set_ylabel("elbow torque [N m]")
    a.legend(fontsize=7)
    a = ax[1, 1]
    a.plot(c["t"], c["f1"], "C0", label="f1 (gripper joint)")
    a.plot(c["t"], c["f2"], "C1", label="f2 (elbow)")
    a.set_ylabel("friction torque [N m]")
    a.legend(fontsize=7)
    a = ax[2, 0]
    a.plot(c["t"], c["gripper_x"], "C2", label="x")
    a.plot(c["t"], c["gripper_y"], "C4", label="y")
    a.axhline(0, color="k", lw=0.6)
    a.set_ylabel("free gripper [m]")
    a.set_xlabel("time [s]")
    a.legend(fontsize=7)
    a = ax[2, 1]
    a.plot(c["t"], c["energy"], "k", label="total")
    a.plot(c["t"], c["kinetic"], "C1", label="kinetic")
    a.plot(c["t"], c["potential"], "C0", label="potential")
    a.set_ylabel("energy [J]")
    a.set_xlabel("time [s]")
    a.legend(fontsize=7)
    for a in ax.flat:
        a.grid(True, alpha=0.3)
        if math.isfinite(s["swing_time_s"]):
            a.axvline(s["swing_time_s"], color="C3", lw=0.6, ls="--")
    title = title or (f"BPLIR swing: {s['outcome']} at {s['swing_time_s']:.2f} s, "
                      f"{s['capture_speed_mps']:.2f} m/s (seed {s['seed']}, incline "
                      f"{s['incline_deg']:g} deg, controller {s['controller']})")
    return finish(fig, title)


def animate_swing(result, path, fps: int = 25, max_frames: int = 120) -> Path:
    """GIF of the robot on the line (matplotlib + Pillow)."""
    p = result.params
    tp = p.simulated_plant
    st = result.logs["state"]
    t, x = st.t, st.data
    frames = np.unique(np.linspace(0, len(t) - 1, min(max_frames, max(2, int(t[-1] * fps) + 1)))
                       .astype(int))
    alpha = math.radians(p.scenario.incline_deg)
    D = p.scenario.grip_spacing
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7, 5))
    FigureCanvasAgg(fig)  # the frames are blitted on an Agg canvas
    ax = fig.subplots()
    L = tp.l1 + tp.l2
    ax.set_xlim(-L * 1.05, L * 1.05)
    ax.set_ylim(-L * 1.05, 0.6)
    ax.set_aspect("equal")
    ax.plot([-2 * L * math.cos(alpha), 2 * L * math.cos(alpha)],
            [-2 * L * math.sin(alpha), 2 * L * math.sin(alpha)], color="0.3", lw=2, label="line")
    ax.plot([D * math.cos(alpha)], [D * math.sin(alpha)], "gx", ms=10, label="target")
    (link,) = ax.plot([], [], "o-", lw=4, color="C0", ms=6)
    (trail,) = ax.plot([], [], "C1", lw=1, alpha=0.7)
    text = ax.text(0.02, 0.95, "", transform=ax.transAxes, fontsize=9, va="top")
    ax.legend(loc="lower right", fontsize=8)
    ax.set_title("BPLIR brachiation")
    elbow = np.column_stack([tp.l1 * np.sin(x[:, 0]), -tp.l1 * np.cos(x[:, 0])])
    grip = elbow + np.column_stack([tp.l2 * np.sin(x[:, 0] + x[:, 1]),
                                    -tp.l2 * np.cos(x[:, 0] + x[:, 1])])

    def draw(k):
        link.set_data([0, elbow[k, 0], grip[k, 0]], [0, elbow[k, 1], grip[k, 1]])
        trail.set_data(grip[:k + 1, 0], grip[:k + 1, 1])
        text.set_text(f"t = {t[k]:.2f} s")
        return link, trail, text

    # blitted frames: the axes, ticks and legend are drawn once, each frame
    # redraws only the robot, its trail and the clock
    from PIL import Image

    fig.canvas.draw()
    background = fig.canvas.copy_from_bbox(fig.bbox)
    images = []
    for k in frames:
        fig.canvas.restore_region(background)
        for artist in draw(k):
            ax.draw_artist(artist)
        images.append(Image.fromarray(np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()))
    # one palette for all frames, from the last (it holds every colour drawn)
    palette = images[-1].quantize(colors=64)
    frames_p = [im.quantize(palette=palette, dither=Image.Dither.NONE) for im in images]
    path = Path(path)
    with atomic_path(path) as tmp:  # an interrupted render leaves no truncated GIF
        frames_p[0].save(tmp, save_all=True, append_images=frames_p[1:],
                         duration=int(round(1000 / fps)), loop=0)
    return path
