"""How long a run will take, before it runs (`--dry-run`): each group's worlds, chunks and
whether its program is stored, timed by what a finished run last recorded for such a group on
this device kind (`record_timings`, kept beside the compile cache in `timings/`)."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import pandas as pd

from graspjax.batch.plan import Group, Job, chunks, default_batch, plan
from graspjax.batch.program import program
from graspjax.config import Config
from graspjax.runtime.stores import keep, store


@dataclasses.dataclass(frozen=True)
class PlannedGroup:
    """One program's share of a run, as `--dry-run` tells it before anything runs."""

    scene: str  # the scene's object letters
    setups: tuple[int, ...]
    worlds: int  # worlds it plays (every grid point)
    chunks: int  # device calls of `batch` worlds
    stored: bool  # its program loads from the store of exported programs (no trace)
    seconds: float | None  # estimated time on one device of this kind, from the timings last
    # recorded for such a group here (`record_timings`); None where none were


def planned(groups: list[Group], batch: int, keep_views: bool) -> list[PlannedGroup]:
    """`groups` as a run plays them in chunks of `batch` (`PlannedGroup`); nothing is traced,
    compiled or written."""
    cut = chunks(groups, batch)
    recorded = _recorded()
    out = []
    for g, group in enumerate(groups):
        stored = program(group, batch, keep_views=keep_views).stored()
        past = recorded.get(_key(group, batch, keep_views))
        # a stored program loads, and XLA's cache then holds its compiled form as a rule
        seconds = None if past is None else (len(group.worlds) * past["per_world_s"] + (
            0.0 if stored else past["trace_s"] + past["compile_s"]))
        out.append(PlannedGroup("".join(group.letters), group.setups, len(group.worlds),
                                sum(c.group == g for c in cut), stored, seconds))
    return out


def plan_lines(groups: list[PlannedGroup], points: int, batch: int | None) -> list[str]:
    """What `--dry-run` prints: the run (chunks of `batch`, default the device's), then a line
    per group, then the estimate."""
    devices, kind = _devices()
    batch = batch or default_batch()
    def s(seconds: float) -> str:
        return f"{seconds:.1f} s" if seconds < 10 else f"{seconds:.0f} s"

    lines = [f"{points} grid point(s), {sum(g.worlds for g in groups)} worlds in "
             f"{sum(g.chunks for g in groups)} chunks of up to {batch}, {len(groups)} "
             f"program(s); {devices} {kind} device(s)"]
    for g in groups:
        lines.append(f"  {g.scene} (Setup {', '.join(map(str, g.setups))}): {g.worlds} worlds, "
                     f"{g.chunks} chunk(s), program "
                     f"{'stored' if g.stored else 'to trace and compile'}, "
                     + ("no timings recorded here" if g.seconds is None else f"about {s(g.seconds)}"))
    known = [g.seconds for g in groups if g.seconds is not None]
    lines.append(f"estimated: about {s(sum(known))} on one device (chunks of several programs "
                 "overlap, several devices or processes share them)" if len(known) == len(groups)
                 else f"estimated: unknown for {len(groups) - len(known)} program(s) (a run "
                 "records its timings for the next estimate)")
    return lines


def _key(group: Group, batch: int, keep_views: bool) -> str:
    """What a group's recorded timings are filed under: its program's shape and work."""
    return (f"{''.join(group.letters)} setups {group.setups} attempts {group.attempts} "
            f"batch {batch}" + (" views" if keep_views else ""))


def _file() -> Path | None:
    """This device kind's recorded timings, beside the compile cache."""
    folder = store("timings")
    kind = re.sub(r"[^A-Za-z0-9]+", "_", _devices()[1])
    return None if folder is None else folder / f"{kind}.json"


def _recorded() -> dict:
    path = _file()
    try:
        recorded = json.loads(path.read_text()) if path is not None else {}
    except (OSError, ValueError):
        return {}
    return recorded if isinstance(recorded, dict) else {}


def record_timings(groups: list[Group], batch: int, keep_views: bool,
                   timings: pd.DataFrame) -> None:
    """Keep what each group of a finished run took on this device kind (seconds per world
    played, and its first chunk's trace and compile: `timings.csv`), for `planned`."""
    path = _file()
    if path is None:
        return
    recorded = _recorded()
    for g, rows in timings.groupby("group"):
        if g < len(groups) and rows["worlds"].sum() > 0:
            recorded[_key(groups[g], batch, keep_views)] = {
                "per_world_s": float(rows["wall_s"].sum() / rows["worlds"].sum()),
                "trace_s": float(rows["trace_s"].sum()), "compile_s": float(rows["compile_s"].sum())}
    keep(path, json.dumps(recorded, indent=1, sort_keys=True).encode())


def plane_plan_lines(jobs: list[Job], config: Config, points: int, seed: int,
                     batch: int | None) -> list[str]:
    """What `graspjax planes --dry-run` prints: the worlds `jobs` settle and view once, in
    chunks of `batch` (default: the device's), per group, and the grid points scored on every
    view (one compiled scoring call)."""
    groups = plan(jobs, [config], seed)
    batch = batch or default_batch()
    cut = chunks(groups, batch)
    devices, kind = _devices()
    lines = [f"{points} grid point(s) scored on every first view, "
             f"{sum(len(g.worlds) for g in groups)} worlds settled and viewed in {len(cut)} "
             f"chunks of up to {batch}; {devices} {kind} device(s)"]
    for g, group in enumerate(groups):
        lines.append(f"  {''.join(group.letters)} (Setup {', '.join(map(str, group.setups))}): "
                     f"{len(group.worlds)} worlds, {sum(c.group == g for c in cut)} chunk(s)")
    lines.append("estimated: unknown (a plane study records no timings; its settling costs "
                 "about what a run's first call does)")
    return lines


def _devices() -> tuple[int, str]:
    """How many devices JAX sees, and their kind ("NVIDIA H200", "cpu")."""
    import jax

    device = jax.devices()[0]
    return jax.device_count(), getattr(device, "device_kind", device.platform)
