"""Simulation: objects a-l, scenes, layouts, depth rendering and the floating gripper (MuJoCo MJX).

Everything here acts on ONE world; `graspjax.batch.program` batches worlds with `jax.vmap`.
"""

from graspjax.codes import Outcome
from graspjax.sim.objects import BASIC, INDUSTRIAL, OBJECTS, ObjectSpec, parse_letters
from graspjax.sim.scene import Scene, build_scene, scene_for
from graspjax.sim.world import Execution, GraspPose

__all__ = ["BASIC", "INDUSTRIAL", "OBJECTS", "Execution", "GraspPose", "ObjectSpec", "Outcome",
           "Scene", "build_scene", "parse_letters", "scene_for"]
