"""Self-contained HTML replays of logged motion, from Drake's Meshcat.

The robot is the BPLIR plant's own geometry, drawn by Drake's
``MeshcatVisualizer`` while its recording is on; the line, its obstacles
and the grippers' clamps are Meshcat objects in the plane of motion.  The
recorded animation and every object are embedded in the file that
``Meshcat.StaticHtml()`` writes (the viewer's JavaScript inlined, the
scene as base64 data): it plays and scrubs offline in any browser
(Meshcat's *Animations* panel: play, pause, the time slider).

Data first: :class:`ReplayScene` describes what to draw, in the plane of
motion (x along the horizontal, y up, metres, the holding gripper at the
origin unless a base pose is given per frame); :func:`replay_html` renders
it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..io import write_text_atomic
from ..params import PlantParams
import html as html_text
import re
import logging
from ..diagrams.visual import build_replay_visualizer

#: colours (RGBA) of the scene
LINE_RGBA = (0.25, 0.25, 0.28, 1.0)
OBSTACLE_RGBA = (0.85, 0.15, 0.12, 1.0)
CLAMP_RGBA = (0.1, 0.1, 0.1, 1.0)
TARGET_RGBA = (0.1, 0.7, 0.2, 0.45)


@dataclass
class ReplayScene:
    """What surrounds the robot, in the plane of motion (metres).

    ``line``: polyline vertices ``[(x, y), ...]`` of the conductor;
    ``obstacles``: ``(x, y, angle_rad, width_m)`` boxes on the line;
    ``targets``: ``(x, y)`` capture points (translucent spheres);
    ``clamps``: ``(x, y, angle_rad, t_on, t_off)`` closed grippers on the
    line, shown from ``t_on`` to ``t_off`` (s; ``inf`` for never off);
    ``view``: more ``(x, y)`` points the camera keeps in view (a whole
    stretch of line); ``camera_distance``: the camera's distance from the
    plane in units of the scene's size."""

    line: list = field(default_factory=list)
    obstacles: list = field(default_factory=list)
    targets: list = field(default_factory=list)
    clamps: list = field(default_factory=list)
    view: list = field(default_factory=list)
    camera_distance: float = 1.1


def plane_pose(x: float, y: float, angle: float = 0.0):
    """The pose of a point of the plane of motion, rotated by ``angle``
    about its normal (``/drake`` turns the plane upright, see below)."""
    from pydrake.math import RigidTransform, RotationMatrix

    return RigidTransform(RotationMatrix.MakeZRotation(angle), [x, y, 0.0])


def _cylinder_along_x(length: float, radius: float):
    """A Meshcat cylinder (axis along its z) and the rotation putting its
    axis along the plane's x."""
    from pydrake.geometry import Cylinder
    from pydrake.math import RotationMatrix

    return Cylinder(radius, length), RotationMatrix.MakeYRotation(math.pi / 2)


def add_scene(meshcat, scene: ReplayScene, recording_end: float, log_end: float) -> None:
    """The scene's objects; clamps shown from ``t_on`` to ``t_off`` where
    these fall in the log (``log_end``: its duration), an event after the
    last frame (``recording_end``) but inside the log at the last frame."""
    from pydrake.geometry import Box, Rgba, Sphere
    from pydrake.math import RigidTransform

    line = np.asarray(scene.line, dtype=float).reshape(-1, 2)
    for i, (a, b) in enumerate(zip(line[:-1], line[1:])):
        d = b - a
        length = float(np.hypot(*d))
        shape, R = _cylinder_along_x(length, 0.012)
        path = f"/drake/scene/line/{i}"
        meshcat.SetObject(path, shape, Rgba(*LINE_RGBA))
        X = plane_pose(*((a + b) / 2), math.atan2(d[1], d[0]))
        meshcat.SetTransform(path, X.multiply(RigidTransform(R)))
    for i, (x, y, angle, width) in enumerate(scene.obstacles):
        path = f"/drake/scene/obstacles/{i}"
        meshcat.SetObject(path, Box(width, 0.08, 0.08), Rgba(*OBSTACLE_RGBA))
        meshcat.SetTransform(path, plane_pose(x, y, angle))
    for i, (x, y) in enumerate(scene.targets):
        path = f"/drake/scene/targets/{i}"
        meshcat.SetObject(path, Sphere(0.05), Rgba(*TARGET_RGBA))
        meshcat.SetTransform(path, plane_pose(x, y))
    for i, (x, y, angle, t_on, t_off) in enumerate(scene.clamps):
        path = f"/drake/scene/clamps/{i}"
        shape, R = _cylinder_along_x(0.09, 0.035)
        meshcat.SetObject(path, shape, Rgba(*CLAMP_RGBA))
        meshcat.SetTransform(path, plane_pose(x, y, angle).multiply(RigidTransform(R)))
        # visibility is animated: hidden before t_on and from t_off on
        meshcat.SetProperty(path, "visible", t_on <= 0.0, 0.0)
        if 0.0 < t_on <= log_end:
            meshcat.SetProperty(path, "visible", True, float(min(t_on, recording_end)))
        if t_off <= log_end:
            meshcat.SetProperty(path, "visible", False, float(min(t_off, recording_end)))


