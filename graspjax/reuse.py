"""A paired study of the re-alignment that reuses a finished run's worlds
(`graspjax sweep --paired --reuse RUN`).

The re-alignment's settings (`align.*`) and its budget (`procedure.max_reorientations`) act only
once a view holds no grasp: `procedure.steps._search` reads them to turn the camera, and a view
that finds its grasp ends the search before any turn. So a world whose every attempt aimed at
an object and found its grasp in the first view plays the same at every value of them: its rows
are RUN's, copied to each grid point. The other worlds (an attempt whose first view held no
grasp, an attempt that found no target, an object never attempted) play again at each point
whose settings differ from RUN's; a point with RUN's settings copies all of RUN's rows. A copy
is what the world would play only on the same code, device, seed, jobs, batch (a world's floats
depend on its chunk's shape) and every other setting: `load` refuses a RUN that differs in any.
"""

from __future__ import annotations

import collections
import dataclasses
import json
from pathlib import Path

import numpy as np
import pandas as pd

from graspjax.batch.plan import WorldKey, round_attempts
from graspjax.batch.rows import RunColumns, with_run_columns
from graspjax.config import Config, run_settings
from graspjax.errors import InputError
from graspjax.provenance import made_by_other_code
from graspjax.report.files import load_attempts, load_rounds
from graspjax.schema import ROUND_COLUMNS, sort_attempts

AFTER_FIRST_MISS = ("align.", "procedure.max_reorientations")  # the keys that act only then
# (a prefix ending in "." names a whole section)


def acts_after_first_miss(key: str) -> bool:
    """Whether the dotted setting `key` acts only once a view holds no grasp (`AFTER_FIRST_MISS`)."""
    return any(key == k or k.endswith(".") and key.startswith(k) for k in AFTER_FIRST_MISS)


@dataclasses.dataclass(frozen=True)
class Reused:
    """A finished run's rows, and which of its worlds (setup, trial or round, objects) a study
    of `AFTER_FIRST_MISS` keys must play again."""

    run_id: str
    settings: dict  # RUN's settings by dotted name, as its config.json holds them
    attempts: pd.DataFrame
    rounds: pd.DataFrame  # its Setup 2/3 round rows (none: no columns)
    played_again: frozenset[tuple[int, int, str]]

    @property
    def worlds(self) -> int:
        """How many worlds RUN played."""
        return len(set(_ids(self.attempts)))

    def summary(self, folder: str) -> str:
        """What a study reusing this run (`folder`, as given) plays and copies, in words."""
        return (f"--reuse {folder}: {len(self.played_again)} of its {self.worlds} worlds play "
                "again where a point's settings differ from its; the others' rows are its own")

    def copies_all(self, config: Config) -> bool:
        """A grid point with RUN's own settings: every row is RUN's."""
        return _as_saved(run_settings(config)) == self.settings

    def plays(self, configs: list[Config]):
        """`plan.plan`'s `keep`: the worlds the study plays (grid point i: `configs[i]`)."""
        copied = [self.copies_all(c) for c in configs]
        return lambda w: not copied[w.point] and world_id(w) in self.played_again

    def copied_points(self, configs: list[Config]) -> list[int]:
        """The grid points that copy some of RUN's rows, one chunk each, in order."""
        return [i for i, c in enumerate(configs)
                if self.copies_all(c) or len(self.played_again) < self.worlds]

    def rows(self, point: int, run: RunColumns, chunk: int) -> tuple[pd.DataFrame, pd.DataFrame]:
        """Grid point `point`'s copied attempt and round rows, as chunk `chunk` of the study."""
        copy_all = self.copies_all(run.points[point])

        def copied(frame: pd.DataFrame, trial: str = "trial") -> pd.DataFrame:
            keep = [copy_all or ids not in self.played_again for ids in _ids(frame, trial)]
            return frame.loc[np.array(keep, bool)].reset_index(drop=True).assign(point=point)

        attempts = with_run_columns(copied(self.attempts), run, chunk)
        return attempts, copied(self.rounds, "round").assign(method=run.points[point].method)


def world_id(world: WorldKey) -> tuple[int, int, str]:
    """A world's name in its rows: setup, trial (Setup 1) or round, and its objects."""
    return world.setup, world.trial, "".join(world.objects)


