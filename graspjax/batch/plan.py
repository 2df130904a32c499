"""Planning a run on the host: jobs into worlds, worlds into groups, groups into chunks.

- A `Job` is the paper's unit: objects, setups, trials. With every grid
  point of a sweep (a `Config` and its seed) it yields *worlds*: in Setup 1
  one world per (object, trial), holding that object alone, with one
  attempt; in Setups 2 and 3 one world per round, holding all the job's
  objects, with one attempt per object.
- Worlds that can share one compiled program form a *group*: the same scene
  (objects, and whether objects touch each other), the same number of
  attempts per round and the same static configuration. Traced
  configuration values (thresholds, frictions, ...) differ freely between
  the worlds of a group, so a sweep over them compiles once.
- A group runs in *chunks* of at most `batch` worlds, padded to one static
  size and split over every local device. A chunk is the unit of progress.

Nothing here touches a device: planning is plain Python over the run's command.
"""

from __future__ import annotations

import dataclasses

import jax

from graspjax.config import Config
from graspjax.sim.objects import parse_letters

MAX_SEED = 2**31 - 1  # a world's seed is an int32 on the device (`procedure.WorldSpec.seed`)
MAX_BATCH = 65_536  # worlds per device call: 32 times the GPU's default, whose six-object
# rounds take 3.4 GiB of device memory (here about 110 GiB); every chunk is padded to it, so a
# larger batch (a million: 4.2 GB on the host in 38 s before any device call) is a mistake


@dataclasses.dataclass(frozen=True)
class Job:
    """Setups x trials in one scene; each world attempts `objects` once (Setup 1: one each)."""

    objects: tuple[str, ...]  # attempted objects (Setups 2, 3: the round's order of preference)
    setups: tuple[int, ...]  # each setup gets `trials` trials (Setup 1) or rounds
    trials: int

    def __post_init__(self):
        parse_letters("".join(self.objects))
        if not self.setups or any(s not in (1, 2, 3) for s in self.setups):
            raise ValueError(f"setups must be 1, 2 or 3, got {self.setups}")
        if self.trials < 1:
            raise ValueError(f"trials must be >= 1, got {self.trials}")

    @property
    def letters(self) -> tuple[str, ...]:
        """Objects of the scene model, in a-l order."""
        return tuple(sorted(self.objects))

    def attempts(self, config: Config) -> int:
        """Attempts a job makes per grid point under `config`: Setup 1 one per world (object
        and trial), Setups 2 and 3 `round_attempts` per round."""
        return sum(self.trials * (len(self.objects) if setup == 1
                                  else round_attempts(setup, self.objects, config))
                   for setup in self.setups)


def table_job(table: int, trials: int) -> Job:
    """The paper's presets: Table 1 = a-f in Setups 1-3, Table 2 = g-l in Setup 1."""
    if table == 1:
        return Job(tuple("abcdef"), (1, 2, 3), trials)
    if table == 2:
        return Job(tuple("ghijkl"), (1,), trials)
    raise ValueError(f"table must be 1 or 2, got {table}")


@dataclasses.dataclass(frozen=True)
class WorldKey:
    """One world's key, host side: which round of which grid point it plays (its seeds follow)."""

    point: int  # grid point index (0 for a plain run)
    seed: int  # the grid point's seed
    setup: int
    trial: int  # trial (Setup 1) or round (Setups 2, 3)
    objects: tuple[str, ...]  # attempt order (Setup 1: the one object)


@dataclasses.dataclass(frozen=True)
class Group:
    """Worlds that share one compiled program."""

    letters: tuple[str, ...]  # objects of the scene
    collide: bool  # objects touch each other (Setups 2, 3)
    attempts: int  # attempts per round
    config: Config  # static configuration (traced values: per world, from its point)
    worlds: tuple[WorldKey, ...]

    @property
    def setups(self) -> tuple[int, ...]:
        """The setups its worlds play (`plan` groups Setup 1 apart from Setups 2 and 3)."""
        return (2, 3) if self.collide else (1,)

    @property
    def work(self) -> int:
        """A rough measure of the device time of the group's chunks, to start the longest
        first: calls per world (the drop and each attempt) times worlds times the objects that
        move in a world (all of them in Setups 2 and 3, one in Setup 1)."""
        return (self.attempts + 1) * len(self.worlds) * (len(self.letters) if self.collide else 1)


