"""Running experiments: many worlds in lockstep, one row per grasp attempt.

A *job* is a scene plus the setups, objects and trials to run in it. Each
world plays one *round* (DESIGN.md 3): it attempts each listed object once.
In Setup 1 the objects come one after another, each alone on the table with
its own layout (seed, 1, object, trial); in Setups 2 and 3 one layout
(seed, setup, round) holds them all, and the nearest object not yet tried is
the next target; a lifted object leaves the scene, a failed one stays where
it ends up. Worlds of every setup of a job share one batch, so a whole table
compiles the physics once.

Jitted work (per-world functions vmapped), Python orchestration and file I/O
are kept apart: each attempt step runs compiled batch functions, waits for
them, moves the few result arrays to NumPy, and rows are assembled on the
host.
"""

from __future__ import annotations

import dataclasses
import functools
import time
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.config import Config
from graspjax.perception import AlignReason, GraspReason
from graspjax.pipeline import centred_pose, select_target, view
from graspjax.sim import layout
from graspjax.sim.objects import OBJECTS, parse_letters
from graspjax.sim.world import GraspPose, Outcome, simulator

LETTER_INDEX = {c: i for i, c in enumerate(OBJECTS)}  # a = 0 ... l = 11 (seeds use it)


@dataclasses.dataclass(frozen=True)
class Job:
    """Setups x trials worlds in one scene; each world attempts `objects` once."""

    objects: tuple[str, ...]  # attempted objects (Setup 1: in this order)
    setups: tuple[int, ...]  # each setup gets `trials` worlds
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

    @property
    def worlds(self) -> list[tuple[int, int]]:
        return [(s, t) for s in self.setups for t in range(self.trials)]


def table_jobs(table: int, trials: int) -> Job:
    """The paper's presets: Table 1 = a-f in Setups 1-3, Table 2 = g-l in Setup 1."""
    if table == 1:
        return Job(tuple("abcdef"), (1, 2, 3), trials)
    if table == 2:
        return Job(tuple("ghijkl"), (1,), trials)
    raise ValueError(f"table must be 1 or 2, got {table}")


def default_batch(worlds: int) -> int:
    """Worlds per compiled batch: all of them up to a device-dependent maximum."""
    most = 4096 if jax.default_backend() == "gpu" else 64
    return max(1, min(worlds, most))


def _where(mask, a, b):
    """Per-world select between two pytrees with a leading world axis."""
    return jax.tree.map(lambda x, y: jnp.where(mask.reshape((-1,) + (1,) * (x.ndim - 1)), x, y),
                        a, b)


