"""The furthest stage a grasp's candidates reached (`perception/reasons.py`), by hand."""

import numpy as np

from graspjax.perception import GraspReason
from graspjax.perception.reasons import further_reason, furthest_reason

R = GraspReason


def test_the_furthest_stage_wins_and_unchecked_entries_reach_none():
    reasons = np.array([R.NO_ANTIPODAL, R.NO_ROOM, R.TOO_WIDE, -1], np.int32)
    assert int(furthest_reason(reasons)) == R.NO_ROOM
    assert int(furthest_reason(reasons, np.array([1, 0, 1, 1], bool))) == R.TOO_WIDE
    assert int(furthest_reason(np.array([-1, -1], np.int32))) == R.NO_ANTIPODAL  # not checked
    assert int(furthest_reason(np.array([R.JAWS_BLOCKED, R.FOUND], np.int32))) == R.FOUND


def test_further_reason_prefers_the_later_stage_and_the_first_on_a_tie():
    assert int(further_reason(R.NO_ROOM, R.JAWS_BLOCKED)) == R.JAWS_BLOCKED
    assert int(further_reason(R.NO_WALL, R.COLLISION)) == R.NO_WALL
    assert int(further_reason(R.NO_DEPTH, R.NO_ANTIPODAL)) == R.NO_DEPTH  # both stage 0