@dataclasses.dataclass(frozen=True)
class Chunk:
    """The unit of progress: up to `batch` worlds of one group."""

    index: int  # position in the run (stable for a given command and batch size)
    group: int
    worlds: tuple[WorldKey, ...]


def plan(jobs: list[Job], points: list[Config], seed: int, paired: bool = False,
         keep=None) -> list[Group]:
    """Every world of a run (with `keep`, those for which `keep(WorldKey)` holds: `reuse`, the
    others' rows are copied), grouped by compiled program; grid point i has seed `seed + i`,
    or `seed` for every point when `paired` (the same layouts and keys: differences are
    paired)."""
    groups: dict = {}
    for i, config in enumerate(points):
        seed_i = seed if paired else seed + i
        for job in jobs:
            for setup in job.setups:
                if setup == 1:
                    worlds = [WorldKey(i, seed_i, 1, t, (c,)) for c in job.objects
                              for t in range(job.trials)]
                else:
                    worlds = [WorldKey(i, seed_i, setup, t, job.objects) for t in range(job.trials)]
                key = (job.letters, setup > 1, round_attempts(setup, job.objects, config),
                       jax.tree.structure(config))
                groups.setdefault(key, (config, []))[1].extend(w for w in worlds if keep is None or keep(w))
    return [Group(letters, collide, attempts, config, tuple(worlds))
            for (letters, collide, attempts, _), (config, worlds) in groups.items() if worlds]


def round_attempts(setup: int, objects: tuple[str, ...], config: Config) -> int:
    """Attempts per world: one per object (Setup 1: the one object), or in Setups 2 and 3
    `procedure.round_attempts` when it is set (a round continued until empty or stuck)."""
    if setup > 1 and config.procedure.round_attempts > 0:
        return config.procedure.round_attempts
    return len(objects) if setup > 1 else 1


def chunks(groups: list[Group], batch: int) -> list[Chunk]:
    """Each group's worlds cut into chunks of `batch`, one device call each (the last one
    padded by its program), numbered through the run. Neither the device count nor the group's
    size changes a chunk's shape: a world plays in the same shape whatever the run. So a
    `batch` beyond a group's worlds is kept, not cut to them (its rows would change: XLA's
    floats depend on the shape), and bounded instead (`MAX_BATCH`)."""
    out = []
    for g, group in enumerate(groups):
        for start in range(0, len(group.worlds), batch):
            out.append(Chunk(len(out), g, group.worlds[start:start + batch]))
    return out


def default_batch() -> int:
    """Worlds per device call. A GPU needs thousands to be busy: 2,048 keeps the padding of the
    last chunk small at the tables' sizes (1,000 rounds of Setups 2 and 3 fill one call) and
    cuts larger runs into enough chunks to share among several GPUs. The CPU is busy with a
    few, and chunks of 10 keep a 10-trial Setup 1 chunk to one object (the broad phase then
    skips every other object's pairs) and Setups 2 and 3 apart (a Setup 2 round does not wait
    out the bin's longer drop): README's command plays faster than at 32 (results/benchmarks)."""
    return 2048 if jax.default_backend() == "gpu" else 10


def share(work: dict[int, float], processes: int) -> list[list[int]]:
    """Groups (id -> the `Group.work` of their chunks still to play) split among at most
    `processes` processes that play them side by side: the most work first, each to the share
    with the least so far (ties: the first share), so that the shares end near the same time.
    Each share lists its groups in plan order; the shares come heaviest first, so the last is
    the lightest. A group is never split: its program would compile in every process that
    plays it."""
    shares: list[list[int]] = [[] for _ in range(max(1, min(processes, len(work))))]
    load = [0.0] * len(shares)
    for group in sorted(work, key=lambda g: (-work[g], g)):
        lightest = load.index(min(load))
        shares[lightest].append(group)
        load[lightest] += work[group]
    order = sorted(range(len(shares)), key=lambda i: (-load[i], i))
    return [sorted(shares[i]) for i in order]
