"""Integer codes carried in arrays: why a step succeeded (0) or failed, how an attempt ended,
what a pixel shows. Failures are data, never exceptions under `jit`. Plain Python: the reports
and the output schema (`schema.py`) read them without loading JAX's simulator.
"""

from enum import IntEnum

import numpy as np


def names(kind: type[IntEnum], codes):
    """The names of integer codes of `kind` (host values, not traced ones): a str for one code
    (`GraspReason(4)` -> 'NO_ANTIPODAL'), an array of str of `codes`' shape for a batch. The
    result classes' `reason_name` properties use it; the int codes stay in the arrays."""
    codes = np.asarray(codes)
    if codes.ndim == 0:
        return kind(int(codes)).name
    return np.array([kind(int(c)).name for c in codes.ravel()]).reshape(codes.shape)


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
    TOO_TILTED = 5  # no plane within `max_plane_tilt_deg`, but one tilted past it holds at least
    # `min_plane_fraction` of the pixels (a camera that sees its table more obliquely than the limit)


class TargetReason(IntEnum):
    """Why `target.target_candidates` found (0) or did not find a target on a real depth image."""

    FOUND = 0  # a target pixel was chosen
    EMPTY_WORKSPACE = 1  # no valid depth inside the workspace and depth range
    NO_OBJECT = 2  # nothing stands `min_height` above the support plane
    NO_SURFACE = 3  # everything standing is a speck (< `min_target_pixels`) or too steep to face


class Outcome(IntEnum):
    """How one executed grasp attempt ended (carried as int32 in arrays)."""

    SUCCESS = 0  # the target was lifted by at least min_lift and is held between the fingers
    MISSED = 1  # the jaws closed on nothing
    SLIPPED = 2  # something was between the jaws but the target was not lifted and held
    COLLISION = 3  # the approach was blocked before the grasp pose was reached
    WRONG_OBJECT = 4  # another object was lifted instead of the target
    DIVERGED = 5  # the simulation state became non-finite
    NOT_EXECUTED = 6  # no grasp to execute (perception found none)


ALIGN_BASE = 10  # Reason of an alignment failure: ALIGN_BASE + AlignReason
DETECT_BASE = 20  # Reason of a detection failure: DETECT_BASE + GraspReason


class Reason(IntEnum):
    """The one reason an attempt ended as it did (int32 in arrays; precedence: module docstring)."""

    SUCCESS = Outcome.SUCCESS  # executed: the target was lifted and held
    MISSED = Outcome.MISSED  # executed: the jaws closed on nothing
    SLIPPED = Outcome.SLIPPED  # executed: the target was not lifted and held
    COLLISION = Outcome.COLLISION  # executed: the approach was blocked
    WRONG_OBJECT = Outcome.WRONG_OBJECT  # executed: another object was lifted
    DIVERGED = Outcome.DIVERGED  # the simulation state became non-finite
    NO_TARGET = 6  # nothing in the workspace stands above the table (or the protocol stopped)
    VIEW_UNREACHABLE = 7  # the re-aligned view would sink below min_view_height or face down
    TARGET_LOST = 8  # the target point was not found again in the last view (hidden, out of view)
    ALIGN_NO_DEPTH = ALIGN_BASE + AlignReason.NO_DEPTH  # re-alignment: no valid depth
    ALIGN_NO_PLANE = ALIGN_BASE + AlignReason.NO_PLANE  # re-alignment: every hypothesis degenerate
    ALIGN_TOO_FEW_INLIERS = ALIGN_BASE + AlignReason.TOO_FEW_INLIERS  # re-alignment: weak plane
    ALIGN_NO_NEW_VIEW = ALIGN_BASE + AlignReason.NO_NEW_VIEW  # re-alignment: only the plane faced
    DETECT_NO_DEPTH = DETECT_BASE + GraspReason.NO_DEPTH  # detection failures, as GraspReason
    DETECT_SURFACE_TOO_SMALL = DETECT_BASE + GraspReason.SURFACE_TOO_SMALL
    DETECT_NO_EDGES = DETECT_BASE + GraspReason.NO_EDGES
    DETECT_NO_ANTIPODAL = DETECT_BASE + GraspReason.NO_ANTIPODAL
    DETECT_TOO_NARROW = DETECT_BASE + GraspReason.TOO_NARROW
    DETECT_TOO_WIDE = DETECT_BASE + GraspReason.TOO_WIDE
    DETECT_OUT_OF_VIEW = DETECT_BASE + GraspReason.OUT_OF_VIEW
    DETECT_COLLISION = DETECT_BASE + GraspReason.COLLISION
    DETECT_NO_ROOM = DETECT_BASE + GraspReason.NO_ROOM
    DETECT_NO_WALL = DETECT_BASE + GraspReason.NO_WALL
    DETECT_JAWS_BLOCKED = DETECT_BASE + GraspReason.JAWS_BLOCKED  # real images only (never here)

    @property
    def label(self) -> str:
        """How attempts.csv names it: the outcome, or 'detection: X' / 'alignment: X' / 'no target'."""
        if self <= Reason.DIVERGED:
            return self.name
        if self == Reason.NO_TARGET:
            return "no target"
        if self == Reason.TARGET_LOST:
            return "target lost"
        if self.name.startswith("DETECT_"):
            return "detection: " + self.name[len("DETECT_"):]
        return "alignment: " + self.name.removeprefix("ALIGN_")


class Surface(IntEnum):
    """What a pixel of a simulated view shows (ground truth the method never sees)."""

    NONE = -1  # no valid depth
    TARGET = 0  # the object being attempted
    OTHER_OBJECT = 1  # another object
    TABLE = 2
    BIN = 3  # a wall of the bin
