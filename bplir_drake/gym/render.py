"""Pictures of the learning environment's robot: an RGB array drawn with
matplotlib (Agg) and the robot in Meshcat."""
from __future__ import annotations

import math

import numpy as np

from ..analysis.replay import quiet_meshcat, stand_upright
from ..diagrams.visual import build_replay_visualizer
from ..systems.plant import elbow_position, gripper_position


class LineRenderer:
    """The robot on its line as an RGB array: the line through the holding
    gripper, the grip to take, the two links and the time."""

    def __init__(self, size=(480, 360), dpi: int = 80):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.fig = Figure(figsize=(size[0] / dpi, size[1] / dpi), dpi=dpi)
        FigureCanvasAgg(self.fig)
        self.ax = self.fig.subplots()
        self._key = None

    def _scene(self, p) -> None:
        """The axes, the line and the grip of the robot ``p`` (drawn again
        only when the episode's robot or line changes)."""
        tp, sc = p.simulated_plant, p.scenario
        key = (tp.l1, tp.l2, sc.incline_deg, sc.grip_spacing)
        if key == self._key:
            return
        self._key = key
        ax = self.ax
        ax.clear()
        L, alpha, D = tp.l1 + tp.l2, math.radians(sc.incline_deg), sc.grip_spacing
        ax.set_xlim(-1.05 * L, 1.05 * L)
        ax.set_ylim(-1.05 * L, 0.3 * L)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.plot([-2 * L * math.cos(alpha), 2 * L * math.cos(alpha)],
                [-2 * L * math.sin(alpha), 2 * L * math.sin(alpha)], color="0.3", lw=2,
                label="line")
        ax.plot([D * math.cos(alpha)], [D * math.sin(alpha)], "gx", ms=10, label="grip")
        (self.links,) = ax.plot([], [], "o-", lw=4, color="C0", ms=6)
        self.text = ax.text(0.02, 0.95, "", transform=ax.transAxes, fontsize=9, va="top")
        ax.legend(loc="lower right", fontsize=8)
        self.fig.tight_layout()

    def draw(self, p, x, t: float) -> np.ndarray:
        """The picture of ``p``'s robot at state ``x`` and time ``t`` (s)."""
        self._scene(p)
        tp = p.simulated_plant
        (ex, ey), (gx, gy) = elbow_position(x, tp.l1), gripper_position(x, tp.l1, tp.l2)
        self.links.set_data([0.0, ex, gx], [0.0, ey, gy])
        self.text.set_text(f"t = {t:.2f} s")
        self.fig.canvas.draw()
        return np.asarray(self.fig.canvas.buffer_rgba())[..., :3].copy()

    def close(self) -> None:
        """Let the figure go."""
        self.fig = None


class MeshcatRenderer:
    """The robot drawn in Meshcat (Drake's visualizer on the plant's
    geometry; the address is ``meshcat.web_url()``)."""

    def __init__(self):
        self.meshcat = quiet_meshcat()
        stand_upright(self.meshcat)
        self._key = self._built = None

    def draw(self, p, x, t: float):
        """Show ``p``'s robot at state ``x`` (returns None)."""
        key = p.simulated_plant
        if key != self._key:
            self._key = key
            self._built = build_replay_visualizer(key, self.meshcat)
            self._ctx = self._built.diagram.CreateDefaultContext()
        b = self._built
        b.plant.SetPositions(b.plant.GetMyMutableContextFromRoot(self._ctx),
                             np.asarray(x[:2], dtype=float))
        self._ctx.SetTime(t)
        b.diagram.ForcedPublish(self._ctx)
        return None

    def close(self) -> None:
        """Let the visualizer and the server go."""
        self._built = None
        self.meshcat = None
