"""How far MJX's Newton solver is from converged after k iterations, on the states a run meets.

    python3 experiments/solver_convergence.py [WORLDS]

States (the bin scene, a-f in Setup 3, `bench.physics_workload`, WORLDS worlds, default 8):

- `pile`: the dropped pile after `sim.pile_settle_time`;
- `squeeze`: a top-down grasp over each world's first object, the jaws closed for
  `sim.close_time`, then the hand raised halfway to the lifted pose in one segment and held
  there until half of `sim.lift_time` has passed (the grip carries the object: the state
  whose friction decides an attempt's outcome).

Each state is solved again (`mjx.forward`, warm-started from the step before, as in a run)
with k solver iterations, k = 1 ... 8, and against a reference of 100 iterations with 50
line-search steps. Printed per k: the relative error of the accelerations
(|qacc_k - qacc_ref| / |qacc_ref|, median and maximum over worlds) and of the hand's total
contact normal force. Runs on the CPU in a few minutes.
"""

import sys

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.bench import physics_workload
from graspjax.config import Config
from graspjax.sim.scene import CLOSED_TARGET, mjx
from graspjax.sim.world import (
    GraspPose,
    Reflex,
    hand_contact_force,
    hand_waypoints,
    move_hand,
    physics_model,
    segment,
    with_parking,
)


def states(worlds: int, config: Config):
    """The pile and squeeze states (mjx.Data, batched over worlds) and the batch's models."""
    s = config.sim
    work = physics_workload("abcdef", 3, worlds, config)
    scene, spec, zero = work.scene, work.spec, work.zero
    pile, _ = work.simulate(work.data, spec, work.drops, work.idle, zero,
                            zero + s.segments(s.settle_time + s.pile_settle_time), False)
    first = jnp.asarray(np.asarray(spec.order)[:, 0])
    kin = jax.vmap(lambda d: mjx.kinematics(scene.model, d))(pile)
    centre = kin.xpos[jnp.arange(worlds), jnp.asarray(scene.object_body)[first]]
    opened = scene.gripper.opening / 2

    def squeeze(d, w, tcp):
        model = with_parking(scene, physics_model(scene, w.config), d)
        grasp = GraspPose(tcp=tcp + jnp.array([0.0, 0.0, 0.01]), approach=jnp.array([0.0, 0.0, -1.0]),
                          closing=jnp.array([1.0, 0.0, 0.0]), valid=jnp.array(True))
        points, quat = hand_waypoints(scene, grasp, w.config)
        d = move_hand(scene, d, points[1], quat, opened=True)
        reflex = Reflex(tripped=jnp.array(False), stop=points[1])
        for k in range(s.segments(s.close_time)):
            f0, f1 = k / s.segments(s.close_time), (k + 1) / s.segments(s.close_time)
            jaws = opened + (CLOSED_TARGET - opened) * jnp.array([f0, f1])
            d, reflex = segment(scene, model, d, points[1], points[1], quat, jaws, reflex,
                                jnp.array(False), 1e9)
        closed = jnp.full(2, CLOSED_TARGET)
        lift = points[1] + (points[2] - points[1]) * 0.5
        d, reflex = segment(scene, model, d, points[1], lift, quat, closed, reflex,
                            jnp.array(False), 1e9)  # raised halfway in one segment ...
        for _ in range(s.segments(s.lift_time) // 2 - 1):  # ... and held there
            d, reflex = segment(scene, model, d, lift, lift, quat, closed, reflex,
                                jnp.array(False), 1e9)
        return d

    held = jax.jit(jax.vmap(squeeze))(pile, spec, centre)
    models = jax.vmap(lambda d, w: with_parking(scene, physics_model(scene, w.config), d))
    return scene, {"pile": (pile, models(pile, spec)), "squeeze": (held, models(held, spec))}


def main() -> None:
    worlds = int(sys.argv[1]) if len(sys.argv) > 1 else 8
    config = Config()
    scene, found = states(worlds, config)
    print(f"{jax.devices()[0].device_kind}, jax {jax.__version__}, {worlds} worlds, "
          f"elliptic cone: {config.sim.cone == 'elliptic'}")

    def solved(model, d, iterations, ls_iterations):
        opt = model.opt.replace(iterations=iterations, ls_iterations=ls_iterations)
        d = mjx.forward(model.replace(opt=opt), d)
        return d.qacc, hand_contact_force(scene, d)

    for name, (data, models) in found.items():
        reference = jax.jit(jax.vmap(lambda m, d: solved(m, d, 100, 50)))(models, data)
        print(f"\n{name}: hand contact force (reference) median "
              f"{float(jnp.median(reference[1])):.2f} N, max {float(jnp.max(reference[1])):.2f} N")
        print(f"{'k':>3} {'qacc rel. error median':>23} {'max':>9} {'hand force rel. error max':>26}")
        for k in range(1, 9):
            qacc, force = jax.jit(jax.vmap(lambda m, d, k=k: solved(
                m, d, k, config.sim.ls_iterations)))(models, data)
            error = jnp.linalg.norm(qacc - reference[0], axis=-1) / jnp.linalg.norm(reference[0], axis=-1)
            force_error = jnp.abs(force - reference[1]) / jnp.maximum(reference[1], 1e-3)
            print(f"{k:>3} {float(jnp.median(error)):>23.2e} {float(jnp.max(error)):>9.2e} "
                  f"{float(jnp.max(force_error)):>26.2e}", flush=True)


if __name__ == "__main__":
    main()
