"""A swing shown live in Drake's Meshcat while it is simulated.

:class:`LiveView` starts a Meshcat server on this machine (its address is
``url``) and draws the simulated robot there -- the plant's own geometry,
beside a scene (:meth:`LiveView.scene`: the line, its obstacles, the
capture point) -- as the simulator advances: a monitor of the simulator
poses the drawing at ``fps`` frames per simulated second and paces the
simulation at real time, so that what the browser shows is the swing as
it would happen.  After the swing, the view replays it on its
*Animations* panel, like the self-contained HTML replay."""
from __future__ import annotations

import numpy as np

from ..diagrams.visual import build_replay_visualizer
from .replay import add_scene, plane_pose, quiet_meshcat, set_camera, stand_upright


class LiveView:
    """The Meshcat server and the robot drawn in it (nominal links, the
    plane of motion upright in Meshcat's world).  ``frames``: how many
    poses it has drawn."""

    def __init__(self, plant_params, fps: float = 30.0, port: int | None = None,
                 rate: float = 1.0):
        from pydrake.geometry import MeshcatParams

        params = MeshcatParams()
        if port is not None:
            params.port = int(port)
        params.host = "localhost"
        self.meshcat = quiet_meshcat(params)
        self.fps, self.rate, self.plant_params = float(fps), float(rate), plant_params
        self.built = build_replay_visualizer(plant_params, self.meshcat, fps=fps)
        self.context = self.built.diagram.CreateDefaultContext()
        stand_upright(self.meshcat)
        self.frames = 0
        self._next = 0.0
        self._recording = False

    @property
    def url(self) -> str:
        """Where a browser on this machine sees the view."""
        return self.meshcat.web_url()

    def scene(self, scene) -> None:
        """Draw ``scene`` (a :class:`~bplir_drake.analysis.replay.ReplayScene`:
        the line, obstacles, targets) and look at it."""
        add_scene(self.meshcat, scene, 0.0, 0.0)
        set_camera(self.meshcat, scene, self.plant_params)

    def show(self, t: float, q, base=None) -> None:
        """Draw the robot at joint angles ``q`` (rad) at simulated time ``t``,
        its holding gripper at ``base`` (x, y, rotation; None: the origin)."""
        if base is not None:
            self.meshcat.SetTransform("/drake/robot", plane_pose(*base))
        plant = self.built.plant
        self.context.SetTime(float(t))
        plant.SetPositions(plant.GetMyMutableContextFromRoot(self.context),
                           np.asarray(q, dtype=float)[:2])
        self.built.diagram.ForcedPublish(self.context)
        self.frames += 1

    def attach(self, sim, built, pose=None, offset: float = 0.0) -> None:
        """Draw ``built``'s simulated robot as ``sim`` advances (a monitor,
        every 1/fps of simulated time) and pace ``sim`` at ``rate`` times
        real time (0: as fast as it goes).  ``pose(state) -> (q, base)``
        maps the simulated state to the drawn robot's angles and holding
        gripper (a traversal's swapped robot); ``offset`` (s) is added to
        the simulated time."""
        from pydrake.systems.framework import EventStatus

        plant = built.plant

        def monitor(root):
            t = root.get_time()
            if t + 1e-12 >= self._next:
                pc = plant.GetMyContextFromRoot(root)
                x = np.r_[plant.GetPositions(pc), plant.GetVelocities(pc)]
                q, base = (x[:2], None) if pose is None else pose(x)
                self.show(offset + t, np.ravel(q), None if base is None else np.ravel(base))
                self._next = t + 1.0 / self.fps
            return EventStatus.Succeeded()

        self._next = sim.get_context().get_time()
        if not self._recording:
            self.built["visualizer"].StartRecording(False)
            self._recording = True
        sim.set_monitor(monitor)
        sim.set_target_realtime_rate(self.rate)

    def finish(self) -> None:
        """The swing is over: its frames become the view's animation (the
        *Animations* panel plays and scrubs it)."""
        if self._recording:
            vis = self.built["visualizer"]
            vis.StopRecording()
            vis.PublishRecording()
            self._recording = False

    def close(self) -> None:
        """Stop the server."""
        self.meshcat.Delete()
        self.meshcat = None


class Following:
    """A traversal's swing shown in a :class:`LiveView`: the drawn robot is
    the original one, its holding gripper where the traversal holds
    (``pose``), the time the traversal's (``offset``); the view's animation
    is made when the whole traversal ends (:meth:`LiveView.finish`)."""

    def __init__(self, view: LiveView, pose, offset: float):
        self.view, self.pose, self.offset = view, pose, offset

    def attach(self, sim, built) -> None:
        """As :meth:`LiveView.attach`, with this swing's pose and offset."""
        self.view.attach(sim, built, self.pose, self.offset)

    def finish(self) -> None:
        """Nothing yet: the traversal goes on."""
