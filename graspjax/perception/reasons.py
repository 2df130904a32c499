"""Integer outcome codes carried in arrays (failures are data, never exceptions under jit)."""

from enum import IntEnum

import jax.numpy as jnp
import numpy as np


class GraspReason(IntEnum):
    """Why `detect_grasp` found (0) or did not find a grasp.

    Candidate-level codes are ordered by how far a T-beam placement got
    through the checks; an image's overall code is the furthest any of its
    candidates reached (or an earlier, image-level failure).
    """

    FOUND = 0  # a valid grasp was found
    NO_DEPTH = 1  # no valid depth pixel in the image
    SURFACE_TOO_SMALL = 2  # the target surface cluster has too few pixels
    NO_EDGES = 3  # fewer than two straight edges on the contour
    NO_ANTIPODAL = 4  # no pair of edges with opposite normals facing each other
    TOO_NARROW = 5  # antipodal pairs exist, all narrower than `min_width`
    TOO_WIDE = 6  # antipodal pairs exist, none fits inside the opening
    OUT_OF_VIEW = 7  # the T-beam leaves the image
    COLLISION = 8  # a T-beam corner lies inside the surface cluster
    NO_ROOM = 9  # the depth at the fingers leaves no room to reach grasp depth
    NO_WALL = 10  # beyond an edge the surface falls too gently for a finger to hold it
    JAWS_BLOCKED = 11  # real images: a jaw's path on the full-resolution image stands above its tips


# Stage order of the candidate checks: a larger stage got further.
CANDIDATE_STAGE = {
    GraspReason.NO_ANTIPODAL: 0,
    GraspReason.TOO_NARROW: 1,
    GraspReason.TOO_WIDE: 2,
    GraspReason.OUT_OF_VIEW: 3,
    GraspReason.COLLISION: 4,
    GraspReason.NO_ROOM: 5,
    GraspReason.JAWS_BLOCKED: 6,
    GraspReason.NO_WALL: 7,
    GraspReason.FOUND: 8,
}
STAGE = np.zeros(max(GraspReason) + 1, np.int32)  # each GraspReason's stage (0 if not a candidate's)
for _reason, _stage in CANDIDATE_STAGE.items():
    STAGE[_reason] = _stage
BY_STAGE = np.array(sorted(CANDIDATE_STAGE, key=CANDIDATE_STAGE.get), np.int32)  # stage -> reason


def furthest_reason(reasons, among=None):
    """The `GraspReason` of the furthest candidate stage that `reasons` (int array) reached,
    counting only those where `among` (bool, same shape) when it is given."""
    stage = jnp.asarray(STAGE)[reasons]
    if among is not None:
        stage = jnp.where(among, stage, 0)
    return jnp.asarray(BY_STAGE)[jnp.max(stage)]


class AlignReason(IntEnum):
    """Why `align_tool` found (0) or did not find a plane."""

    FOUND = 0  # a plane with at least `min_inliers` inliers was found
    NO_DEPTH = 1  # no valid depth pixel in the image
    NO_PLANE = 2  # every hypothesis was degenerate or left the image
    TOO_FEW_INLIERS = 3  # the best plane has fewer than `min_inliers` inliers
    NO_NEW_VIEW = 4  # every plane with enough inliers faces the camera already (`min_turn_deg`)


class SupportReason(IntEnum):
    """Why `support_plane` found (0) or did not find the plane the objects stand on."""

    FOUND = 0  # a plane holding at least `min_plane_fraction` of the valid pixels was found
    NO_DEPTH = 1  # fewer than three valid pixels in the workspace
    NO_PLANE = 2  # every hypothesis was degenerate or tilted beyond `max_plane_tilt_deg`
    TOO_FEW_INLIERS = 3  # the best plane holds less than `min_plane_fraction` of the pixels
    OFF = 4  # not searched (`scene.support = false`: the paper's rule, target = nearest point)


class TargetReason(IntEnum):
    """Why `target.target_candidates` found (0) or did not find a target on a real depth image."""

    FOUND = 0  # a target pixel was chosen
    EMPTY_WORKSPACE = 1  # no valid depth inside the workspace and depth range
    NO_OBJECT = 2  # nothing stands `min_height` above the support plane
    NO_SURFACE = 3  # everything standing is a speck (< `min_target_pixels`) or too steep to face