class RoundRunner:
    """Compiled per-world procedure functions of one scene and configuration."""

    def __init__(self, job: Job, config: Config):
        self.job, self.config = job, config
        self.sim = simulator(job.letters, config.gripper, config.sim, any(s > 1 for s in job.setups))
        scene = self.sim.scene
        self.scene = scene
        camera = config.camera.camera()
        n = scene.num_objects
        cfg = config

        def round_layout(key, setup, members):
            """Setup 2 or 3 layout of the member objects (others, and Setup 1, inactive)."""
            g_pos, g_quat, _ = layout.grouped(key, scene.footprint_radius, cfg.layout)
            d_pos, d_quat, _ = layout.dense(key, scene.object_points, cfg.layout)
            grouped = setup == 2
            return (jnp.where(grouped, g_pos, d_pos), jnp.where(grouped, g_quat, d_quat),
                    members & (setup > 1))

        def single_layout(key, target):
            return layout.single(key, target, n, cfg.layout)

        self._round_layout = jax.jit(jax.vmap(round_layout))
        self._single_layout = jax.jit(jax.vmap(single_layout))
        self._where = jax.jit(_where)
        self._select = jax.jit(jax.vmap(
            lambda d, e, k: select_target(scene, d, e, camera, cfg, k)))
        self._centre = jax.jit(jax.vmap(lambda t: centred_pose(t, cfg)))
        self._view = jax.jit(jax.vmap(
            lambda d, r, p, t, k: view(scene, d, r, p, t, camera, cfg, k)))

    def run_chunk(self, worlds: list[tuple[int, int]], batch: int, seed: int,
                  on_attempts: Callable[[int], None] = lambda n: None) -> tuple[list[dict], dict]:
        """Play one round in each world of `worlds` ((setup, trial) pairs, padded to `batch`).

        Returns the attempt rows and the seconds spent per phase.
        """
        sim, scene, cfg = self.sim, self.scene, self.config
        real = len(worlds)
        padded = worlds + [(1, 0)] * (batch - real)
        setup = np.array([w[0] for w in padded], np.int32)
        trial = np.array([w[1] for w in padded], np.int32)
        n = scene.num_objects
        order = np.array([scene.letters.index(c) for c in self.job.objects], np.int32)
        members = np.zeros(n, bool)
        members[order] = True
        timings = {"physics_s": 0.0, "perception_s": 0.0}

        def timed(phase, fn, *args):
            start = time.perf_counter()
            out = jax.block_until_ready(fn(*args))
            timings[phase] += time.perf_counter() - start
            return out

        round_keys = jax.vmap(lambda s, t: layout.layout_key(seed, s, t))(
            jnp.asarray(setup), jnp.asarray(trial))
        pos, quat, active = self._round_layout(round_keys, jnp.asarray(setup),
                                               jnp.broadcast_to(jnp.asarray(members), (batch, n)))
        data = sim.reset(sim.empty(batch), pos, quat, active)
        # Drops settle: a loose group briefly, a dense pile longer; Setup 1 places per attempt.
        drop = {1: 0.0, 2: 1.0, 3: 3.0}[int(setup.max())] * cfg.sim.settle_time
        if drop > 0:
            data = timed("physics_s", sim.hold_still, data, drop)

        attempted = np.zeros((batch, n), bool)
        removed = np.zeros((batch, n), bool)
        in_scene = np.where((setup > 1)[:, None], members[None], False)
        rows = []
        is_single = jnp.asarray(setup == 1)
        for k, obj in enumerate(order):
            # Setup 1: the k-th object alone on the table, with its own layout.
            letter = LETTER_INDEX[scene.letters[obj]]
            keys = jax.vmap(lambda t, c=letter: layout.layout_key(seed, 1, c, t))(
                jnp.asarray(trial))
            single = sim.reset(data, *self._single_layout(keys, jnp.full(batch, obj, jnp.int32)))
            data = self._where(is_single, single, data)
            data = timed("physics_s", sim.hold_still, data, cfg.sim.settle_time)
            now_in_scene = np.where((setup == 1)[:, None], np.arange(n)[None] == obj, in_scene)
            eligible = now_in_scene & ~attempted & ~removed
            step_keys = jnp.where(is_single, keys, round_keys)
            attempt_keys = jax.vmap(lambda key, k=k: jax.random.fold_in(key, 1000 + k))(step_keys)

            kin = sim.kinematics(data)
            start = time.perf_counter()
            target = self._select(kin, jnp.asarray(eligible), attempt_keys)
            rotation, position = self._centre(target)
            found = jnp.zeros(batch, bool)
            pose = None
            reorientations = jnp.zeros(batch, jnp.int32)
            detect_reason = jnp.zeros(batch, jnp.int32)
            align_reason = jnp.full(batch, -1, jnp.int32)
            blocked = jnp.zeros(batch, bool)  # no reachable re-aligned view left
            for r in range(cfg.procedure.max_reorientations + 1):
                look_keys = jax.vmap(lambda key, r=r: jax.random.fold_in(key, r))(attempt_keys)
                v = self._view(kin, rotation, position, target.index, look_keys)
                fresh = ~found & ~blocked & v.grasp.found & (target.index >= 0)
                pose = v.grasp_pose if pose is None else self._where(fresh, v.grasp_pose, pose)
                searching = ~found & ~blocked
                detect_reason = jnp.where(searching, v.grasp.reason, detect_reason)
                found = found | fresh
                if r < cfg.procedure.max_reorientations:
                    move = ~found & ~blocked & v.can_realign
                    align_reason = jnp.where(~found & ~blocked, v.alignment.reason, align_reason)
                    reorientations = reorientations + move.astype(jnp.int32)
                    blocked = blocked | (~found & ~v.can_realign)
                    rotation = jnp.where(move[:, None, None], v.next_rotation, rotation)
                    position = jnp.where(move[:, None], v.next_position, position)
            jax.block_until_ready(found)
            timings["perception_s"] += time.perf_counter() - start

            grasp = GraspPose(pose.tcp, pose.approach, pose.closing, found)
            start = time.perf_counter()
            data, result = sim.execute(data, grasp, jnp.maximum(target.index, 0))
            timings["physics_s"] += time.perf_counter() - start

            chosen = np.asarray(target.index)
            host = jax.tree.map(np.asarray, {
                "found": found, "pose": pose, "reorientations": reorientations,
                "detect_reason": detect_reason, "align_reason": align_reason, "blocked": blocked})
            for w in np.flatnonzero(chosen[:real] >= 0):
                rows.append(_row(self.job, scene, seed, padded[w], k, chosen[w], result, w, host))
            # Bookkeeping: the target was tried; whatever was lifted leaves the scene.
            attempted[np.arange(batch), np.maximum(chosen, 0)] |= chosen >= 0
            lifted = result.lifted_object
            gone = np.zeros((batch, n), bool)
            gone[np.arange(batch), np.maximum(lifted, 0)] = lifted >= 0
            removed |= gone
            data = sim.go_home(sim.park(data, jnp.asarray(gone)))
            on_attempts(real)

        # Objects of a Setup 2/3 round that never got their attempt.
        for w in range(real):
            if setup[w] == 1:
                continue
            for obj in order[~attempted[w, order]]:
                why = "removed with another object" if removed[w, obj] else "not visible"
                rows.append(_missing_row(self.job, scene, seed, padded[w], obj, why))
        return rows, timings


