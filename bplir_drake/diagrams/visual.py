"""The robot drawn by Drake's Meshcat visualizer, for replays of logged
motion (no dynamics run: the plant only supplies the geometry poses)."""
from __future__ import annotations

from ..params import PlantParams
from ..systems.plant import add_acrobot_plant
from .parts import Built


def build_replay_visualizer(p: PlantParams, meshcat, *, fps: float = 30.0,
                            prefix: str = "robot") -> Built:
    """The BPLIR plant with its scene graph (links, elbow and gripper
    spheres) and a ``MeshcatVisualizer`` publishing to ``meshcat`` under
    ``/drake/<prefix>`` at ``fps`` (the recording's frame rate).
    ``systems["visualizer"]`` is the visualizer."""
    from pydrake.geometry import MeshcatVisualizer, MeshcatVisualizerParams, Role
    from pydrake.systems.framework import DiagramBuilder

    builder = DiagramBuilder()
    plant, scene_graph = add_acrobot_plant(builder, p, scene_graph=True)
    vis_params = MeshcatVisualizerParams(role=Role.kIllustration, prefix=prefix,
                                         publish_period=1.0 / fps)
    visualizer = MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat, vis_params)
    diagram = builder.Build()
    diagram.set_name("bplir_replay")
    return Built(diagram, plant, {"visualizer": visualizer, "scene_graph": scene_graph})
