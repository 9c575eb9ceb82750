"""Figures and animation of a swing (data from :func:`analysis.swing.run_swing`)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ...io import atomic_path
from ...params.robot import robot_label
from ...plotting import figure_axes, finish
from .logs import log_table
from ..replay import ReplayScene, replay_html, write_replay_html


#: the panels of :func:`plot_swing`: (row, column, y label, [(log column,
#: style, label), ...])
SWING_PANELS = (
    (0, 0, "angle [rad]", [("q1", "C0", "q1"), ("q2", "C1", "q2"), ("q1_est", "C0:", "q1 estimate"),
                           ("q2_est", "C1:", "q2 estimate"), ("q2_ref", "k--", "q2 reference")]),
    (0, 1, "rate [rad/s]", [("q1d", "C0", "q1'"), ("q2d", "C1", "q2'")]),
    (1, 0, "elbow torque [N m]", [("torque", "C3", "applied (motor)"),
                                  ("torque_cmd", "k:", "commanded")]),
    (1, 1, "motor voltage [V]", [("voltage", "C3", "winding voltage"),
                                 ("back_emf", "C7--", "back-EMF")]),
    (2, 0, "free gripper from the\nholding one [m]", [("gripper_along", "C2", "along the line"),
                                                  ("gripper_above", "C4", "above the line")]),
    (2, 1, "energy [J]", [("energy", "k", "total"), ("kinetic", "C1", "kinetic"),
                          ("potential", "C0", "potential")]),
)


#: the panel names of :func:`plot_swing`, in the order of ``SWING_PANELS``
PANEL_NAMES = ("angles", "rates", "torque", "voltage", "gripper", "energy")


def _one_axes(axes) -> bool:
    return axes is not None and np.asarray(axes, dtype=object).size == 1


def plot_swing(result, axes=None, title=None, panel: str | None = None):
    """Six panels (3 x 2 axes) in the style of Fig. 7.6: angles, rates,
    applied torque, the motor's winding voltage and back-EMF (with the
    driver's limit), the free gripper along and above its (inclined) line,
    energy split; the decision time
    marked.  Given one axes (or ``panel``), one panel: ``panel`` of
    :data:`PANEL_NAMES` (default ``"angles"``).  Returns the figure."""
    cols, d = log_table(result)
    c = {k: d[:, i] for i, k in enumerate(cols)}
    s = result.summary
    if panel is not None or _one_axes(axes):
        name = panel or "angles"
        if name not in PANEL_NAMES:
            raise ValueError(f"panel = {name!r}; allowed: " + ", ".join(PANEL_NAMES))
        fig, a = figure_axes(axes, 1, 1, figsize=(6, 3.6))
        index = PANEL_NAMES.index(name)
        _draw_panel(a, c, SWING_PANELS[index], result, index)
        a.set_xlabel("time [s]")
        return finish(fig, title)
    fig, ax = figure_axes(axes, 3, 2, figsize=(12, 9), sharex=True)
    for k, (row, col, _, _) in enumerate(SWING_PANELS):
        _draw_panel(ax[row, col], c, SWING_PANELS[k], result, k)
    for a in ax[2]:
        a.set_xlabel("time [s]")
    caption = (f"{s.outcome} at {s.swing_time_s:.2f} s, {s.capture_speed_mps:.2f} m/s; "
               f"seed {s.seed}, incline {s.incline_deg:g} deg, grip spacing "
               f"{s.grip_spacing_m:g} m, controller {s.controller}, supply "
               f"{result.params.motor.supply_voltage:g} V; dashed red line: the interlock's decision")
    return finish(fig, title or f"{robot_label(result.params)} swing", caption)


def _draw_panel(a, c, spec, result, index):
    """One panel of :func:`plot_swing` on the axes ``a``."""
    s = result.summary
    _, _, ylabel, lines = spec
    for name, style, label in lines:
        a.plot(c["t"], c[name], style, lw=0.8 if style.startswith("k") and name != "energy"
               else None, label=label)
    a.set_ylabel(ylabel)
    first = a.get_legend() is None   # overlaid swings: the first one's legend
    if PANEL_NAMES[index] == "torque":
        lim = s.thresholds["torque_limit_Nm"]
        for sign in (1, -1):
            a.axhline(sign * lim, color="grey", lw=0.6)
        a.text(0.99, 0.90, f"torque limit \u00b1{lim:g} N m", transform=a.transAxes,
               va="top", ha="right", fontsize=7, color="grey")
    elif PANEL_NAMES[index] == "voltage":
        vmax = result.params.motor.max_voltage
        for sign in (1, -1):
            a.axhline(sign * vmax, color="grey", lw=0.6)
        a.text(0.01, 0.90, f"driver limit \u00b1{vmax:.1f} V", transform=a.transAxes,
               va="top", fontsize=7, color="grey")
    elif PANEL_NAMES[index] == "gripper":   # the line, whatever its incline
        sc = result.params.scenario
        a.axhline(0, color="k", lw=0.6, label=f"the line ({sc.incline_deg:g} deg)" * first)
        a.axhline(sc.grip_spacing, color="C2", lw=0.6, ls=":",
                  label=f"the grip, {sc.grip_spacing:g} m along it" * first)
    if first:
        a.legend(fontsize=7, ncol=2 if len(lines) > 3 else 1)
    a.grid(True, alpha=0.3)
    if math.isfinite(s.swing_time_s):
        a.axvline(s.swing_time_s, color="C3", lw=0.6, ls="--")


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
    ax.set_title(f"{robot_label(p)} brachiation")
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


def swing_replay_scene(result):
    """The :class:`~bplir_drake.analysis.replay.ReplayScene` of a swing:
    the line through the holding gripper at the scenario's incline, the
    target one grip spacing along it, the holding gripper's clamp, and the
    arriving gripper's clamp from the capture on (a captured swing)."""
    s = result.summary
    return swing_scene(result.params, float(s.swing_time_s) if result.success else None)


def swing_scene(p, captured_at: float | None = None):
    """The scene of a swing of ``p`` (:func:`swing_replay_scene`), the
    arriving clamp shown from ``captured_at`` (s; None: never)."""
    alpha = math.radians(p.scenario.incline_deg)
    D = p.scenario.grip_spacing
    reach = p.plant.l1 + p.plant.l2
    u = np.array([math.cos(alpha), math.sin(alpha)])
    clamps = [(0.0, 0.0, alpha, 0.0, math.inf)]
    if captured_at is not None:
        clamps.append((*(D * u), alpha, captured_at, math.inf))
    return ReplayScene(line=[tuple(-reach * u), tuple((D + reach) * u)],
                       targets=[tuple(D * u)], clamps=clamps)


def replay_swing_html(result, path, fps: float = 30.0) -> Path:
    """A self-contained HTML Meshcat replay of a swing (the simulated
    robot's true motion), written atomically to ``path``."""

    st = result.logs["state"]
    s = result.summary
    title = (f"{robot_label(result.params)} swing: {s.outcome} (seed {s.seed}, incline "
             f"{s.incline_deg:g} deg)")
    html = replay_html(result.params.simulated_plant, st.t, st.data[:, :2],
                       swing_replay_scene(result), fps=fps, title=title)
    return write_replay_html(path, html)
