"""The paper's procedure (Fig. 1) in one simulated world: perception joined to the physics.

1. Overview: the tool camera looks straight down from `camera_height` over
   the workspace centre.
2. Select: the nearest point (z_min) among the objects still to be attempted
   is the target. (Which objects are "still to be attempted" is protocol
   bookkeeping and uses the simulator's object identities; everything the
   method itself decides uses depth alone.)
3. Centre: the camera moves parallel to the table until its optical axis
   passes through that point, and looks again.
4. Detect a grasp (double T-beam), with z_min taken on the target's pixels.
5. Re-align when none is found: the camera turns to look along the negative
   normal of the best neighbour plane, at the same distance from the plane's
   inliers, and detects again; at most `max_reorientations` times.
6. The grasp (camera frame) becomes a world-frame grasp pose for the gripper.

Every function acts on ONE world; `experiment.py` vmaps and jits them.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from graspjax.camera import Camera
from graspjax.config import Config
from graspjax.geometry import look_down, rotation_between
from graspjax.perception import Alignment, Grasp, align_tool, detect_grasp
from graspjax.sim.render import render_depth_and_piece
from graspjax.sim.scene import Scene
from graspjax.sim.world import GraspPose


@dataclasses.dataclass(frozen=True)
class Target:
    """The object chosen in the overview image of one world."""

    index: jax.Array  # () int32 object index, -1 if no eligible object is visible
    point: jax.Array  # (3,) world position of its z_min point


@dataclasses.dataclass(frozen=True)
class View:
    """What one camera pose yields: a grasp attempt and a plane for re-alignment."""

    grasp: Grasp  # camera frame of this view
    alignment: Alignment  # camera frame of this view
    grasp_pose: GraspPose  # the grasp in the world frame (valid iff grasp.found)
    next_rotation: jax.Array  # (3, 3) camera-to-world rotation of the re-aligned view
    next_position: jax.Array  # (3,) camera centre of the re-aligned view
    can_realign: jax.Array  # () bool: a plane was found and its view is reachable


for _cls in (Target, View):
    jax.tree_util.register_dataclass(
        _cls, data_fields=[f.name for f in dataclasses.fields(_cls)], meta_fields=[])


def _look(scene: Scene, data, rotation, position, camera: Camera, config: Config, key):
    """Depth image (H, W) and object index per pixel (H, W) (-1: table or nothing)."""
    depth, piece = render_depth_and_piece(scene.render, data.geom_xpos, data.geom_xmat, rotation,
                                          position, camera, config.camera, key)
    objects = jnp.asarray(scene.piece_object)
    return depth, jnp.where(piece >= 0, objects[jnp.maximum(piece, 0)], -1)


def overview_pose(config: Config):
    """The start pose: straight down over the workspace centre."""
    return look_down(jnp.array([0.0, 0.0, config.procedure.camera_height]))


def select_target(scene: Scene, data, eligible: jax.Array, camera: Camera, config: Config,
                  key) -> Target:
    """Overview image; the nearest pixel among `eligible` (n,) objects picks the target."""
    rotation, position = overview_pose(config)
    depth, obj = _look(scene, data, rotation, position, camera, config, key)
    allowed = (obj >= 0) & eligible[jnp.maximum(obj, 0)] & (depth > 0)
    flat = jnp.argmin(jnp.where(allowed, depth, jnp.inf).reshape(-1))
    v, u = jnp.divmod(flat, camera.width)
    point_cam = camera.unproject(jnp.stack([u, v]).astype(jnp.float32), depth.reshape(-1)[flat])
    seen = allowed.reshape(-1)[flat]
    return Target(index=jnp.where(seen, obj.reshape(-1)[flat], -1).astype(jnp.int32),
                  point=rotation @ point_cam + position)


def centred_pose(target: Target, config: Config):
    """Camera moved parallel to the table so its optical axis passes through the target."""
    return look_down(jnp.array([target.point[0], target.point[1],
                                config.procedure.camera_height]))


def view(scene: Scene, data, rotation, position, target: jax.Array, camera: Camera,
         config: Config, key) -> View:
    """Look from a pose: detect a grasp and score re-alignment planes on the target."""
    k_render, k_align = jax.random.split(key)
    depth, obj = _look(scene, data, rotation, position, camera, config, k_render)
    mask = obj == target
    grasp = detect_grasp(depth, camera, config.detect, config.gripper, seed_mask=mask)
    alignment = align_tool(depth, camera, config.align, k_align, seed_mask=mask)

    approach = rotation[:, 2]
    centre = rotation @ grasp.position + position
    pose = GraspPose(tcp=centre + grasp.depth * approach, approach=approach,
                     closing=rotation @ grasp.closing_axis, valid=grasp.found)

    # Re-aligned view: optical axis along the negative plane normal, at the same distance
    # from the inliers' centroid, turned from the current view by the smallest rotation.
    normal = rotation @ alignment.normal
    point = rotation @ alignment.point + position
    next_rotation = rotation_between(approach, -normal) @ rotation
    next_position = point + jnp.linalg.norm(alignment.point) * normal
    reachable = (next_position[2] >= config.procedure.min_view_height) & (normal[2] > 0)
    return View(grasp=grasp, alignment=alignment, grasp_pose=pose,
                next_rotation=jnp.where(alignment.found, next_rotation, rotation),
                next_position=jnp.where(alignment.found, next_position, position),
                can_realign=alignment.found & reachable)