def replay_html(plant: PlantParams, t, q, scene: ReplayScene, *, fps: float = 30.0,
                base=None, title: str = "BPLIR replay") -> str:
    """The HTML of a Meshcat replay of the joint angles ``q`` (n x 2, rad,
    the conventions of docs/concepts.md) logged at times ``t`` (s), resampled at ``fps``.

    ``base``: optional ``(n x 3)`` pose of the holding gripper (x, y,
    rotation) per logged time, for motion that moves the robot along the
    line; ``None`` holds it at the origin."""
    t = np.asarray(t, dtype=float)
    q = np.asarray(q, dtype=float).reshape(len(t), 2)
    if len(t) < 2 or not np.all(np.diff(t) >= 0):
        raise ValueError("a replay needs at least two logged times in increasing order")
    meshcat = quiet_meshcat()
    try:
        built = build_replay_visualizer(plant, meshcat, fps=fps)
        diagram, mbp, vis = built.diagram, built.plant, built["visualizer"]
        context = diagram.CreateDefaultContext()
        plant_context = mbp.GetMyMutableContextFromRoot(context)
        frames = np.arange(int(math.floor((t[-1] - t[0]) * fps + 0.5)) + 1) / fps
        qs = np.column_stack([np.interp(frames + t[0], t, q[:, i]) for i in range(2)])
        bs = None if base is None else np.column_stack(
            [np.interp(frames + t[0], t, np.asarray(base, dtype=float)[:, i]) for i in range(3)])
        vis.StartRecording(False)
        for k, (tk, qk) in enumerate(zip(frames, qs)):
            # the recording files a publish under frame floor(t fps): a hair
            # past k / fps keeps rounding from filing two frames under one
            context.SetTime(float(tk) + 1e-9)
            mbp.SetPositions(plant_context, qk)
            diagram.ForcedPublish(context)
            if bs is not None:
                meshcat.SetTransform("/drake/robot", plane_pose(*bs[k]), float(tk) + 1e-9)
        add_scene(meshcat, scene, float(frames[-1]), float(t[-1] - t[0]))
        vis.StopRecording()
        vis.get_mutable_recording().set_autoplay(True)
        vis.PublishRecording()
        stand_upright(meshcat)
        set_camera(meshcat, scene, plant)
        page = meshcat.StaticHtml()
    finally:
        meshcat.Delete()
        del meshcat

    return re.sub(r"<title>[^<]*</title>", f"<title>{html_text.escape(title)}</title>", page,
                  count=1)


def quiet_meshcat(params=None):
    """A Meshcat server (with ``params``, a ``MeshcatParams``) without its
    "listening for connections" log line: a replay is written to a file,
    and a live view says its address itself."""
    from pydrake.geometry import Meshcat

    log = logging.getLogger("drake")
    level = log.level
    log.setLevel(logging.WARNING)
    try:
        return Meshcat() if params is None else Meshcat(params)
    finally:
        log.setLevel(level)


def stand_upright(meshcat) -> None:
    """Stand the plane of motion (x right, y up) upright in Meshcat's z-up
    world: x stays, y becomes z."""
    from pydrake.math import RigidTransform, RotationMatrix

    meshcat.SetTransform("/drake", RigidTransform(RotationMatrix.MakeXRotation(math.pi / 2)))


def set_camera(meshcat, scene: ReplayScene, plant: PlantParams) -> None:
    """Look at the plane of motion from its front, everything in view."""
    reach = plant.l1 + plant.l2
    pts = np.asarray(list(scene.targets) + list(scene.view) + [(0.0, 0.0), (0.0, -reach)],
                     dtype=float)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    centre = (lo + hi) / 2
    size = max(hi[0] - lo[0], hi[1] - lo[1], reach) + 0.6
    # plane (x, y) -> world (x, 0, y); the viewer on the plane's +z side
    # (world -y) sees x to the right and y up
    meshcat.SetCameraPose(camera_in_world=[centre[0], -scene.camera_distance * size, centre[1]],
                          target_in_world=[centre[0], 0.0, centre[1]])
    # the ground grid and the world axes would cut through the line
    meshcat.SetProperty("/Grid", "visible", False)
    meshcat.SetProperty("/Axes", "visible", False)


def write_replay_html(path, html: str) -> Path:
    """Write a replay atomically."""
    return write_text_atomic(Path(path), html)
