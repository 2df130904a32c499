"""Perception-only study of the re-alignment's plane choice (paper 3.2: window and threshold).

Worlds are placed and settled with the physics exactly as a run places them (same seeds,
same layouts), then each takes its first attempt's first view: overview, target, centred
view, T-beam search. No grasp is executed. For every grid point of the alignment's traced
values (`align.window_px`, `align.distance_threshold`, ...), the planes are scored on every
view and judged against the simulation's ground truth (`procedure.plane_truth`): what the
chosen plane's inliers lie on, how far its normal is from the target's nearest true face,
and how far the re-aligned view would tilt. The views that matter are those whose first view
holds no grasp: the attempts that re-align. One compiled scoring call serves every point.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
import pandas as pd

from graspjax.batch.plan import chunks
from graspjax.batch.program import program
from graspjax.codes import Surface
from graspjax.config import AlignConfig, Config
from graspjax.perception import align_tool
from graspjax.perception.align import plane_inliers
from graspjax.procedure import (
    PlaneTruth,
    RoundState,
    WorldSpec,
    attempt_keys,
    eligible_objects,
    first_look,
    in_bin,
    plane_truth,
    round_goes_on,
    target_faces,
    view,
    view_keys,
)
from graspjax.schema import PLANES_COLUMNS, SURFACE_LABELS
from graspjax.sim.scene import mjx
from graspjax.sim.world import physics_model
from graspjax.stats import detectable_difference, wilson
from graspjax.tree import pytree_dataclass


@pytree_dataclass
class FirstView:
    """A world's first view of its first attempt, with the ground truth to judge planes."""

    depth: jax.Array  # (H, W) metric depth the method sees
    mask: jax.Array  # (H, W) bool the target's surface the method found (where it takes z_min)
    surface: jax.Array  # (H, W) int32 `Surface` of each pixel (ground truth, to judge)
    rotation: jax.Array  # (3, 3) camera-to-world rotation of the view
    face_normals: jax.Array  # (F, 3) outward unit normals of the target's faces (world)
    face_real: jax.Array  # (F,) bool real faces of the target (not padding)
    key: jax.Array  # () PRNG key of the view's alignment (random hypotheses)
    target: jax.Array  # () int32 the object the target point lies on (-1: none)
    grasp_found: jax.Array  # () bool the T-beam found a grasp (the attempt would not re-align)


def first_view(scene, state: RoundState, spec: WorldSpec) -> FirstView:
    """One settled world's first view, with the keys attempt 0 uses (the same image a run sees)."""
    config = spec.config
    camera = config.camera.camera()
    data = mjx.kinematics(physics_model(scene, config), state.data)
    eligible, attempting = eligible_objects(state, spec), round_goes_on(state, spec)
    in_the_bin = in_bin(spec)
    k_search, _ = attempt_keys(state, 0)
    target, aimed, point, (rotation, position), _, k_views = first_look(
        scene, data, eligible, attempting, in_the_bin, k_search, config)
    target = jnp.where(aimed, target, -1)
    key = jax.random.fold_in(k_views, 0)
    first = view(scene, data, rotation, position, target, point, in_the_bin, camera, config, key)
    normals, real = target_faces(scene, data, target)
    return FirstView(depth=first.depth, mask=first.mask, surface=first.surface, rotation=rotation,
                     face_normals=normals, face_real=real, key=view_keys(key)[1], target=target,
                     grasp_found=first.grasp.found & aimed)


def judge(view: FirstView, align: AlignConfig, config: Config) -> PlaneTruth:
    """The plane the re-alignment would choose on one view under `align`, and its ground truth."""
    camera = config.camera.camera()
    alignment = align_tool(view.depth, camera, align, view.key, seed_mask=view.mask)
    normal = view.rotation @ alignment.normal  # world; the re-aligned view looks along -normal
    return plane_truth(view.surface, plane_inliers(view.depth, camera, alignment, align), normal,
                       (view.face_normals, view.face_real), alignment.found & (view.target >= 0),
                       -normal)


