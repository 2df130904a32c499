"""Records -> rows: a chunk's records become `attempts.csv` and `rounds.csv` rows (their
columns, in order, their labels and sort are defined in `schema.py`).

An attempt row names its world (grid point, setup, object, trial; in Setups 2 and 3 the round,
which is the trial of every object in it, and joins `rounds.csv`; seed), says what
happened (success, outcome, one reason and its code, re-alignments, the grasp found, what was
lifted, the grasp pose) and what the simulation knows that the method never saw (where each
re-alignment's plane lay, its normal's error). Objects of a Setup 2/3 round that never got an
attempt get a row too (attempt -1). The run adds its id, the chunk and a `cfg.<key>` column
per grid key and per value the run changed from the defaults (`RunColumns`).

A round row (`rounds.csv`) says how dense a settled Setup 2/3 layout was.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import jax
import numpy as np
import pandas as pd

from graspjax.batch.plan import WorldKey
from graspjax.codes import Outcome
from graspjax.config import MAX_REORIENTATIONS, Config, differences
from graspjax.perception import AlignReason, GraspReason
from graspjax.procedure import Record
from graspjax.schema import REASON_LABELS, ROUND_COLUMNS, SURFACE_LABELS, attempt_columns
from graspjax.sim.clutter import LayoutStats
from graspjax.tree import named_fields

if TYPE_CHECKING:
    from graspjax.batch.schedule import ChunkResult

@dataclasses.dataclass(frozen=True)
class RunColumns:
    """What every row of a run carries besides its world and record."""

    run_id: str  # the run's id (`outputs.run_id`)
    points: list[Config]  # grid point i's configuration
    keys: list[str]  # the grid's dotted keys
    base: Config  # the run's configuration before the grid

    def config_columns(self) -> list[str]:
        """Dotted keys with a `cfg.` column: the grid's, then every value the base changes."""
        return [*self.keys, *sorted(set(differences(self.base, Config())) - set(self.keys))]


def attempt_rows(result: ChunkResult, run: RunColumns) -> pd.DataFrame:
    """Every attempt row of a finished chunk, the first columns first (in world order; the run
    folder sorts the whole run with `sort_attempts`)."""
    return with_run_columns(_record_rows(result.group.letters, result.chunk.worlds,
                                         result.records), run, result.chunk.index)


def with_run_columns(frame: pd.DataFrame, run: RunColumns, chunk: int) -> pd.DataFrame:
    """Attempt rows of a chunk given the run's own columns (its id, the chunk, each row's
    point's method and `cfg.` values), in the schema's order; the world and record columns
    are the frame's (fresh from the records, or copied from a reused run's rows)."""
    frame = frame.drop(columns=[c for c in frame.columns
                                if c in ("run_id", "chunk") or c.startswith("cfg.")])
    frame.insert(0, "chunk", chunk)
    frame.insert(0, "run_id", run.run_id)
    frame["method"] = [run.points[p].method for p in frame["point"]]
    values = [named_fields(p) for p in run.points]
    for key in run.config_columns():
        frame[f"cfg.{key}"] = [values[p][key] for p in frame["point"]]
    columns = attempt_columns(MAX_REORIENTATIONS, run.config_columns())
    unknown = sorted(set(frame.columns) - set(columns))
    if unknown:  # a column the schema does not describe: a bug, not a user's mistake
        raise RuntimeError(f"attempt columns missing from schema.ATTEMPT_COLUMNS: {unknown}")
    return frame.reindex(columns=columns)


