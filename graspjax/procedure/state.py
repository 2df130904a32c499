"""What a world carries through a round and what it returns: its spec, its state between
attempts, one attempt's record and views."""

from __future__ import annotations

import jax
import numpy as np

from graspjax.codes import Surface
from graspjax.config import Config
from graspjax.perception import (
    Alignment,
    Grasp,
)
from graspjax.sim.clutter import LayoutStats
from graspjax.sim.pile import Drops
from graspjax.sim.scene import mjx
from graspjax.sim.world import PhysicsState
from graspjax.tree import pytree_dataclass


@pytree_dataclass
class WorldSpec:
    """What a world plays, fixed for its round (one row of a batch)."""

    seed: jax.Array  # () int32 seed of the grid point the world belongs to
    setup: jax.Array  # () int32 paper setup 1, 2 or 3
    trial: jax.Array  # () int32 trial (Setup 1) or round (Setups 2, 3)
    order: jax.Array  # (A,) int32 scene objects in attempt order (Setup 1: the one object)
    members: jax.Array  # (n,) bool objects in the layout
    config: Config  # this world's traced configuration values


@pytree_dataclass
class RoundState:
    """A world between attempts."""

    data: mjx.Data  # the physics state
    attempted: jax.Array  # (n,) bool objects that had their attempt
    failures: jax.Array  # () int32 attempts in a row that lifted nothing (a stuck round)
    removed: jax.Array  # (n,) bool objects lifted out of the scene
    key: jax.Array  # the round's PRNG key (its layout key)
    drops: Drops  # the objects the first call drops as it settles (Setup 3's pile); none after


@pytree_dataclass
class PlaneTruth:
    """The chosen re-alignment plane of one view against the simulation's ground truth."""

    surface: jax.Array  # () int32 Surface most of the plane's inliers lie on (NONE: no plane)
    on_target: jax.Array  # () share of the plane's inliers on the target (nan: no plane)
    normal_error_deg: jax.Array  # () angle from the plane's normal to the nearest true face
    # normal of the target at its current pose (deg; nan: no plane)
    view_tilt_deg: jax.Array  # () the re-aligned view's optical axis from straight down (deg)


@pytree_dataclass
class TargetClutter:
    """How crowded the attempt's target was when the robot looked (ground truth, to attribute
    success to clutter; `clutter.object_clutter` before the attempt)."""

    touching: jax.Array  # () bool in contact with another object
    resting: jax.Array  # () bool resting on another object
    covered: jax.Array  # () bool another object rests on it
    gap: jax.Array  # () nearest outline distance seen from above to another object (m;
    # negative: overlapping; inf: alone; nan: no target)
    finger_clearance: jax.Array  # () free space around the open fingers at the executed grasp
    # pose to anything but the target and the table (m; `world.finger_clearance`; nan: none)


NO_CLUTTER = TargetClutter(touching=np.bool_(False), resting=np.bool_(False),
                           covered=np.bool_(False), gap=np.float32(np.nan),
                           finger_clearance=np.float32(np.nan))


@pytree_dataclass
class Record:
    """One attempt of one world, fixed-shape (`batch/rows.py` turns it into one CSV row)."""

    target: jax.Array  # () int32 scene object the attempt is credited to: the one the target
    # point lies on (ground truth, for the record only); -1 if none
    aimed: jax.Array  # () bool the method chose a target point (an attempt was made)
    reason: jax.Array  # () int32 Reason
    outcome: jax.Array  # () int32 Outcome (NOT_EXECUTED without a grasp)
    grasp_found: jax.Array  # () bool
    reorientations: jax.Array  # () int32 re-alignments made
    detect_reason: jax.Array  # () int32 GraspReason of the last view searched
    align_reason: jax.Array  # () int32 AlignReason of the last re-alignment, -1 if none tried
    lifted_object: jax.Array  # () int32 scene object lifted, -1 if none
    rise: jax.Array  # () target rise after the hold (m; nan if not executed)
    opening: jax.Array  # () half jaw opening after closing (m; nan if not executed)
    tcp: jax.Array  # (3,) planned grasp: point between the finger tips (world, m; nan if none)
    approach: jax.Array  # (3,) planned grasp: approach direction
    closing: jax.Array  # (3,) planned grasp: closing axis
    realign: PlaneTruth  # (R,) the plane of each re-alignment taken, judged by ground truth
    grasp_object: jax.Array  # () int32 object under the planned grasp centre (ground truth; -1:
    # none, or no grasp)
    segment_precision: jax.Array  # () share of the centred view's target surface (where z_min
    # was taken) on the credited object (ground truth; nan: empty)
    segment_recall: jax.Array  # () share of the credited object's visible pixels in that surface
    layout: LayoutStats  # the scene's density after this call's settling
    clutter: TargetClutter  # the target's clutter before the attempt (ground truth)


@pytree_dataclass
class Views:
    """Every image of one attempt, for debug pictures: the overview, then V = R + 1 views."""

    depth: jax.Array  # (1 + V, H, W) metric depth
    target_mask: jax.Array  # (1 + V, H, W) bool pixels of the credited object (ground truth)
    seed_mask: jax.Array  # (1 + V, H, W) bool where the method took z_min: the overview's
    # candidates, then the target's surface in each view
    rotation: jax.Array  # (1 + V, 3, 3) camera-to-world rotation
    position: jax.Array  # (1 + V, 3) camera centre
    looked: jax.Array  # (1 + V,) bool the procedure took this image
    grasp: Grasp  # detection of each view (leading axis V)
    alignment: Alignment  # alignment of each view (leading axis V)
    state: PhysicsState  # the world before the attempt (a replay starts here: sim/replay.py)


NO_LAYOUT = LayoutStats(objects=np.int32(-1), touching=np.int32(-1), near=np.int32(-1),
                        stacked=np.int32(-1), gap=np.float32(np.nan),
                        spread=np.float32(np.nan))  # not measured


NO_PLANE = PlaneTruth(surface=np.int32(Surface.NONE), on_target=np.float32(np.nan),  # numpy: no
                       normal_error_deg=np.float32(np.nan), view_tilt_deg=np.float32(np.nan))  # backend
