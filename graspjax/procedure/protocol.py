"""The experimenter's protocol around the attempts: a round's layout placed and settled, which
objects are still to be attempted, when the round goes on, the keys of each attempt."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from graspjax.config import Config
from graspjax.procedure.state import RoundState, WorldSpec
from graspjax.sim import layout
from graspjax.sim.objects import LETTER_INDEX
from graspjax.sim.pile import Drops, Walls, no_drops
from graspjax.sim.scene import Scene, mjx
from graspjax.sim.world import GraspPose, physics_model, reset, simulate


def in_bin(spec: WorldSpec) -> jax.Array:
    """() bool: this world's objects lie in the bin (Setup 3 with `layout.bin`); else on the
    open table."""
    return (spec.setup == 3) & spec.config.layout.bin


def _layout_key(scene: Scene, spec: WorldSpec) -> jax.Array:
    """Setup 1: key(seed, 1, object letter, trial); Setups 2, 3: key(seed, setup, round)."""
    letter = jnp.asarray([LETTER_INDEX[c] for c in scene.letters], jnp.int32)[spec.order[0]]
    single = layout.layout_key(spec.seed, 1, letter, spec.trial)
    pile = layout.layout_key(spec.seed, spec.setup, spec.trial)
    return jnp.where(spec.setup == 1, jax.random.key_data(single), jax.random.key_data(pile))


def start_round(scene: Scene, data: mjx.Data, spec: WorldSpec,
                setups: tuple[int, ...] = (1, 2, 3)) -> RoundState:
    """Place the round's layout (not yet settled): one object dropped alone (Setup 1), a group
    of resting objects (Setup 2) or a pile whose objects wait to be dropped one at a time as
    it settles (Setup 3: `RoundState.drops`; the bin's walls standing in its variant). `setups`
    (static) are those the batch's worlds may play: only their layouts are built."""
    config = spec.config
    key = jax.random.wrap_key_data(_layout_key(scene, spec))
    n = scene.num_objects
    points = jnp.asarray(scene.object_points, jnp.float32)
    resting = jnp.asarray(scene.resting, jnp.float32)
    cfg = config.layout
    samplers = {
        1: lambda: layout.single(key, spec.order[0], points, cfg),
        2: lambda: layout.grouped(key, resting, points, cfg)[:3],
        3: lambda: jax.tree.map(
            lambda *both: jnp.where(cfg.bin, *both), layout.in_bin(key, points, cfg),
            layout.grouped(key, resting, points, cfg, cfg.pile_gap_min, cfg.pile_gap_max))}
    placed = {s: samplers[s]() for s in sorted(set(setups))}
    others = list(placed)[:-1]  # each picked where the world plays it; else the last
    pos, quat = jax.tree.map(
        lambda *poses: jnp.select([spec.setup == s for s in others], poses[:-1], poses[-1])
        if others else poses[0], *(placed[s][:2] for s in placed))
    active = jnp.where(spec.setup == 1, placed[1][2], spec.members) if 1 in placed else spec.members
    pile = spec.setup == 3
    drops = _drops(pos, quat, placed[3][3], spec) if 3 in placed else no_drops(n)
    drops = dataclasses.replace(drops, segment=jnp.where(pile, drops.segment, -1))
    walls = Walls(cfg.bin_size, cfg.bin_wall_height, in_bin(spec))
    data = reset(scene, data, pos, quat, active & ~pile, walls)  # a pile's objects wait to drop
    return RoundState(data=data, attempted=jnp.zeros(n, bool), failures=jnp.int32(0),
                      removed=jnp.zeros(n, bool), key=key, drops=drops)


def _drops(pos: jax.Array, quat: jax.Array, order: jax.Array, spec: WorldSpec) -> Drops:
    """Setup 3: the layout's members dropped one at a time in `order`, one every
    `sim.drop_interval` seconds, each at its layout's place and orientation; on the table
    pushed together toward their centre until `sim.push_time`, the push fading out over its
    last `sim.push_fade_time` (`pile.Drops`)."""
    n = order.shape[0]
    config = spec.config
    turn = jnp.cumsum(spec.members[order]) - 1  # the i-th member of the layout dropped
    interval = config.sim.segments(config.sim.drop_interval)
    segment = jnp.zeros(n, jnp.int32).at[order].set((turn * interval).astype(jnp.int32))
    members = spec.members[:, None]
    centre = jnp.sum(jnp.where(members, pos[:, :2], 0.0), 0) / jnp.maximum(jnp.sum(members), 1)
    return Drops(segment=jnp.where(spec.members, segment, -1), xy=pos[:, :2], quat=quat,
                 centre=centre, push=jnp.where(in_bin(spec), 0.0, config.layout.pile_push),
                 push_until=jnp.int32(config.sim.segments(config.sim.push_time)),
                 push_fade=jnp.int32(config.sim.segments(config.sim.push_fade_time)))


def settle_segments(spec: WorldSpec, k: jax.Array, config: Config) -> jax.Array:
    """Segments this world settles after call k: the drop (k = -1), else until the next attempt."""
    s = config.sim
    extra = jnp.select([spec.setup == 1, spec.setup == 2],
                       [s.segments(s.drop_settle_time), s.segments(s.group_settle_time)],
                       s.segments(s.pile_settle_time))
    between = jnp.where(k + 1 < spec.order.shape[0], s.segments(s.settle_time), 0)
    return jnp.where(k < 0, s.segments(s.settle_time) + extra, between).astype(jnp.int32)


def drops_of(state: RoundState, k: jax.Array) -> Drops:
    """What call k drops while it settles: the pile's objects in call -1, else nothing."""
    return dataclasses.replace(state.drops, segment=jnp.where(k < 0, state.drops.segment, -1))


def settle(scene: Scene, state: RoundState, spec: WorldSpec) -> RoundState:
    """Call -1 alone, for studies that look without grasping: the freshly placed layout settles
    exactly as `attempt(..., k=-1)` settles it, without compiling the search."""
    config = spec.config
    zero3 = jnp.zeros(3, jnp.float32)
    k = jnp.int32(-1)
    data, _ = simulate(scene, physics_model(scene, config), state.data,
                       GraspPose(zero3, zero3, zero3, jnp.array(False)), jnp.int32(0),
                       settle_segments(spec, k, config), jnp.array(False), config,
                       reachable=jnp.array(False), drops=drops_of(state, k))
    return dataclasses.replace(state, data=data)


def eligible_objects(state: RoundState, spec: WorldSpec) -> jax.Array:
    """The objects (n,) bool the oracle (`perception.oracle`) may pick by identity: the paper's
    protocol, those of the layout not yet attempted nor removed; a continued round
    (`procedure.round_attempts`), any still in the scene, none once it is stuck."""
    present = spec.members & ~state.removed
    if spec.config.procedure.round_attempts == 0:
        return present & ~state.attempted
    return present & (state.failures < spec.config.procedure.stuck_after)


def round_goes_on(state: RoundState, spec: WorldSpec) -> jax.Array:
    """The protocol lets the next attempt happen () bool: an object is still in the scene (and,
    in a continued round, the round is not stuck: `eligible_objects`). The experimenter sees
    the scene; the method is told nothing of it."""
    if spec.config.procedure.round_attempts == 0:
        return jnp.any(spec.members & ~state.removed)
    return jnp.any(eligible_objects(state, spec))


def attempt_keys(state: RoundState, k) -> tuple[jax.Array, jax.Array]:
    """Attempt k's keys: its search (images, planes) and its execution error."""
    return jax.random.split(jax.random.fold_in(state.key, 1000 + k))