def _record_rows(letters: tuple[str, ...], worlds: tuple[WorldKey, ...], records: list[Record]
                 ) -> pd.DataFrame:
    """One row per attempt (and per object of a round that never got one), in world order:
    the columns a world and its records give, before the run's own."""
    n_real = len(worlds)
    letters = np.array(letters + ("",))  # index -1 -> ""
    frames = []
    for k, record in enumerate(records):
        r = jax.tree.map(lambda x: np.asarray(x)[:n_real], record)
        keep = np.flatnonzero(r.aimed)
        if not len(keep):
            continue
        reason = r.reason[keep]
        frame = _world_columns(worlds, keep, letters[r.target[keep]])
        frame["attempt"] = k
        frame["success"] = (reason == Outcome.SUCCESS).astype(int)
        frame["outcome"] = [Outcome(o).name for o in r.outcome[keep]]
        frame["reason"] = REASON_LABELS[reason]
        # 64-bit like the unattempted rows' codes: a chunk's dtypes then never depend on
        # whether it has such rows, and the run folder joins its rows' CSV lines as they are
        # (`outputs._sorted`) instead of formatting the whole run again (results/benchmarks).
        frame["reason_code"] = reason.astype(np.int64)
        frame["reorientations"] = r.reorientations[keep].astype(np.int64)
        frame["grasp_found"] = r.grasp_found[keep].astype(int)
        frame["first_view_grasp"] = (r.grasp_found[keep] & (r.reorientations[keep] == 0)).astype(int)
        frame["rescued"] = ((reason == Outcome.SUCCESS) & (r.reorientations[keep] > 0)).astype(int)
        frame["detect_reason"] = [GraspReason(c).name for c in r.detect_reason[keep]]
        frame["align_reason"] = [AlignReason(c).name if c >= 0 else "" for c in r.align_reason[keep]]
        frame["lifted_object"] = letters[r.lifted_object[keep]]
        frame["grasp_object"] = letters[r.grasp_object[keep]]
        frame["segment_precision"] = r.segment_precision[keep]
        frame["segment_recall"] = r.segment_recall[keep]
        crowd = jax.tree.map(lambda x, rows=keep: x[rows], r.clutter)  # the target's, before
        # 1.0 / 0.0 (floats: an object never attempted has none of them, nan)
        frame["target_touching"] = crowd.touching.astype(float)
        frame["target_resting"] = crowd.resting.astype(float)
        frame["target_covered"] = crowd.covered.astype(float)
        frame["target_gap_m"] = crowd.gap
        frame["finger_clearance_m"] = crowd.finger_clearance
        frame["rise_m"] = r.rise[keep]
        frame["jaw_opening_m"] = 2 * r.opening[keep]
        for name in ("tcp", "approach", "closing"):
            values = getattr(r, name)[keep]
            for i, axis in enumerate("xyz"):
                frame[f"grasp_{name}_{axis}"] = values[:, i]
        truth = jax.tree.map(lambda x, rows=keep: x[rows], r.realign)  # (rows, R) per field
        for turn in range(MAX_REORIENTATIONS):  # ground truth on each re-alignment taken
            frame[f"realign{turn + 1}_surface"] = SURFACE_LABELS[truth.surface[:, turn] + 1]
            frame[f"realign{turn + 1}_on_target"] = truth.on_target[:, turn]
            frame[f"realign{turn + 1}_normal_error_deg"] = truth.normal_error_deg[:, turn]
            frame[f"realign{turn + 1}_view_tilt_deg"] = truth.view_tilt_deg[:, turn]
        frames.append(frame)
    frames.append(_unattempted(letters[:-1], worlds, records))
    return pd.concat([f for f in frames if len(f)], ignore_index=True)


def layout_columns(stats: LayoutStats) -> dict[str, np.ndarray]:
    """`schema.LAYOUT_COLUMNS` of settled layouts (`clutter.LayoutStats`, NumPy, (R,) each)."""
    objects = np.maximum(stats.objects, 1)
    return {"touching_fraction": stats.touching / objects, "near_fraction": stats.near / objects,
            "stacked": stats.stacked, "min_face_gap_m": stats.gap, "spread_m": stats.spread}


