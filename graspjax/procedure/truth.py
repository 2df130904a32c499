"""The simulation's ground truth, for judging and attribution only: which surface each pixel
shows, the target's true faces, a chosen plane judged against them. `with_oracle` is the one
place labels can reach a decision, and only under the `perception.oracle` ablation."""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp

from graspjax.codes import Surface
from graspjax.config import Config
from graspjax.procedure.state import PlaneTruth
from graspjax.sim.raycast import world_planes
from graspjax.sim.scene import Scene


def surfaces(objects: jax.Array, table: jax.Array, depth: jax.Array, target) -> jax.Array:
    """`Surface` (H, W) int32 of each pixel, from the object index (H, W) and the table (H, W)."""
    return jnp.select([~(depth > 0), (objects == target) & (target >= 0), objects >= 0, table],
                      [Surface.NONE, Surface.TARGET, Surface.OTHER_OBJECT, Surface.TABLE],
                      Surface.BIN).astype(jnp.int32)


def target_pixels(surface: jax.Array) -> jax.Array:
    """Pixels (H, W) bool a view's ground truth `surface` (H, W) puts on the target: for
    judging and for the oracle ablation only (`with_oracle`), never for a decision."""
    return surface == Surface.TARGET


def target_faces(scene: Scene, data, target) -> tuple[jax.Array, jax.Array]:
    """Outward unit normals (G * P, 3) of the target's faces in the world (state after
    kinematics), and which are real faces (G * P,) bool (not padding, not another piece's)."""
    normals, _ = world_planes(scene.solids, data.geom_xpos, data.geom_xmat)
    real = ((jnp.asarray(scene.piece_object) == target) & (target >= 0))[:, None] & (
        jnp.linalg.norm(scene.solids.planes[..., :3], axis=-1) > 0.5)
    return normals.reshape(-1, 3), real.reshape(-1)


def plane_truth(surface: jax.Array, inliers: jax.Array, normal: jax.Array, faces, found,
                view_axis: jax.Array) -> PlaneTruth:
    """Judge a chosen plane: its inliers (H, W) bool against the `Surface` (H, W) of each pixel,
    its world normal (3,) against the target's faces (`target_faces`), and the tilt of the view
    whose optical axis (3,) looks along its negative normal."""
    counts = jnp.stack([jnp.sum(inliers & (surface == c)) for c in range(4)])
    on_target = counts[Surface.TARGET] / jnp.maximum(jnp.sum(counts), 1)
    normals, real = faces
    cosine = jnp.max(jnp.where(real, normals @ normal, -1.0))
    nan = jnp.float32(jnp.nan)
    return PlaneTruth(
        surface=jnp.where(found, jnp.argmax(counts), Surface.NONE).astype(jnp.int32),
        on_target=jnp.where(found, on_target, nan).astype(jnp.float32),
        normal_error_deg=jnp.where(found, jnp.rad2deg(jnp.arccos(jnp.clip(cosine, -1.0, 1.0))), nan),
        view_tilt_deg=jnp.where(found, jnp.rad2deg(jnp.arccos(jnp.clip(-view_axis[2], -1.0, 1.0))),
                                nan))


def with_oracle(config: Config, seen, labelled: Callable):
    """What the method works on: `seen`, found from depth alone; only the ablation
    `perception.oracle` (never in a preset: tests/test_config.py) puts `labelled()`, taken from
    the renderer's labels, in its place. The one place where labels can reach a decision; the
    flag is static, so without it no label-made choice is even traced."""
    return labelled() if config.perception.oracle else seen
