"""Records into rows (`batch/rows.py`): who an attempt is credited to, and why an object of a
round never got an attempt; the protocol's bookkeeping between attempts (`procedure`)."""

import numpy as np

from graspjax.batch.plan import WorldKey
from graspjax.batch.rows import _record_rows
from graspjax.codes import Outcome, Reason
from graspjax.config import MAX_REORIENTATIONS, Config, override
from graspjax.procedure import (
    PlaneTruth,
    Record,
    RoundState,
    TargetClutter,
    WorldSpec,
    eligible_objects,
    round_goes_on,
)
from graspjax.sim.clutter import LayoutStats

LETTERS = ("a", "b", "c")


def _record(target, aimed, reason, lifted=(-1, -1), under=(-1, -1)):
    """One attempt of two worlds (B = 2)."""
    b = 2
    nan = np.full(b, np.nan, np.float32)
    truth = PlaneTruth(surface=np.full((b, MAX_REORIENTATIONS), -1, np.int32),
                       on_target=np.full((b, MAX_REORIENTATIONS), np.nan, np.float32),
                       normal_error_deg=np.full((b, MAX_REORIENTATIONS), np.nan, np.float32),
                       view_tilt_deg=np.full((b, MAX_REORIENTATIONS), np.nan, np.float32))
    executed = [r <= Reason.DIVERGED for r in reason]
    return Record(
        target=np.array(target, np.int32), aimed=np.array(aimed), reason=np.array(reason, np.int32),
        outcome=np.array([r if e else Outcome.NOT_EXECUTED for r, e in zip(reason, executed,
                                                                           strict=True)], np.int32),
        grasp_found=np.array(executed), reorientations=np.zeros(b, np.int32),
        detect_reason=np.zeros(b, np.int32), align_reason=np.full(b, -1, np.int32),
        lifted_object=np.array(lifted, np.int32), rise=nan, opening=nan,
        tcp=np.zeros((b, 3), np.float32), approach=np.zeros((b, 3), np.float32),
        closing=np.zeros((b, 3), np.float32), realign=truth,
        grasp_object=np.array(under, np.int32), segment_precision=nan, segment_recall=nan,
        layout=LayoutStats(*(np.zeros(b, np.int32),) * 4, nan, nan),
        clutter=TargetClutter(touching=np.zeros(b, bool), resting=np.zeros(b, bool),
                              covered=np.zeros(b, bool), gap=nan, finger_clearance=nan))


def test_rows_credit_the_object_the_target_point_lay_on():
    """World 0: a lifted, then b tried twice (left in the scene) while c is never reached.
    World 1: b lifted with a's attempt, then no target point at all while c is still there."""
    worlds = (WorldKey(0, 0, 2, 0, LETTERS), WorldKey(0, 0, 2, 1, LETTERS))
    records = [_record([0, 0], [True, True], [Outcome.SUCCESS, Outcome.WRONG_OBJECT],
                       lifted=(0, 1), under=(0, 1)),
               _record([1, -1], [True, False], [Reason.DETECT_NO_ROOM, Reason.NO_TARGET]),
               _record([1, -1], [True, False], [Outcome.MISSED, Reason.NO_TARGET], under=(2, -1))]
    rows = _record_rows(LETTERS, worlds, records)
    tried = rows[rows["attempt"] >= 0]
    assert tried[["trial", "attempt", "object"]].values.tolist() == [
        [0, 0, "a"], [1, 0, "a"], [0, 1, "b"], [0, 2, "b"]]  # no row for an attempt not aimed
    assert tried["grasp_object"].tolist() == ["a", "b", "", "c"]  # ground truth, for the record
    assert tried["reason"].tolist() == ["SUCCESS", "WRONG_OBJECT", "detection: NO_ROOM",
                                        "MISSED"]
    missing = rows[rows["attempt"] < 0].set_index(["trial", "object"])["reason"]
    assert missing.to_dict() == {
        (0, "c"): "not attempted: attempts used up",
        (1, "b"): "not attempted: removed with another object",
        (1, "c"): "not attempted: never a target point"}


def test_a_chunks_dtypes_do_not_depend_on_its_unattempted_rows():
    """Two worlds attempting all three objects, and the same with the last attempt cut (so each
    world has an unattempted row): every column keeps its dtype, so that the run folder can join
    the chunks' CSV lines as they are."""
    worlds = (WorldKey(0, 0, 2, 0, LETTERS), WorldKey(0, 0, 2, 1, LETTERS))
    records = [_record([i, i], [True, True], [Outcome.SUCCESS] * 2, lifted=(i, i), under=(i, i))
               for i in range(len(LETTERS))]
    every = _record_rows(LETTERS, worlds, records)
    cut = _record_rows(LETTERS, worlds, records[:-1])
    assert (every["attempt"] >= 0).all() and (cut["attempt"] < 0).sum() == 2
    assert cut.dtypes.to_dict() == every.dtypes.to_dict()


def _state(removed, attempted, failures=0):
    return RoundState(data=None, attempted=np.array(attempted), failures=np.int32(failures),
                      removed=np.array(removed), key=None, drops=None)


def test_the_protocol_uses_identity_and_the_method_does_not():
    """The protocol as we read the paper goes on while an object is in the scene (one attempt per object is
    the experimenter's doing: a failed object is taken out); the oracle's identity skip leaves
    out the objects already tried. A continued round stops once stuck."""
    spec = WorldSpec(seed=0, setup=2, trial=0, order=np.arange(3), members=np.ones(3, bool),
                     config=Config())
    state = _state(removed=[True, False, False], attempted=[True, True, False])
    assert bool(round_goes_on(state, spec))
    assert eligible_objects(state, spec).tolist() == [False, False, True]
    assert not bool(round_goes_on(_state([True] * 3, [True] * 3), spec))
    clutter = WorldSpec(seed=0, setup=2, trial=0, order=np.arange(3), members=np.ones(3, bool),
                        config=override(Config(), ["procedure.round_attempts=6"]))
    assert bool(round_goes_on(_state([False] * 3, [True] * 3, failures=1), clutter))
    assert not bool(round_goes_on(_state([False] * 3, [True] * 3, failures=2), clutter))
    assert eligible_objects(_state([False] * 3, [True] * 3, failures=1), clutter).all()


def test_layout_columns_are_the_schemas():
    """`rows.layout_columns` gives `schema.LAYOUT_COLUMNS`, in order, and fractions of the
    objects on the table."""
    from graspjax.batch.rows import layout_columns
    from graspjax.schema import LAYOUT_COLUMNS

    stats = LayoutStats(objects=np.array([6, 4]), touching=np.array([3, 4]), near=np.array([6, 2]),
                        stacked=np.array([1, 0]), gap=np.array([0.0, 0.01]),
                        spread=np.array([0.12, 0.2]))
    columns = layout_columns(stats)
    assert tuple(columns) == LAYOUT_COLUMNS
    np.testing.assert_allclose(columns["touching_fraction"], [0.5, 1.0])
    np.testing.assert_allclose(columns["near_fraction"], [1.0, 0.5])