def round_rows(result: ChunkResult, run: RunColumns) -> pd.DataFrame:
    """One row per Setup 2/3 round of a chunk: how dense its layout was once the drop settled,
    and how the round went, as VGN measures clutter removal: its attempts and successes, the
    grasp success rate (successes / attempts), the objects placed and removed (lifted out,
    whether the target or not) and the declutter rate (removed / placed); a round continued
    until empty or stuck (`procedure.round_attempts`) says how it ended."""
    worlds, drop = result.chunk.worlds, result.drop
    real = len(worlds)
    stats = jax.tree.map(lambda x: np.asarray(x)[:real], drop.layout)
    keep = [w for w, world in enumerate(worlds) if world.setup > 1]
    lifted = np.stack([np.asarray(r.lifted_object)[:real] for r in result.records], 1)
    success = np.stack([np.asarray(r.reason)[:real] == Outcome.SUCCESS for r in result.records], 1)
    tried = np.stack([np.asarray(r.aimed)[:real] for r in result.records], 1)  # (B, A)
    attempts, successes = tried.sum(1), (success & tried).sum(1)
    placed = np.array([len(w.objects) for w in worlds])
    removed = np.array([len({int(o) for o in row if o >= 0}) for row in lifted])
    frame = _world_columns(worlds, keep)[["point", "seed", "setup", "round", "objects"]]
    frame.insert(1, "method", [run.points[p].method for p in frame["point"]])
    return frame.assign(
        **layout_columns(jax.tree.map(lambda x: x[keep], stats)),
        attempts=attempts[keep], successes=successes[keep],
        grasp_success_rate=successes[keep] / np.where(attempts[keep] > 0, attempts[keep], np.nan),
        objects_placed=placed[keep], objects_removed=removed[keep],
        declutter_rate=removed[keep] / placed[keep],
        end=[_round_end(tried[w], success[w], removed[w], placed[w], run.points[worlds[w].point])
             for w in keep])[list(ROUND_COLUMNS)]


def _round_end(tried: np.ndarray, success: np.ndarray, removed: int, placed: int,
               config: Config) -> str:
    """How a round ended: every object attempted once (the protocol as we read the paper), or, continued,
    `empty` (everything removed), `stuck` (its last `stuck_after` attempts failed) or `limit`
    (its `round_attempts` used up, or no object left in view)."""
    if config.procedure.round_attempts == 0:
        return "once each"
    if removed == placed:
        return "empty"
    outcomes = success[tried]
    stuck = int(np.asarray(config.procedure.stuck_after))
    if len(outcomes) >= stuck and not outcomes[-stuck:].any():
        return "stuck"
    return "limit"


def _world_columns(worlds, index, objects=None) -> pd.DataFrame:
    """The columns that name row i's world `worlds[index[i]]`, and its `objects[i]` (if given)."""
    return pd.DataFrame({
        "point": [worlds[w].point for w in index], "setup": [worlds[w].setup for w in index],
        "object": objects if objects is not None else "", "trial": [worlds[w].trial for w in index],
        "round": pd.array([worlds[w].trial if worlds[w].setup > 1 else None for w in index],
                          dtype="Int64"),  # Setups 2, 3 only: Setup 1 has no rounds
        "seed": [worlds[w].seed for w in index],
        "objects": ["".join(worlds[w].objects) for w in index]})


def _unattempted(letters, worlds, records: list[Record]) -> pd.DataFrame:
    """Objects of a world that never got an attempt credited to them: lifted with another's,
    left when the round's attempts ran out, or never a target point (outside the workspace,
    lower than `perception.min_height`, or the round stopped: no attempt found a target)."""
    n_real = len(worlds)
    target = np.stack([np.asarray(r.target)[:n_real] for r in records], 1)  # (B, A)
    aimed = np.stack([np.asarray(r.aimed)[:n_real] for r in records], 1)
    lifted = np.stack([np.asarray(r.lifted_object)[:n_real] for r in records], 1)
    index, objects, why = [], [], []
    for w, world in enumerate(worlds):
        for c in world.objects:
            i = list(letters).index(c)
            if i not in target[w]:
                index.append(w)
                objects.append(c)
                why.append("removed with another object" if i in lifted[w] else
                           "attempts used up" if aimed[w].all() else "never a target point")
    frame = _world_columns(worlds, index, objects)
    frame["attempt"] = -1
    frame["success"] = 0
    frame["outcome"] = Outcome.NOT_EXECUTED.name
    frame["reason"] = [f"not attempted: {w}" for w in why]
    frame["reason_code"] = -1
    frame["reorientations"] = 0
    frame["grasp_found"] = 0
    frame["first_view_grasp"] = 0
    frame["rescued"] = 0
    return frame


