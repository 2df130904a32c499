"""Simulation: objects a-l, scenes, layouts, depth rendering and the floating gripper (MuJoCo MJX).

Per-world functions live in `world.py`; `Simulator` batches them with
`jax.vmap` and compiles each once per scene.
"""

from graspjax.sim.objects import BASIC, INDUSTRIAL, OBJECTS, ObjectSpec, parse_letters
from graspjax.sim.scene import Scene, build_scene
from graspjax.sim.world import Attempt, GraspPose, Outcome, Simulator, simulator

__all__ = ["BASIC", "INDUSTRIAL", "OBJECTS", "Attempt", "GraspPose", "ObjectSpec", "Outcome",
           "Scene", "Simulator", "build_scene", "parse_letters", "simulator"]
