"""A swing shown live in Drake's Meshcat while it is simulated.

:class:`LiveView` starts a Meshcat server on this machine (its address is
``url``) and draws the simulated robot there -- the plant's own geometry,
the line and the capture point -- as the simulator advances: a monitor of
the simulator poses the drawing at ``fps`` frames per simulated second and
paces the simulation at real time, so that what the browser shows is the
swing as it would happen.  After the swing, the view replays it on its
*Animations* panel, like the self-contained HTML replay."""
from __future__ import annotations

import logging
import math

import numpy as np

from ..diagrams.visual import build_replay_visualizer


class LiveView:
    """The Meshcat server and the robot drawn in it (nominal links, the
    plane of motion upright in Meshcat's world).  ``frames``: how many
    poses it has drawn."""

    def __init__(self, plant_params, fps: float = 30.0, port: int | None = None):
        from pydrake.geometry import Meshcat, MeshcatParams
        from pydrake.math import RigidTransform, RotationMatrix

        params = MeshcatParams()
        if port is not None:
            params.port = int(port)
        params.host = "localhost"
        log = logging.getLogger("drake")   # the command says where it listens, once
        level = log.level
        log.setLevel(logging.WARNING)
        try:
            self.meshcat = Meshcat(params)
        finally:
            log.setLevel(level)
        self.fps = float(fps)
        self.built = build_replay_visualizer(plant_params, self.meshcat, fps=fps)
        self.context = self.built.diagram.CreateDefaultContext()
        self.meshcat.SetTransform("/drake", RigidTransform(RotationMatrix.MakeXRotation(
            math.pi / 2)))
        self.frames = 0
        self._next = 0.0

    @property
    def url(self) -> str:
        """Where a browser on this machine sees the view."""
        return self.meshcat.web_url()

    def show(self, t: float, q) -> None:
        """Draw the robot at joint angles ``q`` (rad) at simulated time ``t``."""
        plant = self.built.plant
        self.context.SetTime(float(t))
        plant.SetPositions(plant.GetMyMutableContextFromRoot(self.context),
                           np.asarray(q, dtype=float)[:2])
        self.built.diagram.ForcedPublish(self.context)
        self.frames += 1

    def attach(self, sim, built) -> None:
        """Draw ``built``'s simulated robot as ``sim`` advances (a monitor,
        every 1/fps of simulated time) and pace ``sim`` at real time."""
        from pydrake.systems.framework import EventStatus

        plant = built.plant

        def monitor(root):
            t = root.get_time()
            if t + 1e-12 >= self._next:
                self.show(t, plant.GetPositions(plant.GetMyContextFromRoot(root)))
                self._next = t + 1.0 / self.fps
            return EventStatus.Succeeded()

        self._next = sim.get_context().get_time()
        self.built["visualizer"].StartRecording(False)
        sim.set_monitor(monitor)
        sim.set_target_realtime_rate(1.0)

    def finish(self) -> None:
        """The swing is over: its frames become the view's animation (the
        *Animations* panel plays and scrubs it)."""
        vis = self.built["visualizer"]
        vis.StopRecording()
        vis.PublishRecording()

    def close(self) -> None:
        """Stop the server."""
        self.meshcat.Delete()
        self.meshcat = None
