"""Figures and the replay of a traversal (data from :func:`.run.run_traverse`)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ...params.robot import robot_label
from ...plotting import figure_axes, finish
from ..replay import ReplayScene, replay_html, write_replay_html

#: colour of each gripper's grips
GRIPPER_COLOURS = {1: "C0", 2: "C1"}


def plot_line_grips(result, axes=None):
    """The stretch of line (height against horizontal position), its
    obstacles, every grip (triangles: holding grips, circles: landings, one
    colour per gripper, a cross for a failed swing).  One axis."""
    line = result.line
    fig, ax = figure_axes(axes, 1, 1, figsize=(12, 4))
    pts = line.polyline(400)
    ax.plot(pts[:, 0], pts[:, 1], color="0.3", lw=1.2, label="line")
    for i, ob in enumerate(line.obstacles):
        seg = line.point(np.linspace(ob.start, ob.end, 20))
        ax.plot(seg[:, 0], seg[:, 1], color="C3", lw=7, solid_capstyle="butt",
                label="obstacle" if i == 0 else None)
        x, y = line.point((ob.start + ob.end) / 2)
        ax.annotate(ob.name, (x, y), xytext=(0, 12), textcoords="offset points",
                    ha="center", fontsize=8, color="C3")
    seen = set()
    for r in result.rows:
        if r.kind != "swing":
            continue
        g = int(r.holding_gripper)
        colour = GRIPPER_COLOURS[g]
        xh, yh = line.point(r.hold_m)
        lab = f"gripper {g} holds" if ("h", g) not in seen else None
        seen.add(("h", g))
        ax.plot(xh, yh, "v", color=colour, ms=9, label=lab)
        other = 3 - g
        if math.isfinite(r.to_m):
            xl, yl = line.point(r.to_m)
            ok = r.outcome == "captured"
            lab = f"gripper {other} lands" if ("l", other) not in seen else None
            seen.add(("l", other))
            ax.plot(xl, yl, "o" if ok else "X", color=GRIPPER_COLOURS[other], ms=7,
                    mfc="none" if ok else None, label=lab)
        else:
            ax.plot(xh + 0.3, yh - 0.2, "X", color="k", ms=9,
                    label="failed swing" if "f" not in seen else None)
            seen.add("f")
    ax.set_xlabel("along the line (horizontal) [m]")
    ax.set_ylabel("height [m]")
    ax.set_ylim(pts[:, 1].min() - 0.6, pts[:, 1].max() + 0.4)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, ncol=3, loc="lower right")
    t = result.totals
    return finish(fig, f"{line.data.get('name', 'line')}: {t['outcome']}, "
                       f"{t['obstacles_passed']}/{t['obstacles']} obstacles, {t['time_s']:.1f} s, "
                       f"{t['energy_J']:.0f} J (seed {result.seed})")


#: the most samples of the motion log a figure or a replay reads
TIMELINE_SAMPLES = 200_000

#: the timeline's shading (colour, alpha) of the manoeuvres without a swing
STILL_SHADES = {"rest": ("0.5", 0.15), "calibrate": ("0.5", 0.15),
                "recover": ("tab:red", 0.08)}


def plot_timeline(result, axes=None):
    """The whole traversal against time (three axes): joint angles of the
    original robot (link 1 from the vertical, elbow), elbow torque, the
    driver's i^2 t integral with its trip level; swings shaded."""
    tl = result.timeline(TIMELINE_SAMPLES)
    fig, ax = figure_axes(axes, 3, 1, figsize=(12, 8), sharex=True)
    t = tl["t"]
    ax[0].plot(t, tl["q"][:, 0], "C0", label="q1 (link 1, unwrapped: it turns over once per swing of gripper 1)")
    ax[0].plot(t, tl["q"][:, 1], "C1", label="q2 (elbow)")
    ax[0].set_ylabel("angle [rad]")
    ax[1].plot(t, tl["torque"], "C3")
    ax[1].set_ylabel("elbow torque [N m]")
    ax[2].plot(t, tl["i2t"], "C2", label="i\u00b2t above continuous")
    ax[2].axhline(result.totals.i2t_budget_A2s, color="C3", ls="--", lw=0.8,
                  label="driver trips")
    ax[2].set_ylabel("i\u00b2t [A\u00b2 s]")
    ax[2].set_xlabel("time [s]")
    for r in result.rows:
        if r.kind == "swing":
            for a in ax:
                a.axvspan(r.t_start_s, r.t_start_s + r.duration_s,
                          color=GRIPPER_COLOURS[int(r.holding_gripper)], alpha=0.12, lw=0)
        elif r.kind in STILL_SHADES:
            colour, alpha = STILL_SHADES[r.kind]
            for a in ax:
                a.axvspan(r.t_start_s, r.t_start_s + r.duration_s, color=colour,
                          alpha=alpha, lw=0)
    for a in ax:
        a.grid(True, alpha=0.3)
    ax[0].legend(fontsize=8)
    ax[2].legend(fontsize=8)
    recovered = any(r.kind == "recover" for r in result.rows)
    return finish(fig, "traversal: swings shaded (blue: gripper 1 holds, orange: gripper 2 "
                       "holds, grey: rest or IMU calibration"
                       + (", red: damping after a timeout or a driver trip)" if recovered
                          else ")"))


def traverse_replay_scene(result):
    """The :class:`~bplir_drake.analysis.replay.ReplayScene` of a traversal:
    the line, its obstacles, every clamp while it is closed."""
    clamps = []
    for _, s, t_on, t_off in result.clamps:
        x, y = result.line.point(s)
        clamps.append((float(x), float(y), float(result.line.incline_at(s)), t_on, t_off))
    return line_scene(result.line, result.params, clamps)


def line_scene(line, params, clamps=()):
    """The :class:`~bplir_drake.analysis.replay.ReplayScene` of a line: the
    conductor, its obstacles and ``clamps``, the whole stretch in view."""
    obstacles = []
    for ob in line.obstacles:
        x, y = line.point((ob.start + ob.end) / 2)
        obstacles.append((float(x), float(y), float(line.incline_at((ob.start + ob.end) / 2)),
                          ob.width))
    pts = line.polyline(100)
    reach = params.plant.l1 + params.plant.l2
    view = [tuple(pts[0]), tuple(pts[-1]), (pts[0, 0], pts[:, 1].min() - reach)]
    return ReplayScene(line=[tuple(p) for p in pts], obstacles=obstacles, clamps=list(clamps),
                       view=view, camera_distance=0.5)


def traverse_replay_html(result, path, fps: float = 20.0) -> Path:
    """A self-contained HTML Meshcat replay of the whole traversal (the
    simulated robot drawn from gripper 1), written atomically to ``path``."""

    tl = result.timeline(TIMELINE_SAMPLES)
    t, keep = np.unique(tl["t"], return_index=True)
    html = replay_html(result.params.simulated_plant, t, tl["q"][keep],
                       traverse_replay_scene(result), fps=fps, base=tl["base"][keep],
                       title=f"{robot_label(result.params)} traversal: {result.totals['outcome']} "
                             f"(seed {result.seed})")
    return write_replay_html(path, html)


__all__ = ["plot_line_grips", "plot_timeline", "traverse_replay_scene", "traverse_replay_html"]