@functools.lru_cache(maxsize=16)
def round_runner(job: Job, config: Config) -> RoundRunner:
    """The shared compiled procedure of a job and configuration."""
    return RoundRunner(job, config)


def _base_row(job: Job, scene, seed: int, world, obj: int) -> dict:
    setup, trial = world
    return {"setup": int(setup), "object": scene.letters[obj], "trial": int(trial),
            "round": int(trial), "seed": seed,
            "scene": "".join(scene.letters), "objects": "".join(job.objects)}


def _row(job, scene, seed, world, k, obj, result, w, host) -> dict:
    """One attempt's row; `host` holds the perception arrays (world axis) in NumPy."""
    detect_reason, align_reason = int(host["detect_reason"][w]), int(host["align_reason"][w])
    found = bool(host["found"][w])
    outcome = Outcome(int(result.outcome[w]))
    if outcome != Outcome.NOT_EXECUTED:
        reason = outcome.name
    elif host["blocked"][w] and align_reason not in (-1, AlignReason.FOUND):
        reason = f"alignment: {AlignReason(align_reason).name}"
    elif host["blocked"][w]:
        reason = "alignment: view not reachable"
    else:
        reason = f"detection: {GraspReason(detect_reason).name}"
    lifted = int(result.lifted_object[w])
    row = _base_row(job, scene, seed, world, obj)
    row.update({
        "attempt": k, "success": int(outcome == Outcome.SUCCESS), "outcome": outcome.name,
        "reason": reason, "reorientations": int(host["reorientations"][w]),
        "grasp_found": int(found), "detect_reason": GraspReason(detect_reason).name,
        "align_reason": AlignReason(align_reason).name if align_reason >= 0 else "",
        "lifted_object": scene.letters[lifted] if lifted >= 0 else "",
        "rise_m": float(result.rise[w]), "jaw_opening_m": 2 * float(result.opening[w]),
    })
    pose = host["pose"]
    for name in ("tcp", "approach", "closing"):
        for i, axis in enumerate("xyz"):
            row[f"grasp_{name}_{axis}"] = float(getattr(pose, name)[w, i]) if found else float("nan")
    return row


def _missing_row(job, scene, seed, world, obj, why) -> dict:
    row = _base_row(job, scene, seed, world, obj)
    row.update({"attempt": -1, "success": 0, "outcome": Outcome.NOT_EXECUTED.name,
                "reason": f"not attempted: {why}", "reorientations": 0, "grasp_found": 0,
                "detect_reason": "", "align_reason": "", "lifted_object": "",
                "rise_m": float("nan"), "jaw_opening_m": float("nan")})
    for name in ("tcp", "approach", "closing"):
        for axis in "xyz":
            row[f"grasp_{name}_{axis}"] = float("nan")
    return row


def run_jobs(jobs: list[Job], config: Config, seed: int, batch: int | None = None,
             progress: Callable[[int], None] = lambda n: None,
             log: Callable[[str], None] = lambda m: None) -> tuple[list[dict], list[dict]]:
    """Run every job in chunks of `batch` worlds; returns attempt rows and per-chunk timings."""
    rows, timings = [], []
    for j, job in enumerate(jobs):
        worlds = job.worlds
        size = batch or default_batch(len(worlds))
        log(f"job {j + 1}/{len(jobs)}: objects {''.join(job.objects)}, setups "
            f"{','.join(map(str, job.setups))}, {job.trials} trials -> {len(worlds)} worlds "
            f"in batches of {size}")
        runner = round_runner(job, config)
        for c in range(0, len(worlds), size):
            start = time.perf_counter()
            chunk_rows, phases = runner.run_chunk(worlds[c:c + size], size, seed, progress)
            chunk_id = len(timings)
            for row in chunk_rows:
                row["chunk"] = chunk_id
            rows += chunk_rows
            timings.append({"chunk": chunk_id, "job": j, "worlds": len(worlds[c:c + size]),
                            "batch": size, "attempts": len(chunk_rows),
                            "wall_s": time.perf_counter() - start, **phases})
    return rows, timings