def study(groups, points: list[Config], batch: int, progress: Callable[[int], None] = lambda n: None
          ) -> tuple[pd.DataFrame, dict]:
    """Settle every world of `groups` (`plan` of one point), take its first view and judge
    the planes of every grid point in `points` (which differ in traced alignment values only).

    Returns one row per (grid point, world) (`schema.PLANES_COLUMNS`) and the timings: settle and view
    seconds, the scoring call's compile seconds, and the scoring's views per second.
    """
    timings = {"settle_s": 0.0, "view_s": 0.0, "score_compile_s": 0.0, "score_s": 0.0,
               "views_scored": 0}
    frames, compiled = [], {}
    for chunk in chunks(groups, batch):
        group = groups[chunk.group]
        if chunk.group not in compiled:
            shared = program(group, batch, keep_views=False)  # padded to the chunks' size
            scene = shared.scene
            look = jax.jit(jax.vmap(lambda s, w, scene=scene: first_view(scene, s, w)))
            compiled[chunk.group] = shared, look, None
        shared, look, score = compiled[chunk.group]
        start = time.perf_counter()
        state, spec = shared.settle(chunk.worlds, [group.config])
        jax.block_until_ready(state)
        timings["settle_s"] += time.perf_counter() - start

        start = time.perf_counter()
        views = jax.block_until_ready(look(state, spec))
        timings["view_s"] += time.perf_counter() - start
        if score is None:
            start = time.perf_counter()
            score = jax.jit(jax.vmap(judge, in_axes=(0, None, None))).lower(
                views, points[0].align, group.config).compile()
            timings["score_compile_s"] += time.perf_counter() - start
            compiled[chunk.group] = shared, look, score

        n = len(chunk.worlds)
        target = np.asarray(views.target)[:n]
        letters = np.array(shared.scene.letters + ("",))
        world_columns = {
            "setup": [w.setup for w in chunk.worlds],
            "trial": [w.trial for w in chunk.worlds],
            "object": [w.objects[0] if w.setup == 1 else "".join(w.objects) for w in chunk.worlds],
            "target": letters[target],
            "first_view_grasp": np.asarray(views.grasp_found)[:n]}
        for i, point in enumerate(points):
            start = time.perf_counter()
            truth = jax.block_until_ready(score(views, point.align, group.config))
            timings["score_s"] += time.perf_counter() - start
            timings["views_scored"] += n
            truth = jax.tree.map(lambda x, n=n: np.asarray(x)[:n], truth)
            frames.append(pd.DataFrame({
                "point": i, **world_columns,
                "plane_found": truth.surface != Surface.NONE,
                "surface": SURFACE_LABELS[truth.surface + 1],
                "on_target": truth.on_target,
                "normal_error_deg": truth.normal_error_deg,
                "view_tilt_deg": truth.view_tilt_deg}))
        progress(n)
    timings["views_per_s"] = timings["views_scored"] / max(timings["score_s"], 1e-9)
    return pd.concat(frames, ignore_index=True)[list(PLANES_COLUMNS)], timings


def summarize(rows: pd.DataFrame, grid: dict[str, list]) -> pd.DataFrame:
    """Per grid point, over the views whose first view has no grasp (those that re-align): how
    often a plane is found, lies on the target (Wilson 95 % interval), its normal's error and the
    view's tilt, and the smallest on-target difference this many views can detect (computed as
    for independent samples: conservative, since every point scores the same views)."""
    out = []
    realigning = rows[~rows.first_view_grasp & (rows.target != "")]
    for point in sorted(rows.point.unique()):  # a point whose views all found a grasp: views 0
        part = realigning[realigning.point == point]
        found = part[part.plane_found]
        on = (found.surface == "target").sum()
        low, high = wilson(on, len(found))
        rate = on / len(found) if len(found) else np.nan
        out.append({**{k: v[point] for k, v in grid.items()}, "point": point,
                    "views": len(part), "plane_found": len(found) / len(part) if len(part) else np.nan,
                    "on_target": rate, "on_target_low": low, "on_target_high": high,
                    "detectable_difference": detectable_difference((on + 1) / (len(found) + 2),
                                                                   len(found)),
                    "normal_error_median_deg": found.normal_error_deg.median(),
                    "within_5deg": (found.normal_error_deg < 5).mean(),
                    "view_tilt_median_deg": found.view_tilt_deg.median()})
    return pd.DataFrame(out)