def load(folder: str, experiment, batch: int, run_meta: dict) -> Reused:
    """RUN (`folder`) for `experiment` (`experiment.Experiment`, of `batch` worlds a chunk;
    `run_meta`: what this run's config.json holds), checked to be the same run in all but
    the grid's `AFTER_FIRST_MISS` keys; else an InputError naming the difference."""
    bad = [k for k in experiment.keys if not acts_after_first_miss(k)]
    if bad:
        raise InputError(f"--reuse: --grid {bad[0]} acts before a view without a grasp; only "
                         f"{', '.join(k + '*' if k.endswith('.') else k for k in AFTER_FIRST_MISS)} "
                         "leave the other worlds as they played")
    if not experiment.paired or experiment.save_views != "none":
        raise InputError("--reuse needs --paired (the worlds are RUN's) and no --save-views "
                         "(its copied worlds have no views)")
    if not (Path(folder) / "config.json").is_file():
        raise InputError(f"--reuse {folder}: no run there (no config.json)")
    try:
        meta = json.loads((Path(folder) / "config.json").read_text())
    except (OSError, ValueError):  # not JSON
        meta = None
    if not isinstance(meta, dict) or not meta.get("finished") or "config" not in meta:
        raise InputError(f"--reuse {folder}: no finished run there (its config.json says so)")
    if meta.get("points") != 1:
        raise InputError(f"--reuse {folder} is a sweep of {meta.get('points')} points; give a run")
    if made_by_other_code(meta):
        raise InputError(f"--reuse {folder} was {made_by_other_code(meta)}")
    ours = {**_as_saved(run_meta), "batch": batch}
    for key in ("jobs", "seed", "batch", "deterministic", "xla_flags", "device.platform",
                "device.kind", *(("cpu",) if ours["device"]["platform"] == "cpu" else ())):
        theirs, mine = (_get(m, key) for m in (meta, ours))
        if theirs != mine:
            raise InputError(f"--reuse {folder}: its {key} is {theirs}, this sweep's {mine}; "
                             "its worlds would not play the same here")
    # every setting, and the device's choices (`config.run_settings` leaves them out) where set
    mine = {**_as_saved(run_settings(experiment.base)), **ours["overrides"]}
    theirs = {**meta["config"], **meta.get("overrides", {})}
    other = sorted(k for k in set(mine) | set(theirs)
                   if mine.get(k) != theirs.get(k) and not acts_after_first_miss(k))
    if other:
        raise InputError(f"--reuse {folder}: its {other[0]} is {theirs.get(other[0])}, "
                         f"this sweep's {mine.get(other[0])}")
    attempts = _attempts(Path(folder))
    rounds = load_rounds(folder)
    return Reused(meta["run_id"], meta["config"], attempts,
                  rounds if rounds is not None else pd.DataFrame(columns=list(ROUND_COLUMNS)),
                  worlds_to_play_again(attempts, experiment.base))


def _attempts(folder: Path) -> pd.DataFrame:
    """RUN's attempt rows as the run kept them (its Parquet file if there, else its CSV)."""
    parquet = folder / "attempts.parquet"
    return sort_attempts(pd.read_parquet(parquet)) if parquet.is_file() else load_attempts(folder)


def worlds_to_play_again(attempts: pd.DataFrame, config: Config) -> frozenset[tuple[int, int, str]]:
    """The worlds where an `AFTER_FIRST_MISS` key may act: not every attempt of the world
    (`plan.round_attempts`) aimed at an object and found its grasp in the first view."""
    held = (attempts["attempt"] >= 0) & (attempts["first_view_grasp"] == 1)
    ids = _ids(attempts)
    found = collections.Counter(world for world, h in zip(ids, held, strict=True) if h)
    return frozenset(world for world in set(ids)
                     if found[world] < round_attempts(world[0], tuple(world[2]), config))


def _ids(frame: pd.DataFrame, trial: str = "trial") -> list[tuple[int, int, str]]:
    """Each row's world (`world_id`); round rows name the round `round`."""
    return list(zip(frame["setup"].astype(int), frame[trial].astype(int),
                    frame["objects"].astype(str), strict=True))


def _get(meta: dict, key: str):
    """A config.json's value at a dotted `key` (None where it has none)."""
    for part in key.split("."):
        meta = meta.get(part) if isinstance(meta, dict) else None
    return meta


def _as_saved(settings: dict) -> dict:
    """Settings as a config.json holds them (tuples as lists)."""
    return json.loads(json.dumps(settings, default=str))
