"""How far a T-beam placement got through the checks (`GraspReason`, defined in `codes.py`):
an image's overall code is the furthest any of its candidates reached."""

import jax.numpy as jnp
import numpy as np

from graspjax.codes import GraspReason

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
    """The `GraspReason` of the furthest candidate stage that `reasons` (int array; -1, not
    checked, reaches none) reached, counting only those where `among` (bool, same shape) when it
    is given."""
    stage = jnp.where(reasons >= 0, jnp.asarray(STAGE)[reasons], 0)
    if among is not None:
        stage = jnp.where(among, stage, 0)
    return jnp.asarray(BY_STAGE)[jnp.max(stage)]


def further_reason(first, second):
    """Of two `GraspReason`s, the one whose candidate stage is further (the first on a tie; an
    image-level reason has stage 0)."""
    stage = jnp.asarray(STAGE)
    return jnp.where(stage[second] > stage[first], second, first)
